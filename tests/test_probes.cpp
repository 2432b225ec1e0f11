// Probes (mps/io/probes.hpp): each reading against a field or a layout whose answer is known by hand.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <random>
#include <string>

#include "mps/boundaries/geometry.hpp"
#include "mps/io/probes.hpp"
#include "mps/solids/fsi.hpp"
#include "mps/step/step.hpp"

namespace {

// A square lattice of fluid with a wall row below, pressure p = a + b x + c y on every particle.
mps::Particles linear_field(double l0, double a, double b, double c) {
  mps::Particles s;
  mps::fill_rectangle(s, {0.0, 0.0, 20 * l0, 20 * l0}, l0, mps::Kind::fluid);
  mps::add_rectangle_walls(s, {0.0, 0.0, 20 * l0, 20 * l0}, l0, mps::bottom, 1, 2);
  for (std::size_t i = 0; i < s.size(); ++i) {
    s.p[i] = a + b * s.x[i] + c * s.y[i];
    s.u[i] = 2.0 - 3.0 * s.y[i];
    s.v[i] = 0.5 * s.x[i];
  }
  return s;
}

// Kernel interpolation reads a constant field exactly anywhere (the weights are normalised), and a linear field
// exactly where the particles around the point are symmetric about it: a lattice point and a cell's corner. Dummies
// (pressure 1e9 here) are never read.
TEST(Probes, KernelInterpolationIsExactForConstantAndForLinearAtSymmetricPoints) {
  const double l0 = 0.01;
  const mps::Kernel kernel = mps::make_kernel(3.1, l0);
  mps::Particles constant = linear_field(l0, 1500.0, 0.0, 0.0);
  for (std::size_t i = 0; i < constant.size(); ++i)
    if (constant.kind[i] == mps::Kind::dummy) constant.p[i] = 1e9;
  for (const mps::Vec<2> at : {mps::Vec<2>{0.1003, 0.0511}, mps::Vec<2>{0.002, 0.001}, mps::Vec<2>{0.15, 0.19}})
    EXPECT_NEAR(mps::kernel_pressure<2>(constant, at, kernel), 1500.0, 1e-9);
  const mps::Particles linear = linear_field(l0, 1000.0, 2.0e4, -5.0e3);
  for (const mps::Vec<2> at : {mps::Vec<2>{0.105, 0.085}, mps::Vec<2>{0.1, 0.1}}) {
    EXPECT_NEAR(mps::kernel_pressure<2>(linear, at, kernel), 1000.0 + 2.0e4 * at[0] - 5.0e3 * at[1], 1e-9);
    const mps::Vec<2> u = mps::kernel_velocity<2>(linear, at, kernel);
    EXPECT_NEAR(u[0], 2.0 - 3.0 * at[1], 1e-12);
    EXPECT_NEAR(u[1], 0.5 * at[0], 1e-12);
  }
  // Far from any particle: the gauge pressure of air and no velocity.
  EXPECT_EQ(mps::kernel_pressure<2>(linear, {1.0, 1.0}, kernel), 0.0);
  EXPECT_EQ(mps::kernel_velocity<2>(linear, {1.0, 1.0}, kernel)[0], 0.0);
}

// The same in 3-D, on a cube of fluid with a linear field, at a lattice point in the middle.
TEST(Probes, KernelInterpolationIn3dIsExactForLinearAtALatticePoint) {
  const double l0 = 0.02;
  mps::Particles3 s;
  mps::fill_box(s, {0.0, 0.0, 0.0, 12 * l0, 12 * l0, 12 * l0}, l0, mps::Kind::fluid);
  for (std::size_t i = 0; i < s.size(); ++i) {
    s.p[i] = 100.0 + 10.0 * s.x[i] - 20.0 * s.y[i] + 30.0 * s.z[i];
    s.w[i] = s.x[i];
  }
  const mps::Vec<3> at{6.5 * l0, 5.5 * l0, 6.5 * l0};
  EXPECT_NEAR(mps::kernel_pressure<3>(s, at, mps::make_kernel(2.1, l0, mps::Weight::bounded, 3)),
              100.0 + 10.0 * at[0] - 20.0 * at[1] + 30.0 * at[2], 1e-10);
  EXPECT_NEAR(mps::kernel_velocity<3>(s, at, mps::make_kernel(2.1, l0, mps::Weight::bounded, 3))[2], at[0], 1e-12);
}

// A patch on a wall averages the wall and fluid particles within its reach across the wall and its size along it;
// dummies carry no pressure of their own; radius 0 is the disc of radius `reach`.
TEST(Probes, PatchPressureIsTheMeanOfTheWallAndFluidWithinThePatch) {
  mps::Particles s;
  s.add(0.0, 0.0, mps::Kind::wall);
  s.add(0.1, 0.0, mps::Kind::fluid);
  s.add(0.0, 0.3, mps::Kind::fluid);  // outside the disc
  s.add(0.0, 0.1, mps::Kind::dummy);  // dummies carry no pressure of their own
  s.p = {10.0, 20.0, 1000.0, 5000.0};
  EXPECT_DOUBLE_EQ(mps::patch_pressure<2>(s, {{0.0, 0.0}, 0, 0.2, 0.0}), 15.0);
  // A sensor 0.6 high reaching 0.2 from the wall line takes the fluid at (0, 0.3) too (the band is closed), and
  // leaves out what is further from the wall than 0.2 even within its height.
  s.add(0.25, 0.0, mps::Kind::fluid);
  s.p.back() = 7.0e4;
  EXPECT_DOUBLE_EQ(mps::patch_pressure<2>(s, {{0.0, 0.0}, 0, 0.2, 0.3}), (10.0 + 20.0 + 1000.0) / 3);
  // The face's edges along the wall cut the patch: below y = 0.05 nothing counts.
  EXPECT_DOUBLE_EQ(mps::patch_pressure<2>(s, {{0.0, 0.0}, 0, 0.2, 0.3, {-1.0, 0.05}, {1.0, 1.0}}), 1000.0);
  // A floor sensor (normal y) at x = 0.1 with half-width 0.05 holds the fluid at (0.1, 0) alone.
  EXPECT_DOUBLE_EQ(mps::patch_pressure<2>(s, {{0.1, 0.0}, 1, 0.2, 0.05}), 20.0);
  EXPECT_EQ(mps::patch_pressure<2>(s, {{5.0, 5.0}, 0, 0.2, 0.3}), 0.0);  // nothing there
}

// The free-surface level over a standing block is its height; a lone drop above it is not the surface; the dry floor
// reads 0. In 3-D the same over a point between four columns.
TEST(Probes, SurfaceLevelIsTheBlocksHeightAndIgnoresALoneDrop) {
  const double l0 = 0.01;
  mps::Particles s;
  mps::fill_rectangle(s, {0.0, 0.0, 0.2, 0.12}, l0, mps::Kind::fluid);
  mps::add_rectangle_walls(s, {0.0, 0.0, 0.5, 0.3}, l0, mps::left | mps::right | mps::bottom, 1, 2);
  s.add(0.1, 0.2, mps::Kind::fluid);
  EXPECT_NEAR(mps::water_level<2>(s, {0.1, 0.0}, l0), 0.12, 1e-12);
  EXPECT_EQ(mps::water_level<2>(s, {0.4, 0.0}, l0), 0.0);
  mps::Particles3 c;
  mps::fill_box(c, {0.0, 0.0, 0.0, 0.1, 0.1, 0.07}, l0, mps::Kind::fluid);
  c.add({0.05, 0.05, 0.2}, mps::Kind::fluid);
  EXPECT_NEAR(mps::water_level<3>(c, {0.05, 0.05, 0.0}, l0), 0.07, 1e-12);
}

// A gauge's wire reads the water standing on the floor under it, as a wave probe reads the wetted length of its
// wire: a column 6 spacings high reads its height whether or not a sheet of water flies 3 spacings above it, and a
// column jittered by up to 0.3 l0 reads its top particle's height; over a dry floor a sheet reads 0, and a one-layer
// film reads l0. The surface method reads the sheet. A floor raised by h moves the wire's reading by h.
TEST(Probes, WireLevelReadsTheWaterStandingOnTheFloorNotASheetAboveIt) {
  const double l0 = 0.05;
  const auto block = [&](mps::Particles3& s, double z0, int layers) {
    mps::fill_box(s, {0.0, 0.0, z0, 10 * l0, 10 * l0, z0 + layers * l0}, l0, mps::Kind::fluid);
  };
  const double x = 5 * l0, y = 5 * l0;  // between four columns of the lattice
  const auto wire = [&](const mps::Particles3& s, double floor = 0.0) {
    return mps::water_level<3>(s, {x, y, floor}, l0, mps::LevelMethod::wire);
  };
  mps::Particles3 column;
  block(column, 0.0, 6);
  EXPECT_NEAR(wire(column), 6 * l0, 1e-12);
  mps::Particles3 with_sheet = column;
  block(with_sheet, 9 * l0, 1);
  EXPECT_NEAR(wire(with_sheet), 6 * l0, 1e-12);
  EXPECT_NEAR(mps::water_level<3>(with_sheet, {x, y, 0.0}, l0), 10 * l0, 1e-12);
  mps::Particles3 jittered = column;
  std::mt19937 random(7);
  std::uniform_real_distribution<double> jitter(-0.3 * l0, 0.3 * l0);
  for (std::size_t i = 0; i < jittered.size(); ++i) jittered.z[i] += jitter(random);
  double top = 0.0;
  for (std::size_t i = 0; i < jittered.size(); ++i)
    if (std::hypot(jittered.x[i] - x, jittered.y[i] - y) < l0) top = std::max(top, jittered.z[i]);
  EXPECT_NEAR(wire(jittered), top + 0.5 * l0, 1e-12);
  mps::Particles3 sheet_only, film, raised;
  block(sheet_only, 9 * l0, 1);
  EXPECT_EQ(wire(sheet_only), 0.0);
  block(film, 0.0, 1);
  EXPECT_NEAR(wire(film), l0, 1e-12);
  block(raised, 0.3, 6);
  EXPECT_NEAR(wire(raised, 0.3), 0.3 + 6 * l0, 1e-12);
  EXPECT_EQ(wire(raised), 0.0);  // from a floor at 0 the water does not stand on it
}

TEST(Probes, LineAndPlanePointsSpanTheirEnds) {
  const auto line = mps::line_points<2>({0.0, 1.0}, {1.0, 3.0}, 5);
  ASSERT_EQ(line.size(), 5u);
  EXPECT_EQ(line.front(), (mps::Vec<2>{0.0, 1.0}));
  EXPECT_EQ(line.back(), (mps::Vec<2>{1.0, 3.0}));
  EXPECT_DOUBLE_EQ(line[1][1], 1.5);
  EXPECT_EQ(mps::line_points<2>({0.0, 1.0}, {1.0, 3.0}, 1).front(), (mps::Vec<2>{0.5, 2.0}));
  const auto plane = mps::plane_points<3>({0.0, 0.0, 1.0}, {2.0, 0.0, 0.0}, {0.0, 4.0, 0.0}, 3, 2);
  ASSERT_EQ(plane.size(), 6u);
  EXPECT_EQ(plane[1], (mps::Vec<3>{0.0, 4.0, 1.0}));  // j fastest
  EXPECT_EQ(plane[5], (mps::Vec<3>{2.0, 4.0, 1.0}));
  EXPECT_THROW(mps::line_points<2>({0.0, 0.0}, {1.0, 1.0}, 0), std::invalid_argument);
  EXPECT_THROW(mps::line_points<2>({0.0, NAN}, {1.0, 1.0}, 2), std::invalid_argument);
  EXPECT_THROW(mps::plane_points<3>({0.0, 0.0, 0.0}, {1.0, 0.0, 0.0}, {0.0, INFINITY, 0.0}, 2, 2),
               std::invalid_argument);
}

// Every bad probe or series is refused with a message naming the probe and the cause.
TEST(Probes, BadProbesAreRefusedByName) {
  const mps::Kernel kernel = mps::make_kernel(2.1, 0.01);
  auto refused = [](auto make, const std::string& words) {
    try {
      make();
    } catch (const std::invalid_argument& e) {
      EXPECT_NE(std::string(e.what()).find(words), std::string::npos) << e.what();
      return;
    }
    ADD_FAILURE() << "not refused: " << words;
  };
  refused([&] { return mps::pressure_probe<2>("p", {}, kernel); }, "no point");
  refused([&] { return mps::pressure_probe<2>("p", {{0.0, NAN}}, kernel); }, "non-finite");
  refused([&] { return mps::level_probe<2>("h", {{0.0, 0.0}}, 0.0); }, "spacing l0");
  refused([&] { return mps::patch_probe<2>("s", {{0.0, 0.0}}, {{}, 2, 0.1, 0.1}); }, "normal axis");
  refused([&] { return mps::patch_probe<2>("s", {{0.0, 0.0}}, {{}, 0, -0.1, 0.1}); }, "reach");
  refused([&] { return mps::ProbeSeries(-1.0); }, "interval");
  refused([&] { return mps::ProbeSeries(NAN); }, "interval");
  mps::ProbeSeries series(0.1);
  series.add(mps::pressure_probe<2>("p", {{0.0, 0.0}}, kernel));
  refused([&] { series.add(mps::pressure_probe<2>("p", {{1.0, 0.0}}, kernel)); }, "taken");
  refused([&] { series.add(mps::pressure_probe<2>("a,b", {{1.0, 0.0}}, kernel)); }, "name");
  refused([&] { series.add(mps::pressure_probe<2>("time", {{1.0, 0.0}}, kernel)); }, "first column");
  refused([&] { series.add({"custom", "pressure", {{0.0, 0.0}}, 1, {}}); }, "no read function");
  mps::Particles s;
  s.add(0.0, 0.0, mps::Kind::fluid);
  series.sample(0.0, s);
  refused([&] { series.sample(NAN, s); }, "non-finite");
  refused([&] { series.add(mps::pressure_probe<2>("q", {{1.0, 0.0}}, kernel)); }, "before the first sample");
  series.sample(0.2, s);
  refused([&] { series.sample(0.1, s); }, "before the last sample");
}

// Samples come at the first call and then at the first call on or after each mark (steps of 0.03 s against an
// interval of 0.1 s: 0, 0.12, 0.21, 0.3 (round-off within 1e-9 of the interval), ...); a step longer than the
// interval skips the marks it passed.
TEST(Probes, SeriesSamplesAtTheFirstCallOnOrAfterEachMark) {
  mps::Particles s;
  s.add(0.0, 0.0, mps::Kind::fluid);
  mps::ProbeSeries series(0.1);
  series.add({"count", "custom", {{0.0, 0.0}}, 1, [n = 0](const mps::Particles&, double* v) mutable { *v = ++n; }});
  std::vector<double> sampled;
  for (int k = 0; k <= 12; ++k)
    if (series.sample(0.03 * k, s)) sampled.push_back(0.03 * k);
  ASSERT_EQ(sampled.size(), 4u);
  EXPECT_DOUBLE_EQ(sampled[1], 0.12);
  EXPECT_DOUBLE_EQ(sampled[2], 0.21);
  EXPECT_NEAR(sampled[3], 0.3, 1e-15);
  EXPECT_TRUE(series.sample(0.95, s));   // past 0.4 ... 0.9
  EXPECT_FALSE(series.sample(0.99, s));  // the next mark is 1.0
  EXPECT_TRUE(series.sample(1.0, s));
  EXPECT_EQ(series.rows().back()[1], 6.0);  // the probe was read at every sample, and only then
  mps::ProbeSeries every;
  every.add({"one", "custom", {{0.0, 0.0}}, 1, [](const mps::Particles&, double* v) { *v = 1.0; }});
  for (int k = 0; k < 5; ++k) EXPECT_TRUE(every.sample(1e-3 * k, s));
}

// The CSV holds the columns named per point and component and the values read; a restored series continues as the
// uninterrupted one; a checkpoint of other probes is refused.
TEST(Probes, SeriesWritesItsCsvAndContinuesFromItsState) {
  const double l0 = 0.01;
  const mps::Particles s = linear_field(l0, 1000.0, 0.0, -9810.0);
  const mps::Kernel kernel = mps::make_kernel(2.1, l0);
  const auto make = [&] {
    mps::ProbeSeries series(0.05);
    series.add(mps::pressure_probe<2>("p", mps::line_points<2>({0.1, 0.05}, {0.1, 0.15}, 3), kernel));
    series.add(mps::velocity_probe<2>("u", {{0.105, 0.105}}, kernel));
    series.add(mps::level_probe<2>("h", {{0.1, 0.0}}, l0));
    return series;
  };
  mps::ProbeSeries whole = make(), first = make();
  EXPECT_EQ(whole.columns(), (std::vector<std::string>{"time", "p[0]", "p[1]", "p[2]", "u.x", "u.y", "h"}));
  for (int k = 0; k < 10; ++k) whole.sample(0.02 * k, s);
  for (int k = 0; k < 5; ++k) first.sample(0.02 * k, s);
  const nlohmann::json state = nlohmann::json::from_cbor(nlohmann::json::to_cbor(first.save_state()), true, true,
                                                             nlohmann::json::cbor_tag_handler_t::store);
  mps::ProbeSeries second = make();
  second.restore_state(state);
  for (int k = 5; k < 10; ++k) second.sample(0.02 * k, s);
  EXPECT_EQ(second.rows(), whole.rows());
  ASSERT_EQ(whole.rows().size(), 4u);  // 0, 0.06, 0.1, 0.16
  EXPECT_NEAR(whole.rows()[0][2], 1000.0 - 9810.0 * 0.1, 1e-9);
  EXPECT_NEAR(whole.rows()[0][6], 0.2, 1e-12);
  const std::filesystem::path path = std::filesystem::temp_directory_path() / "sparsemps_probes_test.csv";
  whole.write_csv(path);
  std::ifstream in(path);
  std::string header, row;
  std::getline(in, header);
  std::getline(in, row);
  EXPECT_EQ(header, "time,p[0],p[1],p[2],u.x,u.y,h");
  EXPECT_EQ(row.substr(0, 2), "0,");
  std::filesystem::remove(path);
  mps::ProbeSeries other(0.05);
  other.add(mps::level_probe<2>("h", {{0.1, 0.0}}, l0));
  EXPECT_THROW(other.restore_state(state), std::runtime_error);
  EXPECT_EQ(whole.describe()["probes"][0]["quantity"], "pressure");
}

// A force probe reads WallForce's last force at every sample: on a block held in still water (group 2: its faces
// wall particles, its inside dummies), Archimedes' rho g V upwards within a few per cent over 20 steps (the FSI tests
// measure it to 0.3 %), and no sideways force by the tank's symmetry.
TEST(Probes, ForceProbeReadsTheWallGroupsForce) {
  const double l0 = 0.01, side = 0.1;
  mps::Particles s;
  for (int j = 0; j < 30; ++j)
    for (int i = 0; i < 40; ++i) {
      const double x = (i + 0.5) * l0, y = (j + 0.5) * l0;
      const bool in_block = std::abs(x - 0.2) < 0.5 * side && std::abs(y - 0.15) < 0.5 * side;
      const bool face = std::abs(x - 0.2) > 0.5 * side - l0 || std::abs(y - 0.15) > 0.5 * side - l0;
      s.add(x, y, !in_block ? mps::Kind::fluid : face ? mps::Kind::wall : mps::Kind::dummy, in_block ? 2 : 0);
    }
  mps::add_rectangle_walls(s, {0.0, 0.0, 0.4, 0.5}, l0, mps::left | mps::right | mps::bottom, 1, 4);
  mps::SimulationConfig c;
  c.l0 = l0;
  c.fy = -9.81;
  c.gamma = 0.01;
  c.dt_max = 1e-3;
  c.hydrostatic_split = false;  // the force needs the whole pressure
  mps::Simulation sim(s, mps::Domain{-0.1, 0.5, -0.1, 0.7}, c);
  auto& block = sim.add<mps::WallForce>(2);
  mps::ProbeSeries series;
  series.add(mps::force_probe("block", block));
  double fx = 0.0, fy = 0.0;
  for (int k = 0; k < 20; ++k) {
    sim.step();
    series.sample(sim.time(), sim.particles());
    EXPECT_EQ(series.rows().back()[1], block.force()[0]);
    EXPECT_EQ(series.rows().back()[2], block.force()[1]);
    fx += series.rows().back()[1] / 20;
    fy += series.rows().back()[2] / 20;
  }
  EXPECT_EQ(series.columns(), (std::vector<std::string>{"time", "block.x", "block.y"}));
  const double archimedes = 1000.0 * 9.81 * side * side;
  EXPECT_NEAR(fy / archimedes, 1.0, 0.03);
  EXPECT_NEAR(fx / archimedes, 0.0, 1e-3);
}

}  // namespace
