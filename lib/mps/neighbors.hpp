#pragma once
// Neighbour search on a uniform cell grid, producing CSR neighbour lists (one per radius).
#include <array>
#include <cmath>
#include <span>
#include <vector>

#include "mps/particles.hpp"

namespace mps {

// The region particles may occupy. A particle outside a non-periodic extent has escaped (the stability
// guard reports it); a periodic axis wraps positions and measures distances by the minimum image.
struct Domain {
  double xmin = 0, xmax = 0, ymin = 0, ymax = 0;
  bool periodic_x = false, periodic_y = false;

  [[nodiscard]] double width() const { return xmax - xmin; }
  [[nodiscard]] double height() const { return ymax - ymin; }
  // r_j - r_i, by the minimum image on periodic axes.
  [[nodiscard]] std::array<double, 2> displacement(double xi, double yi, double xj, double yj) const {
    double dx = xj - xi, dy = yj - yi;
    if (periodic_x) dx -= width() * std::nearbyint(dx / width());
    if (periodic_y) dy -= height() * std::nearbyint(dy / height());
    return {dx, dy};
  }
  [[nodiscard]] bool contains(double x, double y) const;
  void wrap(double& x, double& y) const;  // into [min, max) on periodic axes
  void validate() const;                  // throws std::invalid_argument with the reason
};

// neighbours of particle i are index[offsets[i] .. offsets[i+1]), sorted ascending, i itself excluded.
struct NeighborList {
  double radius = 0;
  std::vector<int> offsets{0};
  std::vector<int> index;

  [[nodiscard]] std::span<const int> of(std::size_t i) const {
    return {index.data() + offsets[i], static_cast<std::size_t>(offsets[i + 1] - offsets[i])};
  }
  [[nodiscard]] std::size_t particles() const { return offsets.size() - 1; }
  [[nodiscard]] std::size_t pairs() const { return index.size(); }
};

// Bins the active (non-ghost) particles into square cells at least `cell_size` wide; one binning serves
// every radius up to cell_size.
class CellGrid {
 public:
  CellGrid(const Domain& domain, double cell_size);
  void bin(const Particles& particles);
  [[nodiscard]] NeighborList neighbors(const Particles& particles, double radius) const;
  // Same, refilling `out` in place: a time loop that keeps its lists reuses their memory instead of having
  // the kernel hand out (and zero) fresh pages every step.
  void neighbors(const Particles& particles, double radius, NeighborList& out) const;
  // A permutation putting particles in cell order (ghosts last): applying it with Particles::permute makes
  // neighbours close in memory, which every sparse kernel and incomplete factorisation profits from.
  [[nodiscard]] std::vector<int> cell_order() const;
  [[nodiscard]] double cell_size() const { return cell_size_; }
  // Calls f(j, dx, dy) for every binned particle j closer than radius (<= cell size) to the point (x, y),
  // with (dx, dy) = r_j - (x, y) by the minimum image. `particles` are those last passed to bin().
  template <class F>
  void for_each_near(const Particles& particles, double x, double y, double radius, F&& f) const {
    const double r2 = radius * radius;
    const auto [cx, cy] = cell_of(x, y);
    for (int oy = -1; oy <= 1; ++oy) {
      int ky = cy + oy;
      if (domain_.periodic_y) ky = (ky + ny_) % ny_;
      else if (ky < 0 || ky >= ny_) continue;
      for (int ox = -1; ox <= 1; ++ox) {
        int kx = cx + ox;
        if (domain_.periodic_x) kx = (kx + nx_) % nx_;
        else if (kx < 0 || kx >= nx_) continue;
        const auto c = static_cast<std::size_t>(cell_index(kx, ky));
        for (int k = cell_start_[c]; k < cell_start_[c + 1]; ++k) {
          const int j = cell_particles_[static_cast<std::size_t>(k)];
          const auto d = domain_.displacement(x, y, particles.x[static_cast<std::size_t>(j)],
                                              particles.y[static_cast<std::size_t>(j)]);
          if (d[0] * d[0] + d[1] * d[1] < r2) f(j, d[0], d[1]);
        }
      }
    }
  }

 private:
  [[nodiscard]] int cell_index(int cx, int cy) const { return cy * nx_ + cx; }
  [[nodiscard]] std::array<int, 2> cell_of(double x, double y) const;

  Domain domain_;
  double cell_size_ = 0, hx_ = 0, hy_ = 0;
  int nx_ = 0, ny_ = 0;
  std::size_t n_particles_ = 0;
  std::vector<int> cell_start_;      // CSR over cells
  std::vector<int> cell_particles_;  // particle indices, grouped by cell
  std::vector<int> ghosts_;
};

// The pairs of `list` closer than radius (<= list.radius): a smaller kernel's list without a second search.
NeighborList restrict_radius(const NeighborList& list, const Particles& particles, const Domain& domain, double radius);
void restrict_radius(const NeighborList& list, const Particles& particles, const Domain& domain, double radius,
                     NeighborList& out);

// One-off search (bins and searches once).
NeighborList find_neighbors(const Particles& particles, const Domain& domain, double radius);

}  // namespace mps
