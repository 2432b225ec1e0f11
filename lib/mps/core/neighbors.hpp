#pragma once
/// \file
/// Neighbour search on a uniform cell grid producing CSR neighbour lists (one per radius), in 2-D and 3-D.
#include <algorithm>
#include <array>
#include <cmath>
#include <span>
#include <vector>

#include "mps/core/domain.hpp"
#include "mps/core/particles.hpp"

namespace mps {

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
  /// Same, with searches allowed up to cell_size + margin (margin >= 0) in cells sized by cell_size alone: a wider
  /// search in the same cells keeps cell_order() as it was.
  BasicCellGrid(const BasicDomain<D>& domain, double cell_size, double margin);
  void bin(const BasicParticles<D>& particles);  ///< sorts the particles' current positions into the cells
  /// `particles` must be those last passed to bin(), not moved since.
  [[nodiscard]] NeighborList neighbors(const BasicParticles<D>& particles, double radius) const;
  /// Same, refilling `out` in place: a time loop that keeps its lists reuses their memory instead of having
  /// the kernel hand out (and zero) fresh pages every step. `rows` (one flag per particle, or empty for all): the
  /// particles whose rows are searched; the others get empty rows, though they still appear in the rows searched.
  void neighbors(const BasicParticles<D>& particles, double radius, NeighborList& out,
                 std::span<const char> rows = {}) const;
  /// One search filling the lists of two radii, `inner` for inner_radius <= radius: cheaper than searching
  /// once and restricting the list.
  void neighbors(const BasicParticles<D>& particles, double radius, NeighborList& out, double inner_radius,
                 NeighborList& inner, std::span<const char> rows = {}) const;
  /// The same search also filling `fringe` with the pairs from radius up to fringe_radius (<= cell size), and
  /// `inner` unless null. A time loop that keeps the fringe can, while no particle has moved more than half of
  /// fringe_radius - radius, widen `list` by it (add_fringe) to hold every pair now closer than radius, without a
  /// search.
  void neighbors(const BasicParticles<D>& particles, double radius, NeighborList& list, double inner_radius,
                 NeighborList* inner, double fringe_radius, NeighborList& fringe,
                 std::span<const char> rows = {}) const;
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
  // Fills list (pairs within radius), inner (within its radius, <= radius) and fringe (from radius to its radius)
  // in one scan; either may be null.
  void search(const BasicParticles<D>& particles, double radius, NeighborList& list, NeighborList* inner,
              NeighborList* fringe, std::span<const char> searched_rows) const;
  template <bool with_inner, bool with_fringe>
  void search_lists(const BasicParticles<D>& particles, double radius, NeighborList& list, NeighborList* inner,
                    NeighborList* fringe, std::span<const char> searched_rows) const;
  // The cell-ordered runs [begin, end) along x that hold every binned particle within radius of r (wrapped into the
  // domain), each with the shift that turns its coordinates into the nearest periodic image. In 3-D a row of cells is
  // scanned only as far along x as the sphere reaches at the row's nearest point, and not at all beyond it: that
  // leaves out a third of the cells a box around the sphere holds (docs/benchmarks.md).
  template <class Run>
  void for_each_run(const Vec<D>& r, double radius, Run&& run) const {
    const auto lower = domain_.lower();
    const auto periodic = domain_.periodic();
    std::array<std::array<int, 2>, D> range;
    for (std::size_t a = 0; a < D; ++a) range[a] = span(r[a] - lower[a], radius, h_[a], n_[a], periodic[a]);
    if constexpr (D == 2) {  // a plane's rows, untrimmed: trimming them saved a seventh of the cells and cost more
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
    // The squared distance from r to the cells of unwrapped index k along axis a, less a rounding margin; a closed
    // axis's edge cells reach on outwards, where escaped particles are binned.
    const auto gap2 = [&](std::size_t a, int k) {
      const double below = k == 0 && !periodic[a] ? -HUGE_VAL : lower[a] + k * h_[a];
      const double above = k == n_[a] - 1 && !periodic[a] ? HUGE_VAL : lower[a] + (k + 1) * h_[a];
      const double gap = std::max(0.0, std::max(below - r[a], r[a] - above) - edge_margin_[a]);
      return gap * gap;
    };
    const double radius2 = radius * radius;
    const int nx = n_[0];
    // The runs of one row (cells along x at flat index `row` of the other axes, shifted by `shift`), whose nearest
    // point lies at squared distance d2 from r across x.
    const auto row_runs = [&](int row, Vec<D> shift, double d2) {
      const double reach = std::sqrt(radius2 - d2) + edge_margin_[0];
      const auto [x_lo, x_hi] = span(r[0] - lower[0], reach, h_[0], nx, periodic[0]);
      const auto row_run = [&](int x0, int x1, double sx) {  // cells x0..x1 of the row are contiguous
        shift[0] = sx;
        run(cell_start_[static_cast<std::size_t>(row * nx + x0)],
            cell_start_[static_cast<std::size_t>(row * nx + x1) + 1], shift);
      };
      if (x_lo < 0) row_run(x_lo + nx, nx - 1, -domain_.extent(0));
      row_run(std::max(x_lo, 0), std::min(x_hi, nx - 1), 0.0);
      if (x_hi >= nx) row_run(0, x_hi - nx, domain_.extent(0));
    };
    // Each row of cells along x at the cells of the range across it, lowest axis fastest after x.
    std::array<int, D> k{};
    for (std::size_t a = 1; a < D; ++a) k[a] = range[a][0];
    while (true) {
      int row = 0;
      Vec<D> shift{};
      double d2 = 0.0;
      for (std::size_t a = D - 1; a >= 1; --a) {
        const int ka = k[a] < 0 ? k[a] + n_[a] : k[a] >= n_[a] ? k[a] - n_[a] : k[a];
        shift[a] = k[a] < 0 ? -domain_.extent(static_cast<int>(a)) : k[a] >= n_[a] ? domain_.extent(static_cast<int>(a))
                                                                                    : 0.0;
        row = row * n_[a] + ka;
        d2 += gap2(a, k[a]);
      }
      if (d2 < radius2) row_runs(row, shift, d2);
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
  Vec<D> edge_margin_{};  // how far rounding may put a binned particle outside its cell's bounds, by axis
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

/// Widens `list` in place by `fringe` (its pairs from list.radius to fringe.radius, from the same search): each row
/// the sorted union of both, the radius the fringe's. Throws if their rows or radii do not match.
void add_fringe(NeighborList& list, const NeighborList& fringe);

/// One-off search (bins and searches once).
template <int D>
NeighborList find_neighbors(const BasicParticles<D>& particles, const BasicDomain<D>& domain, double radius);

}  // namespace mps
