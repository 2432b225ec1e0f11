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
