#pragma once
/// \file
/// The domain particles live in, in 2-D and 3-D: its extent, periodic axes, the minimum-image displacement.
#include <array>
#include <cmath>
#include <cstddef>

#include "mps/core/vec.hpp"

namespace mps {

/// The extent of a D-dimensional domain, by axis name (specialised for D = 2 and 3).
template <int D>
struct Extent;

/// [xmin, xmax] x [ymin, ymax], each axis closed or periodic.
template <>
struct Extent<2> {
  /// @{ extent [m]
  double xmin = 0, xmax = 0, ymin = 0, ymax = 0;  /// @}
  /// @{ whether an axis wraps around (period: its extent)
  bool periodic_x = false, periodic_y = false;  /// @}
  /// The lower and upper bounds and the periodicity, by axis.
  [[nodiscard]] std::array<double, 2> lower() const { return {xmin, ymin}; }
  [[nodiscard]] std::array<double, 2> upper() const { return {xmax, ymax}; }  ///< same, upper bounds
  [[nodiscard]] std::array<bool, 2> periodic() const { return {periodic_x, periodic_y}; }  ///< same, periodicity
};

/// [xmin, xmax] x [ymin, ymax] x [zmin, zmax], each axis closed or periodic.
template <>
struct Extent<3> {
  /// @{ extent [m]
  double xmin = 0, xmax = 0, ymin = 0, ymax = 0, zmin = 0, zmax = 0;  /// @}
  /// @{ whether an axis wraps around (period: its extent)
  bool periodic_x = false, periodic_y = false, periodic_z = false;  /// @}
  /// The lower and upper bounds and the periodicity, by axis.
  [[nodiscard]] std::array<double, 3> lower() const { return {xmin, ymin, zmin}; }
  [[nodiscard]] std::array<double, 3> upper() const { return {xmax, ymax, zmax}; }  ///< same, upper bounds
  [[nodiscard]] std::array<bool, 3> periodic() const { return {periodic_x, periodic_y, periodic_z}; }  ///< same
};

/// The region particles may occupy. A particle outside a non-periodic extent has escaped (the stability
/// guard reports it); a periodic axis wraps positions and measures distances by the minimum image.
template <int D>
struct BasicDomain : Extent<D> {
  /// The extent along axis d.
  [[nodiscard]] double extent(int d) const {
    return this->upper()[static_cast<std::size_t>(d)] - this->lower()[static_cast<std::size_t>(d)];
  }
  [[nodiscard]] double width() const { return this->xmax - this->xmin; }   ///< xmax - xmin
  [[nodiscard]] double height() const { return this->ymax - this->ymin; }  ///< ymax - ymin
  /// r_j - r_i, by the minimum image on periodic axes.
  [[nodiscard]] Vec<D> displacement(const Vec<D>& ri, const Vec<D>& rj) const {
    Vec<D> d;
    const auto periodic = this->periodic();
    for (std::size_t a = 0; a < D; ++a)
      d[a] = periodic[a] ? nearest_image(rj[a] - ri[a], extent(static_cast<int>(a))) : rj[a] - ri[a];
    return d;
  }
  /// 2-D: r_j - r_i from coordinates.
  [[nodiscard]] std::array<double, 2> displacement(double xi, double yi, double xj, double yj) const
    requires(D == 2)
  {
    return {this->periodic_x ? nearest_image(xj - xi, width()) : xj - xi,
            this->periodic_y ? nearest_image(yj - yi, height()) : yj - yi};
  }
  /// d - L round(d / L), rounding half to even; the comparisons settle the usual |d| < 1.5 L without a
  /// division (this sits in every pair loop of a periodic channel).
  [[nodiscard]] static double nearest_image(double d, double length) {
    const double half = 0.5 * length;
    if (d > half && d < 3.0 * half) return d - length;
    if (d < -half && d > -3.0 * half) return d + length;
    if (d >= -half && d <= half) return d;
    return d - length * std::nearbyint(d / length);
  }
  [[nodiscard]] bool contains(const Vec<D>& r) const;  ///< finite and inside the extent on non-periodic axes
  /// 2-D: the same for (x, y).
  [[nodiscard]] bool contains(double x, double y) const
    requires(D == 2)
  {
    return contains(Vec<2>{x, y});
  }
  void wrap(Vec<D>& r) const;  ///< into [min, max) on periodic axes
  /// 2-D: the same for (x, y).
  void wrap(double& x, double& y) const
    requires(D == 2);
  void validate() const;  ///< throws std::invalid_argument with the reason
};

/// r_j - r_i by the minimum image, with the domain's periodicity and periods read once: for pair loops, where
/// BasicDomain::displacement would read them for every pair. The same numbers.
template <int D>
class Displacement {
 public:
  /// Reads the domain's periodicity and periods.
  explicit Displacement(const BasicDomain<D>& domain) : periodic_(domain.periodic()) {
    for (std::size_t a = 0; a < D; ++a) length_[a] = domain.extent(static_cast<int>(a));
  }
  /// r_j - r_i
  [[nodiscard]] Vec<D> operator()(const Vec<D>& ri, const Vec<D>& rj) const {
    Vec<D> d;
    for (std::size_t a = 0; a < D; ++a)
      d[a] = periodic_[a] ? BasicDomain<D>::nearest_image(rj[a] - ri[a], length_[a]) : rj[a] - ri[a];
    return d;
  }

 private:
  std::array<bool, D> periodic_;
  Vec<D> length_;
};

using Domain = BasicDomain<2>;   ///< a 2-D domain
using Domain3 = BasicDomain<3>;  ///< a 3-D domain

extern template struct BasicDomain<2>;
extern template struct BasicDomain<3>;

}  // namespace mps
