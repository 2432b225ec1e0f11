#include "mps/core/kernel.hpp"

#include <cmath>
#include <sstream>
#include <stdexcept>
#include <string>

namespace mps {

Weight parse_weight(std::string_view name) {
  if (name == "bounded") return Weight::bounded;
  if (name == "classic") return Weight::classic;
  throw std::invalid_argument("unknown weight '" + std::string(name) + "'; valid: bounded, classic");
}

std::string_view to_string(Weight weight) { return weight == Weight::bounded ? "bounded" : "classic"; }

Kernel make_kernel(double radius_over_l0, double l0, Weight weight, int dim) {
  if (dim != 2 && dim != 3) throw std::invalid_argument("kernel: the dimension must be 2 or 3, got " + std::to_string(dim));
  if (!(l0 > 0.0) || !std::isfinite(l0))
    throw std::invalid_argument("kernel: particle spacing l0 must be positive, got " + std::to_string(l0));
  // Above 10 l0 the lattice sums below and every neighbour list grow past use (1e6 l0 would never return).
  if (!(radius_over_l0 > 1.0 && radius_over_l0 <= kMaxRadius)) {
    std::ostringstream message;
    message << "kernel: radius re/l0 = " << radius_over_l0 << " is outside (1, " << kMaxRadius
            << "]; choose a radius in that range (the usual ones are 2.1 to 4.1)";
    throw std::invalid_argument(message.str());
  }
  Kernel k;
  k.weight = weight;
  k.re = radius_over_l0 * l0;
  k.dim = dim;
  k.l0 = l0;
  const int n = static_cast<int>(std::ceil(radius_over_l0));
  const int nz = dim == 3 ? n : 0;
  double sum_w = 0.0, sum_wr2 = 0.0, sum_rate = 0.0, sum_higher_order = 0.0, sum_higher_order_weight = 0.0;
  for (int c = -nz; c <= nz; ++c)
    for (int j = -n; j <= n; ++j)
      for (int i = -n; i <= n; ++i) {
        if (i == 0 && j == 0 && c == 0) continue;
        const double r = l0 * (dim == 2 ? std::hypot(i, j) : std::hypot(i, j, c));
        const double w = k.w(r);
        k.lattice_neighbors += w > 0.0;
        sum_w += w;
        sum_wr2 += w * r * r;
        sum_rate -= k.dw(r) * r;
        sum_higher_order += k.higher_order_weight(r) * r * r;
        sum_higher_order_weight += k.higher_order_weight(r);
      }
  k.n0 = sum_w;
  k.lambda = sum_wr2 / sum_w;
  k.n_rate = sum_rate;
  k.n_higher_order = sum_higher_order;
  k.n_higher_order_weight = sum_higher_order_weight;
  return k;
}

}  // namespace mps
