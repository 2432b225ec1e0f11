#include "mps/neighbors.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

namespace mps {

bool Domain::contains(double x, double y) const {
  const bool in_x = periodic_x || (x >= xmin && x <= xmax);
  const bool in_y = periodic_y || (y >= ymin && y <= ymax);
  return in_x && in_y && std::isfinite(x) && std::isfinite(y);
}

void Domain::wrap(double& x, double& y) const {
  if (periodic_x) {
    x = xmin + std::fmod(x - xmin, width());
    if (x < xmin) x += width();
    if (x >= xmax) x -= width();
  }
  if (periodic_y) {
    y = ymin + std::fmod(y - ymin, height());
    if (y < ymin) y += height();
    if (y >= ymax) y -= height();
  }
}

void Domain::validate() const {
  if (!(xmax > xmin) || !(ymax > ymin) || !std::isfinite(xmin) || !std::isfinite(xmax) ||
      !std::isfinite(ymin) || !std::isfinite(ymax))
    throw std::invalid_argument("Domain: need finite bounds with xmax > xmin and ymax > ymin");
}

CellGrid::CellGrid(const Domain& domain, double cell_size) : domain_(domain), cell_size_(cell_size) {
  domain_.validate();
  if (!(cell_size > 0.0) || !std::isfinite(cell_size))
    throw std::invalid_argument("CellGrid: cell size (the largest search radius) must be positive, got " +
                                std::to_string(cell_size));
  nx_ = std::max(1, static_cast<int>(std::floor(domain_.width() / cell_size)));
  ny_ = std::max(1, static_cast<int>(std::floor(domain_.height() / cell_size)));
  // Three cells are the least a periodic axis needs for the 3x3 scan to visit no cell twice.
  if ((domain_.periodic_x && nx_ < 3) || (domain_.periodic_y && ny_ < 3))
    throw std::invalid_argument("CellGrid: a periodic axis must be at least 3 search radii long");
  hx_ = domain_.width() / nx_;
  hy_ = domain_.height() / ny_;
}

std::array<int, 2> CellGrid::cell_of(double x, double y) const {
  // Clamping keeps escaped particles binned (at the edge) so the search stays correct; the guard reports them.
  int cx = static_cast<int>(std::floor((x - domain_.xmin) / hx_));
  int cy = static_cast<int>(std::floor((y - domain_.ymin) / hy_));
  if (domain_.periodic_x) cx = ((cx % nx_) + nx_) % nx_;
  if (domain_.periodic_y) cy = ((cy % ny_) + ny_) % ny_;
  return {std::clamp(cx, 0, nx_ - 1), std::clamp(cy, 0, ny_ - 1)};
}

void CellGrid::bin(const Particles& particles) {
  const std::size_t n = particles.size();
  n_particles_ = n;
  std::vector<int> cell(n, -1);
  cell_start_.assign(static_cast<std::size_t>(nx_) * ny_ + 1, 0);
  ghosts_.clear();
  for (std::size_t i = 0; i < n; ++i) {
    if (particles.kind[i] == Kind::ghost) {
      ghosts_.push_back(static_cast<int>(i));
      continue;
    }
    if (!std::isfinite(particles.x[i]) || !std::isfinite(particles.y[i]))
      throw std::runtime_error("CellGrid: particle " + std::to_string(i) + " has a non-finite position");
    const auto [cx, cy] = cell_of(particles.x[i], particles.y[i]);
    cell[i] = cell_index(cx, cy);
    ++cell_start_[static_cast<std::size_t>(cell[i]) + 1];
  }
  for (std::size_t c = 1; c < cell_start_.size(); ++c) cell_start_[c] += cell_start_[c - 1];
  cell_particles_.resize(n - ghosts_.size());
  std::vector<int> fill(cell_start_.begin(), cell_start_.end() - 1);
  for (std::size_t i = 0; i < n; ++i)
    if (cell[i] >= 0) cell_particles_[static_cast<std::size_t>(fill[static_cast<std::size_t>(cell[i])]++)] =
        static_cast<int>(i);
}

NeighborList CellGrid::neighbors(const Particles& particles, double radius) const {
  NeighborList list;
  neighbors(particles, radius, list);
  return list;
}

void CellGrid::neighbors(const Particles& particles, double radius, NeighborList& list) const {
  if (particles.size() != n_particles_) throw std::logic_error("CellGrid::neighbors: bin() the particles first");
  if (!(radius > 0.0) || radius > cell_size_ * (1.0 + 1e-12))
    throw std::invalid_argument("CellGrid::neighbors: radius must be in (0, cell size]");
  const auto n = static_cast<std::ptrdiff_t>(particles.size());
  list.radius = radius;
  list.offsets.assign(particles.size() + 1, 0);

  // Two passes (count, then fill) keep the result in one allocation and independent of thread scheduling.
  auto visit = [&](std::ptrdiff_t i, auto&& on_neighbor) {
    const auto si = static_cast<std::size_t>(i);
    for_each_near(particles, particles.x[si], particles.y[si], radius, [&](int j, double, double) {
      if (j != i) on_neighbor(j);
    });
  };

#pragma omp parallel for schedule(static)
  for (std::ptrdiff_t i = 0; i < n; ++i) {
    if (particles.kind[static_cast<std::size_t>(i)] == Kind::ghost) continue;
    int count = 0;
    visit(i, [&](int) { ++count; });
    list.offsets[static_cast<std::size_t>(i) + 1] = count;
  }
  for (std::size_t i = 1; i < list.offsets.size(); ++i) list.offsets[i] += list.offsets[i - 1];
  list.index.resize(static_cast<std::size_t>(list.offsets.back()));
#pragma omp parallel for schedule(static)
  for (std::ptrdiff_t i = 0; i < n; ++i) {
    if (particles.kind[static_cast<std::size_t>(i)] == Kind::ghost) continue;
    int* out = list.index.data() + list.offsets[static_cast<std::size_t>(i)];
    int* begin = out;
    visit(i, [&](int j) { *out++ = j; });
    std::sort(begin, out);
  }
}

std::vector<int> CellGrid::cell_order() const {
  std::vector<int> order(cell_particles_);
  order.insert(order.end(), ghosts_.begin(), ghosts_.end());
  return order;
}

NeighborList restrict_radius(const NeighborList& list, const Particles& particles, const Domain& domain, double radius) {
  NeighborList out;
  restrict_radius(list, particles, domain, radius, out);
  return out;
}

void restrict_radius(const NeighborList& list, const Particles& particles, const Domain& domain, double radius,
                     NeighborList& out) {
  if (!(radius > 0.0) || radius > list.radius * (1.0 + 1e-12))
    throw std::invalid_argument("restrict_radius: radius must be in (0, the list's radius]");
  if (&out == &list) throw std::invalid_argument("restrict_radius: out must not be the input list");
  const double r2 = radius * radius;
  const auto n = static_cast<std::ptrdiff_t>(list.particles());
  out.radius = radius;
  out.offsets.assign(list.offsets.size(), 0);
  auto keep = [&](std::size_t i, int j) {
    const auto d = domain.displacement(particles.x[i], particles.y[i], particles.x[static_cast<std::size_t>(j)],
                                       particles.y[static_cast<std::size_t>(j)]);
    return d[0] * d[0] + d[1] * d[1] < r2;
  };
#pragma omp parallel for schedule(static)
  for (std::ptrdiff_t ii = 0; ii < n; ++ii) {
    const auto i = static_cast<std::size_t>(ii);
    int count = 0;
    for (int j : list.of(i)) count += keep(i, j);
    out.offsets[i + 1] = count;
  }
  for (std::size_t i = 1; i < out.offsets.size(); ++i) out.offsets[i] += out.offsets[i - 1];
  out.index.resize(static_cast<std::size_t>(out.offsets.back()));
#pragma omp parallel for schedule(static)
  for (std::ptrdiff_t ii = 0; ii < n; ++ii) {
    const auto i = static_cast<std::size_t>(ii);
    int* dst = out.index.data() + out.offsets[i];
    for (int j : list.of(i))
      if (keep(i, j)) *dst++ = j;  // stays sorted: a subsequence of a sorted row
  }
}

NeighborList find_neighbors(const Particles& particles, const Domain& domain, double radius) {
  CellGrid grid(domain, radius);
  grid.bin(particles);
  return grid.neighbors(particles, radius);
}

}  // namespace mps
