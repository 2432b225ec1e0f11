#pragma once
/// \file
/// Small fixed-size vector arithmetic for D = 2 and 3, each sum in axis order from its first term, so that a 2-D
/// result is the bits of the written-out dx * dx + dy * dy.
#include <array>
#include <cmath>
#include <cstddef>

namespace mps {

/// A point or vector of D components.
template <int D>
using Vec = std::array<double, D>;

/// a . b
template <int D>
[[nodiscard]] inline double dot(const Vec<D>& a, const Vec<D>& b) {
  double s = a[0] * b[0];
  for (std::size_t d = 1; d < D; ++d) s += a[d] * b[d];
  return s;
}

/// |a|^2
template <int D>
[[nodiscard]] inline double norm2(const Vec<D>& a) {
  return dot<D>(a, a);
}

/// |a| by std::hypot (no overflow or underflow in the squares)
template <int D>
[[nodiscard]] inline double norm(const Vec<D>& a) {
  if constexpr (D == 2) return std::hypot(a[0], a[1]);
  else return std::hypot(a[0], a[1], a[2]);
}

}  // namespace mps
