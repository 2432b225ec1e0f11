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

  /// The weight at distance r (0 from re on).
  [[nodiscard]] double w(double r) const {
    if (r >= re) return 0.0;
    return weight == Weight::bounded ? re / (0.85 * r + 0.15 * re) - 1.0 : re / r - 1.0;
  }
};

/// The largest kernel radius, in l0, that make_kernel and SimulationConfig accept.
inline constexpr double kMaxRadius = 10.0;

/// A kernel of radius radius_over_l0 * l0 whose n0 and lambda are summed over the perfect square (dim 2) or cubic
/// (dim 3) lattice of spacing l0 around an interior particle; throws std::invalid_argument for a radius outside
/// (1, kMaxRadius] or a dimension other than 2 or 3.
Kernel make_kernel(double radius_over_l0, double l0, Weight weight = Weight::bounded, int dim = 2);

}  // namespace mps
