#include "mps/step/config.hpp"

#include <cmath>
#include <sstream>
#include <stdexcept>

namespace mps {
namespace {

std::string fmt(double v) {
  std::ostringstream s;
  s << v;
  return s.str();
}

}  // namespace

std::string range_text(double min, double max, bool min_open, bool max_open) {
  const bool low = std::isfinite(min), high = std::isfinite(max);
  if (low && high) return "in " + std::string(min_open ? "(" : "[") + fmt(min) + ", " + fmt(max) + (max_open ? ")" : "]");
  if (low) return min == 0 ? (min_open ? "positive" : ">= 0") : (min_open ? "> " : ">= ") + fmt(min);
  if (high) return (max_open ? "< " : "<= ") + fmt(max);
  return max_open ? "finite" : "";
}

bool in_range(double v, double min, double max, bool min_open, bool max_open) {
  if (std::isnan(v) || (std::isinf(v) && !(v == max && !max_open))) return false;
  return (min_open ? v > min : v >= min) && (max_open ? v < max : v <= max);
}

std::string pressure_treatment(const SimulationConfig& config) {
  std::string names;
  auto add = [&](bool on, const char* name) {
    if (!on) return;
    if (!names.empty()) names += '+';
    names += name;
  };
  add(config.higher_order_source, "hs");
  add(config.higher_order_laplacian, "hl");
  add(config.error_compensating_source, "ecs");
  add(config.continuous_free_surface, "cfs");
  add(config.pressure_gradient == GradientVariant::corrected, "gc");
  add(config.stabilisation_distance > 0.0, "ds");
  return names.empty() ? "none" : names;
}

void set_pressure_treatment(SimulationConfig& config, std::string_view names) {
  const std::string valid = "; valid: hs, hl, ecs, cfs, gc and ds joined by '+' (e.g. hs+hl+ecs), or none";
  bool hs = false, hl = false, ecs = false, cfs = false, gc = false, ds = false;
  if (names != "none") {
    std::size_t start = 0;
    while (true) {
      const std::size_t end = names.find('+', start);
      const std::string_view name = names.substr(start, end == std::string_view::npos ? end : end - start);
      bool* flag = name == "hs"    ? &hs
                   : name == "hl"  ? &hl
                   : name == "ecs" ? &ecs
                   : name == "cfs" ? &cfs
                   : name == "gc"  ? &gc
                   : name == "ds"  ? &ds
                                   : nullptr;
      if (!flag)
        throw std::invalid_argument("pressure treatment: unknown name '" + std::string(name) + "' in '" +
                                    std::string(names) + "'" + valid);
      if (*flag)
        throw std::invalid_argument("pressure treatment: '" + std::string(name) + "' given twice in '" +
                                    std::string(names) + "'" + valid);
      *flag = true;
      if (end == std::string_view::npos) break;
      start = end + 1;
    }
  }
  config.higher_order_source = hs;
  config.higher_order_laplacian = hl;
  config.error_compensating_source = ecs;
  config.continuous_free_surface = cfs;
  if (gc) config.pressure_gradient = GradientVariant::corrected;
  if (!ds) config.stabilisation_distance = 0.0;
  else if (!(config.stabilisation_distance > 0.0))
    config.stabilisation_distance = SimulationConfig::default_stabilisation_distance;
}

void SimulationConfig::validate() const {
  for_each_parameter([this]<class T>(const Parameter<T>& p) {
    if constexpr (std::is_same_v<T, double> || std::is_same_v<T, int>) {
      const double v = static_cast<double>(this->*p.member);
      if (!in_range(v, p.min, p.max, p.min_open, p.max_open))
        throw std::invalid_argument("simulation config: " + std::string(p.name) + " must be " +
                                    range_text(p.min, p.max, p.min_open, p.max_open) +
                                    (*p.unit ? " (in " + std::string(p.unit) + ")" : "") + ", got " + fmt(v) + " (" +
                                    p.doc + ")");
    }
  });
}

}  // namespace mps
