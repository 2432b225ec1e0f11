#pragma once
/// \file
/// MPS weight functions and the reference values n0 and lambda that normalise the operators.
#include <string_view>

namespace mps {

/// The MPS weight function w(r) for r < re.
enum class Weight {
  bounded,  ///< re / (0.85 r + 0.15 re) - 1: finite at r = 0 (seed 004, eq. 3); the default
  classic,  ///< re / r - 1 (Koshizuka & Oka 1996): singular at r = 0
};
Weight parse_weight(std::string_view name);  ///< "bounded" | "classic"
std::string_view to_string(Weight weight);  ///< the name parse_weight reads

/// A weight function at a radius, with its reference values on the perfect lattice (from make_kernel).
struct Kernel {
  Weight weight = Weight::bounded;  ///< which w(r)
  double re = 0;      ///< effective radius
  double n0 = 0;      ///< sum of w over the neighbours of an interior particle of the perfect lattice
  double lambda = 0;  ///< sum w r^2 / sum w on that lattice (Laplacian normalisation)
  int lattice_neighbors = 0;  ///< how many neighbours that interior particle has
  int dim = 2;        ///< the dimension of the lattice n0 and lambda were summed on
  double l0 = 0;      ///< the lattice's spacing
  /// Sum of -w'(r) r on that lattice: normalises the higher-order source (number_density_rate) into a divergence.
  double n_rate = 0;
  /// Sum of f(r) r^2 on that lattice, f the higher-order Laplacian's weight: normalises that Laplacian.
  double n_higher_order = 0;
  /// Sum of f(r) on that lattice: the higher-order Laplacian's weight over a full support.
  double n_higher_order_weight = 0;
  /// The Laplacian (PPE, laplacian operators) weighs pairs by higher_order_weight instead of w (Khayyer & Gotoh's
  /// higher-order Laplacian, normalised on the lattice: docs/pressure.md).
  bool higher_order_laplacian = false;

  /// The weight at distance r (0 from re on).
  [[nodiscard]] double w(double r) const {
    if (r >= re) return 0.0;
    return weight == Weight::bounded ? re / (0.85 * r + 0.15 * re) - 1.0 : re / r - 1.0;
  }
  /// w(r) as a product, without a branch: the same bits below re, +-0 from re on. A sum begun at +0 that adds every
  /// listed pair's term with it is the sum over w > 0, without a branch to mispredict where a list reaches past re.
  [[nodiscard]] double w_unbranched(double r) const {
    const double inside = (weight == Weight::bounded ? re / (0.85 * r + 0.15 * re) : re / r) - 1.0;
    return inside * (r < re ? 1.0 : 0.0);
  }
  /// dw/dr at distance r (0 from re on).
  [[nodiscard]] double dw(double r) const {
    if (r >= re) return 0.0;
    if (weight == Weight::classic) return -re / (r * r);
    const double s = 0.85 * r + 0.15 * re;
    return -0.85 * re / (s * s);
  }
  /// The higher-order Laplacian's weight f = w'' + (d - 3) w'/r (Khayyer & Gotoh 2010, 2012: 3 re/r^3 in 2-D and
  /// 2 re/r^3 in 3-D for the classic w), taken at max(r, l0/2): in 2-D f grows as 1/r even for the bounded w, and a
  /// pair pressed closer than half a spacing would otherwise dominate its row. 0 from re on.
  [[nodiscard]] double higher_order_weight(double r) const {
    if (r >= re) return 0.0;
    r = r > 0.5 * l0 ? r : 0.5 * l0;
    double d2w = 0.0;
    if (weight == Weight::classic) {
      d2w = 2.0 * re / (r * r * r);
    } else {
      const double s = 0.85 * r + 0.15 * re;
      d2w = 2.0 * 0.85 * 0.85 * re / (s * s * s);
    }
    return d2w + (dim - 3) * dw(r) / r;
  }
  /// The weight the Laplacian gives the pair at distance r.
  [[nodiscard]] double laplacian_weight(double r) const { return higher_order_laplacian ? higher_order_weight(r) : w(r); }
  /// The sum of laplacian_weight over a full support on the perfect lattice (n0 for the MPS Laplacian).
  [[nodiscard]] double laplacian_weight_sum() const { return higher_order_laplacian ? n_higher_order_weight : n0; }
  /// The factor of a d-dimensional Laplacian's sum: 2d/(lambda n0), or 2d/n_higher_order for the higher-order weight.
  /// Either makes the Laplacian exact for quadratics on the perfect lattice.
  [[nodiscard]] double laplacian_scale(int d) const {
    return higher_order_laplacian ? 2.0 * d / n_higher_order : 2.0 * d / (lambda * n0);
  }
};

/// The largest kernel radius, in l0, that make_kernel and SimulationConfig accept.
inline constexpr double kMaxRadius = 10.0;

/// A kernel of radius radius_over_l0 * l0 whose n0 and lambda are summed over the perfect square (dim 2) or cubic
/// (dim 3) lattice of spacing l0 around an interior particle; throws std::invalid_argument for a radius outside
/// (1, kMaxRadius] or a dimension other than 2 or 3.
Kernel make_kernel(double radius_over_l0, double l0, Weight weight = Weight::bounded, int dim = 2);

}  // namespace mps
