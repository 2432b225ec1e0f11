#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <set>
#include <stdexcept>
#include <string>
#include <type_traits>

#include "mps/io/io.hpp"
#include "mps/step/config.hpp"

// The schema is the one list of SimulationConfig's fields: validation walks it. Every number field set just outside
// its range, to NaN, and to infinity where that is outside, is refused with a message naming the field; its default
// and its range's included ends are accepted (dt_max and l0 have no default, so a valid value is set first).
TEST(ConfigSchema, EveryNumberOutsideItsRangeIsRefusedNamingTheField) {
  mps::SimulationConfig valid;
  valid.l0 = 0.01;
  valid.dt_max = 1e-3;
  ASSERT_NO_THROW(valid.validate());
  int numbers = 0;
  mps::for_each_parameter([&]<class T>(const mps::Parameter<T>& p) {
    if constexpr (std::is_same_v<T, double> || std::is_same_v<T, int>) {
      ++numbers;
      auto refused = [&](double value) {
        mps::SimulationConfig c = valid;
        c.*p.member = static_cast<T>(value);
        try {
          c.validate();
        } catch (const std::invalid_argument& e) {
          const std::string what = e.what();
          EXPECT_EQ(what.find(std::string(p.name) + " must be "), std::string("simulation config: ").size()) << what;
          return true;
        }
        return false;
      };
      auto accepted = [&](double value) { return !refused(value); };
      EXPECT_TRUE(accepted(static_cast<double>(valid.*p.member))) << p.name;
      if (std::isfinite(p.min)) {
        EXPECT_TRUE(refused(p.min_open ? p.min : p.min - 1)) << p.name;
        if (!p.min_open) {
          EXPECT_TRUE(accepted(p.min)) << p.name;
        }
      }
      if (std::isfinite(p.max)) {
        EXPECT_TRUE(refused(p.max_open ? p.max : p.max + 1)) << p.name;
        if (!p.max_open) {
          EXPECT_TRUE(accepted(p.max)) << p.name;
        }
      }
      if constexpr (std::is_same_v<T, double>) {
        EXPECT_TRUE(refused(std::nan(""))) << p.name;
        const bool infinity_allowed = std::isinf(p.max) && !p.max_open;
        EXPECT_EQ(refused(std::numeric_limits<double>::infinity()), !infinity_allowed) << p.name;
      }
    }
  });
  EXPECT_EQ(numbers, 23);  // the 22 doubles and reorder_every
}

// The summaries record the config from the same list: one key per field, each ending in its unit, with the field's
// value; changing a field changes its key's value and only that.
TEST(ConfigSchema, TheSummarysConfigHoldsEveryFieldWithItsUnit) {
  mps::SimulationConfig c;
  c.l0 = 0.02;
  c.fz = -9.81;
  c.solver = "hypre-pcg";
  const nlohmann::json j = mps::config_json(c);
  int fields = 0;
  std::set<std::string> names;
  mps::for_each_parameter([&]<class T>(const mps::Parameter<T>& p) {
    ++fields;
    EXPECT_TRUE(names.insert(p.name).second) << "two fields named " << p.name;
  });
  EXPECT_EQ(j.size(), static_cast<std::size_t>(fields));
  EXPECT_EQ(j.at("l0_m"), 0.02);
  EXPECT_EQ(j.at("fz_m_per_s2"), -9.81);
  EXPECT_EQ(j.at("radius_laplacian_l0"), 4.1);
  EXPECT_EQ(j.at("nu_m2_per_s"), 1e-6);
  EXPECT_EQ(j.at("rho_kg_per_m3"), 1000.0);
  EXPECT_EQ(j.at("reorder_every_steps"), 20);
  EXPECT_EQ(j.at("gamma"), 0.99);
  EXPECT_EQ(j.at("solver"), "hypre-pcg");
  EXPECT_EQ(j.at("weight"), "bounded");
  EXPECT_EQ(j.at("pressure_gradient"), "min-reference");
  EXPECT_EQ(j.at("warm_start"), true);
  EXPECT_EQ(j.at("max_speed"), "off");  // infinity: no guard; JSON has no infinity
  c.max_speed = 5;
  EXPECT_EQ(mps::config_json(c).at("max_speed_m_per_s"), 5.0);
}
