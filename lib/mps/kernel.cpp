#include "mps/kernel.hpp"

#include <cmath>
#include <stdexcept>
#include <string>

namespace mps {

Weight parse_weight(std::string_view name) {
  if (name == "bounded") return Weight::bounded;
  if (name == "classic") return Weight::classic;
  throw std::invalid_argument("unknown weight '" + std::string(name) + "'; valid: bounded, classic");
}

std::string_view to_string(Weight weight) { return weight == Weight::bounded ? "bounded" : "classic"; }

Kernel make_kernel(double radius_over_l0, double l0, Weight weight) {
  if (!(l0 > 0.0) || !std::isfinite(l0))
    throw std::invalid_argument("kernel: particle spacing l0 must be positive, got " + std::to_string(l0));
  if (!(radius_over_l0 > 1.0) || !std::isfinite(radius_over_l0))
    throw std::invalid_argument("kernel: radius must exceed one particle spacing (re/l0 > 1), got " +
                                std::to_string(radius_over_l0));
  Kernel k{weight, radius_over_l0 * l0, 0.0, 0.0, 0};
  const int n = static_cast<int>(std::ceil(radius_over_l0));
  double sum_w = 0.0, sum_wr2 = 0.0;
  for (int j = -n; j <= n; ++j)
    for (int i = -n; i <= n; ++i) {
      if (i == 0 && j == 0) continue;
      const double r = l0 * std::hypot(i, j);
      const double w = k.w(r);
      k.lattice_neighbors += w > 0.0;
      sum_w += w;
      sum_wr2 += w * r * r;
    }
  k.n0 = sum_w;
  k.lambda = sum_wr2 / sum_w;
  return k;
}

}  // namespace mps
