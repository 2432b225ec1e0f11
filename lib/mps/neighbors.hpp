#pragma once
/// \file
/// The domain, and neighbour search on a uniform cell grid producing CSR neighbour lists (one per radius), in 2-D and
/// 3-D.
#include <algorithm>
#include <array>
#include <cmath>
#include <span>
#include <vector>

#include "mps/particles.hpp"

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

/// Neighbours in CSR form: those of particle i are index[offsets[i] .. offsets[i+1]), sorted ascending, i itself
/// excluded.
struct NeighborList {
  double radius = 0;            ///< the search radius [m]
  std::vector<int> offsets{0};  ///< particles() + 1 entries
  std::vector<int> index;       ///< neighbour indices, row after row

  /// The neighbours of particle i.
  [[nodiscard]] std::span<const int> of(std::size_t i) const {
    return {index.data() + offsets[i], static_cast<std::size_t>(offsets[i + 1] - offsets[i])};
  }
  [[nodiscard]] std::size_t particles() const { return offsets.size() - 1; }  ///< rows of the list
  [[nodiscard]] std::size_t pairs() const { return index.size(); }  ///< entries, each pair counted from both sides
};

/// Bins the active (non-ghost) particles into square (cubic) cells at least half of `cell_size` wide; one binning
/// serves every radius up to cell_size. The binned coordinates are kept in cell order, so a search scans a few
/// contiguous runs of memory (one per row of cells along x) instead of chasing particle indices.
template <int D>
class BasicCellGrid {
 public:
  BasicCellGrid(const BasicDomain<D>& domain, double cell_size);  ///< an empty grid; throws for a bad domain or size
  void bin(const BasicParticles<D>& particles);  ///< sorts the particles' current positions into the cells
  /// `particles` must be those last passed to bin(), not moved since.
  [[nodiscard]] NeighborList neighbors(const BasicParticles<D>& particles, double radius) const;
  /// Same, refilling `out` in place: a time loop that keeps its lists reuses their memory instead of having
  /// the kernel hand out (and zero) fresh pages every step.
  void neighbors(const BasicParticles<D>& particles, double radius, NeighborList& out) const;
  /// One search filling the lists of two radii, `inner` for inner_radius <= radius: cheaper than searching
  /// once and restricting the list.
  void neighbors(const BasicParticles<D>& particles, double radius, NeighborList& out, double inner_radius,
                 NeighborList& inner) const;
  /// A permutation putting particles in cell order (ghosts last): applying it with Particles::permute makes
  /// neighbours close in memory, which every sparse kernel and incomplete factorisation profits from.
  [[nodiscard]] std::vector<int> cell_order() const;
  [[nodiscard]] double cell_size() const { return cell_size_; }  ///< the largest radius a search may use
  /// Calls f(j, d) for every binned particle j closer than radius (<= cell size) to the point r, with d = r_j - r
  /// by the minimum image.
  template <class F>
  void for_each_near(Vec<D> r, double radius, F&& f) const {
    domain_.wrap(r);
    const double r2 = radius * radius;
    for_each_run(r, radius, [&](int begin, int end, const Vec<D>& shift) {
      for (int k = begin; k < end; ++k) {
        const auto kk = static_cast<std::size_t>(k);
        Vec<D> d;
        for (std::size_t a = 0; a < D; ++a) d[a] = coords_[a][kk] + shift[a] - r[a];
        if (norm2(d) < r2) f(ids_[kk], d);
      }
    });
  }
  /// 2-D: calls f(j, dx, dy) for every binned particle j closer than radius to (x, y).
  template <class F>
  void for_each_near(double x, double y, double radius, F&& f) const
    requires(D == 2)
  {
    for_each_near(Vec<2>{x, y}, radius, [&](int j, const Vec<2>& d) { f(j, d[0], d[1]); });
  }

 private:
  static double norm2(const Vec<D>& d) {
    double s = d[0] * d[0];
    for (std::size_t a = 1; a < D; ++a) s += d[a] * d[a];
    return s;
  }
  void search(const BasicParticles<D>& particles, double radius, NeighborList& list, NeighborList* inner) const;
  // The cell-ordered runs [begin, end) along x that hold every binned particle within radius of r (wrapped into the
  // domain), each with the shift that turns its coordinates into the nearest periodic image.
  template <class Run>
  void for_each_run(const Vec<D>& r, double radius, Run&& run) const {
    const auto lower = domain_.lower();
    const auto periodic = domain_.periodic();
    std::array<std::array<int, 2>, D> range;
    for (std::size_t a = 0; a < D; ++a) range[a] = span(r[a] - lower[a], radius, h_[a], n_[a], periodic[a]);
    if constexpr (D == 2) {  // the rows of a plane, without the general odometer below
      const int nx = n_[0], ny = n_[1];
      for (int ky = range[1][0]; ky <= range[1][1]; ++ky) {
        const int row = ky < 0 ? ky + ny : ky >= ny ? ky - ny : ky;
        const double sy = ky < 0 ? -domain_.extent(1) : ky >= ny ? domain_.extent(1) : 0.0;
        const auto row_run = [&](int x0, int x1, double sx) {  // cells x0..x1 of the row are contiguous
          run(cell_start_[static_cast<std::size_t>(row * nx + x0)],
              cell_start_[static_cast<std::size_t>(row * nx + x1) + 1], Vec<2>{sx, sy});
        };
        if (range[0][0] < 0) row_run(range[0][0] + nx, nx - 1, -domain_.extent(0));
        row_run(std::max(range[0][0], 0), std::min(range[0][1], nx - 1), 0.0);
        if (range[0][1] >= nx) row_run(0, range[0][1] - nx, domain_.extent(0));
      }
      return;
    }
    // Each row of cells along x at the (y, z) cells of the range, lowest axis fastest after x.
    std::array<int, D> k{};
    for (std::size_t a = 1; a < D; ++a) k[a] = range[a][0];
    const int xlo = range[0][0], xhi = range[0][1], nx = n_[0];
    while (true) {
      int row = 0;
      Vec<D> shift{};
      for (std::size_t a = D - 1; a >= 1; --a) {
        const int ka = k[a] < 0 ? k[a] + n_[a] : k[a] >= n_[a] ? k[a] - n_[a] : k[a];
        shift[a] = k[a] < 0 ? -domain_.extent(static_cast<int>(a)) : k[a] >= n_[a] ? domain_.extent(static_cast<int>(a))
                                                                                    : 0.0;
        row = row * n_[a] + ka;
      }
      const auto row_run = [&](int x0, int x1, double sx) {  // cells x0..x1 of the row are contiguous
        Vec<D> s = shift;
        s[0] = sx;
        run(cell_start_[static_cast<std::size_t>(row * nx + x0)], cell_start_[static_cast<std::size_t>(row * nx + x1) + 1],
            s);
      };
      if (xlo < 0) row_run(xlo + nx, nx - 1, -domain_.extent(0));
      row_run(std::max(xlo, 0), std::min(xhi, nx - 1), 0.0);
      if (xhi >= nx) row_run(0, xhi - nx, domain_.extent(0));
      std::size_t a = 1;
      for (; a < D; ++a) {
        if (++k[a] <= range[a][1]) break;
        k[a] = range[a][0];
      }
      if (a == D) break;
    }
  }
  // The cells along one axis that can hold a particle within radius of offset u: clamped to the grid on a
  // closed axis (escaped particles sit in the edge cells), running past it on a periodic one.
  [[nodiscard]] static std::array<int, 2> span(double u, double radius, double h, int cells, bool periodic) {
    int lo = static_cast<int>(std::floor((u - radius) / h)), hi = static_cast<int>(std::floor((u + radius) / h));
    if (!periodic) return {std::clamp(lo, 0, cells - 1), std::clamp(hi, 0, cells - 1)};
    return {std::max(lo, hi - cells + 1), hi};  // never more than one lap
  }
  [[nodiscard]] int cell_of(const Vec<D>& r) const;

  BasicDomain<D> domain_;
  double cell_size_ = 0;
  Vec<D> h_{};
  std::array<int, D> n_{};
  std::size_t n_particles_ = 0;
  std::vector<int> cell_start_;  // CSR over cells
  std::vector<int> ids_;         // particle indices, grouped by cell
  std::array<std::vector<double>, D> coords_;  // their coordinates, in the same order
  std::vector<int> ghosts_;
};

using CellGrid = BasicCellGrid<2>;   ///< the 2-D grid
using CellGrid3 = BasicCellGrid<3>;  ///< the 3-D grid

/// The pairs of `list` closer than radius (<= list.radius): a smaller kernel's list without a second search.
template <int D>
NeighborList restrict_radius(const NeighborList& list, const BasicParticles<D>& particles,
                             const BasicDomain<D>& domain, double radius);
/// Same, refilling `out` in place (reusing its memory).
template <int D>
void restrict_radius(const NeighborList& list, const BasicParticles<D>& particles, const BasicDomain<D>& domain,
                     double radius, NeighborList& out);

/// One-off search (bins and searches once).
template <int D>
NeighborList find_neighbors(const BasicParticles<D>& particles, const BasicDomain<D>& domain, double radius);

}  // namespace mps
