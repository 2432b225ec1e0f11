#include "mps/boundary.hpp"

#include "mps/kernel.hpp"

#include <cmath>
#include <stdexcept>

namespace mps {

void MirrorWall::validate() const {
  if (!std::isfinite(px) || !std::isfinite(py) || !std::isfinite(u) || !std::isfinite(v))
    throw std::invalid_argument("mirror wall: point and velocity must be finite");
  if (!(std::abs(std::hypot(nx, ny) - 1.0) < 1e-9))
    throw std::invalid_argument("mirror wall: the normal (nx, ny) must have unit length");
}

void apply_mirror_velocity(const MirrorWall& wall, const CellGrid& grid, double radius, Particles& p) {
  wall.validate();
  if (!(radius > 0.0) || radius > grid.cell_size() * (1.0 + 1e-12))
    throw std::invalid_argument("apply_mirror_velocity: radius must be in (0, the grid's cell size]");
  const Kernel shepard{Weight::bounded, radius, 0.0, 0.0, 0};
  const auto n = static_cast<std::ptrdiff_t>(p.size());
  // Writes go to walls and dummies, reads come from fluid only: the loop has no dependence between particles.
#pragma omp parallel for schedule(static)
  for (std::ptrdiff_t ii = 0; ii < n; ++ii) {
    const auto i = static_cast<std::size_t>(ii);
    if ((p.kind[i] != Kind::wall && p.kind[i] != Kind::dummy) || p.group[i] != wall.group) continue;
    const double depth = (p.x[i] - wall.px) * wall.nx + (p.y[i] - wall.py) * wall.ny;  // < 0 behind the wall
    const double mx = p.x[i] - 2.0 * depth * wall.nx, my = p.y[i] - 2.0 * depth * wall.ny;
    double sw = 0.0, su = 0.0, sv = 0.0;
    grid.for_each_near(p, mx, my, radius, [&](int j, double dx, double dy) {
      const auto jj = static_cast<std::size_t>(j);
      if (p.kind[jj] != Kind::fluid) return;
      const double w = shepard.w(std::hypot(dx, dy));
      sw += w;
      su += w * p.u[jj];
      sv += w * p.v[jj];
    });
    const double um = sw > 0.0 ? su / sw : wall.u, vm = sw > 0.0 ? sv / sw : wall.v;
    p.u[i] = 2.0 * wall.u - um;
    p.v[i] = 2.0 * wall.v - vm;
  }
}

}  // namespace mps
