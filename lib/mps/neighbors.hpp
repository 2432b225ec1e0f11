#pragma once
/// \file
/// Neighbour search on a uniform cell grid, producing CSR neighbour lists (one per radius).
#include <algorithm>
#include <array>
#include <cmath>
#include <span>
#include <vector>

#include "mps/particles.hpp"

namespace mps {

/// The region particles may occupy. A particle outside a non-periodic extent has escaped (the stability
/// guard reports it); a periodic axis wraps positions and measures distances by the minimum image.
struct Domain {
  /// @{ extent [m]
  double xmin = 0, xmax = 0, ymin = 0, ymax = 0;  /// @}
  /// @{ whether an axis wraps around (period: width() or height())
  bool periodic_x = false, periodic_y = false;  /// @}

  [[nodiscard]] double width() const { return xmax - xmin; }   ///< xmax - xmin
  [[nodiscard]] double height() const { return ymax - ymin; }  ///< ymax - ymin
  /// r_j - r_i, by the minimum image on periodic axes.
  [[nodiscard]] std::array<double, 2> displacement(double xi, double yi, double xj, double yj) const {
    return {periodic_x ? nearest_image(xj - xi, width()) : xj - xi,
            periodic_y ? nearest_image(yj - yi, height()) : yj - yi};
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
  [[nodiscard]] bool contains(double x, double y) const;  ///< finite and inside the extent on non-periodic axes
  void wrap(double& x, double& y) const;  ///< into [min, max) on periodic axes
  void validate() const;                  ///< throws std::invalid_argument with the reason
};

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

/// Bins the active (non-ghost) particles into square cells at least half of `cell_size` wide; one binning
/// serves every radius up to cell_size. The binned coordinates are kept in cell order, so a search scans a few
/// contiguous runs of memory (one per row of cells) instead of chasing particle indices.
class CellGrid {
 public:
  CellGrid(const Domain& domain, double cell_size);  ///< an empty grid; throws for a bad domain or size
  void bin(const Particles& particles);  ///< sorts the particles' current positions into the cells
  /// `particles` must be those last passed to bin(), not moved since.
  [[nodiscard]] NeighborList neighbors(const Particles& particles, double radius) const;
  /// Same, refilling `out` in place: a time loop that keeps its lists reuses their memory instead of having
  /// the kernel hand out (and zero) fresh pages every step.
  void neighbors(const Particles& particles, double radius, NeighborList& out) const;
  /// One search filling the lists of two radii, `inner` for inner_radius <= radius: cheaper than searching
  /// once and restricting the list.
  void neighbors(const Particles& particles, double radius, NeighborList& out, double inner_radius,
                 NeighborList& inner) const;
  /// A permutation putting particles in cell order (ghosts last): applying it with Particles::permute makes
  /// neighbours close in memory, which every sparse kernel and incomplete factorisation profits from.
  [[nodiscard]] std::vector<int> cell_order() const;
  [[nodiscard]] double cell_size() const { return cell_size_; }  ///< the largest radius a search may use
  /// Calls f(j, dx, dy) for every binned particle j closer than radius (<= cell size) to the point (x, y),
  /// with (dx, dy) = r_j - (x, y) by the minimum image.
  template <class F>
  void for_each_near(double x, double y, double radius, F&& f) const {
    if (domain_.periodic_x || domain_.periodic_y) domain_.wrap(x, y);
    const double r2 = radius * radius;
    for_each_run(x, y, radius, [&](int begin, int end, double sx, double sy) {
      for (int k = begin; k < end; ++k) {
        const auto kk = static_cast<std::size_t>(k);
        const double dx = xs_[kk] + sx - x, dy = ys_[kk] + sy - y;
        if (dx * dx + dy * dy < r2) f(ids_[kk], dx, dy);
      }
    });
  }

 private:
  void search(const Particles& particles, double radius, NeighborList& list, NeighborList* inner) const;
  // The cell-ordered runs [begin, end) that hold every binned particle within radius of (x, y) (wrapped into
  // the domain), each with the shift (sx, sy) that turns its coordinates into the nearest periodic image.
  template <class Run>
  void for_each_run(double x, double y, double radius, Run&& run) const {
    const auto [ylo, yhi] = span(y - domain_.ymin, radius, hy_, ny_, domain_.periodic_y);
    const auto [xlo, xhi] = span(x - domain_.xmin, radius, hx_, nx_, domain_.periodic_x);
    for (int ky = ylo; ky <= yhi; ++ky) {
      const int row = ky < 0 ? ky + ny_ : ky >= ny_ ? ky - ny_ : ky;
      const double sy = ky < 0 ? -domain_.height() : ky >= ny_ ? domain_.height() : 0.0;
      const auto row_run = [&](int x0, int x1, double sx) {  // cells x0..x1 of the row are contiguous
        run(cell_start_[static_cast<std::size_t>(cell_index(x0, row))],
            cell_start_[static_cast<std::size_t>(cell_index(x1, row)) + 1], sx, sy);
      };
      if (xlo < 0) row_run(xlo + nx_, nx_ - 1, -domain_.width());
      row_run(std::max(xlo, 0), std::min(xhi, nx_ - 1), 0.0);
      if (xhi >= nx_) row_run(0, xhi - nx_, domain_.width());
    }
  }
  // The cells along one axis that can hold a particle within radius of offset u: clamped to the grid on a
  // closed axis (escaped particles sit in the edge cells), running past it on a periodic one.
  [[nodiscard]] static std::array<int, 2> span(double u, double radius, double h, int cells, bool periodic) {
    int lo = static_cast<int>(std::floor((u - radius) / h)), hi = static_cast<int>(std::floor((u + radius) / h));
    if (!periodic) return {std::clamp(lo, 0, cells - 1), std::clamp(hi, 0, cells - 1)};
    return {std::max(lo, hi - cells + 1), hi};  // never more than one lap
  }
  [[nodiscard]] int cell_index(int cx, int cy) const { return cy * nx_ + cx; }
  [[nodiscard]] std::array<int, 2> cell_of(double x, double y) const;

  Domain domain_;
  double cell_size_ = 0, hx_ = 0, hy_ = 0;
  int nx_ = 0, ny_ = 0;
  std::size_t n_particles_ = 0;
  std::vector<int> cell_start_;  // CSR over cells
  std::vector<int> ids_;         // particle indices, grouped by cell
  std::vector<double> xs_, ys_;  // their coordinates, in the same order
  std::vector<int> ghosts_;
};

/// The pairs of `list` closer than radius (<= list.radius): a smaller kernel's list without a second search.
NeighborList restrict_radius(const NeighborList& list, const Particles& particles, const Domain& domain, double radius);
/// Same, refilling `out` in place (reusing its memory).
void restrict_radius(const NeighborList& list, const Particles& particles, const Domain& domain, double radius,
                     NeighborList& out);

/// One-off search (bins and searches once).
NeighborList find_neighbors(const Particles& particles, const Domain& domain, double radius);

}  // namespace mps
