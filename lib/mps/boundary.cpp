#include "mps/boundary.hpp"

#include "mps/kernel.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

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

PushingPlate::PushingPlate(const Particles& initial, int plate_group, double speed, double l0, double outlet_x,
                           int fluid_group)
    : fluid_group_(fluid_group), speed_(speed), l0_(l0), outlet_x_(outlet_x) {
  if (!(speed > 0.0) || !std::isfinite(speed)) throw std::invalid_argument("pushing plate: speed must be positive");
  if (!(l0 > 0.0) || !std::isfinite(l0)) throw std::invalid_argument("pushing plate: spacing l0 must be positive");
  if (!std::isfinite(outlet_x)) throw std::invalid_argument("pushing plate: outlet_x must be finite");
  int max_id = -1, walls = 0;
  for (std::size_t i = 0; i < initial.size(); ++i) max_id = std::max(max_id, initial.id[i]);
  start_x_.assign(static_cast<std::size_t>(max_id + 1), std::nan(""));
  for (std::size_t i = 0; i < initial.size(); ++i) {
    if (initial.group[i] != plate_group || (initial.kind[i] != Kind::wall && initial.kind[i] != Kind::dummy)) continue;
    start_x_[static_cast<std::size_t>(initial.id[i])] = initial.x[i];
    walls += initial.kind[i] == Kind::wall;
  }
  if (walls == 0)
    throw std::invalid_argument("pushing plate: group " + std::to_string(plate_group) + " has no wall particles");
}

void PushingPlate::operator()(Particles& p, double time) {
  for (std::size_t i = 0; i < p.size(); ++i)
    if (p.kind[i] == Kind::fluid && p.x[i] > outlet_x_) {
      p.kind[i] = Kind::ghost;
      p.u[i] = p.v[i] = p.p[i] = 0.0;
      ++removed_;
    }
  // The plate has stepped back floor(U t / l0) times; each step back leaves a gap of one column.
  const int steps_back = static_cast<int>(std::floor(speed_ * time / l0_));
  const double advance = speed_ * time - steps_back * l0_;
  std::vector<std::size_t> plate_walls;
  for (std::size_t i = 0; i < p.size(); ++i) {
    const auto id = static_cast<std::size_t>(p.id[i]);
    if (id >= start_x_.size() || std::isnan(start_x_[id])) continue;
    p.x[i] = start_x_[id] + advance;
    p.u[i] = speed_;
    p.v[i] = 0.0;
    if (p.kind[i] == Kind::wall) plate_walls.push_back(i);
  }
  const int new_columns = steps_back - columns_;
  if (new_columns <= 0) return;
  std::vector<std::size_t> ghosts;
  for (std::size_t i = 0; i < p.size(); ++i)
    if (p.kind[i] == Kind::ghost) ghosts.push_back(i);
  const std::size_t needed = plate_walls.size() * static_cast<std::size_t>(new_columns);
  if (ghosts.size() < needed)
    throw SimulationError("pushing plate: the inlet needs " + std::to_string(needed) + " ghost particles for its new " +
                          "column but only " + std::to_string(ghosts.size()) + " are left; start the scene with a " +
                          "larger ghost pool");
  std::size_t next = 0;
  for (int c = 1; c <= new_columns; ++c)
    for (std::size_t w : plate_walls) {
      const std::size_t g = ghosts[next++];
      p.x[g] = p.x[w] + c * l0_;
      p.y[g] = p.y[w];
      p.u[g] = speed_;
      p.v[g] = p.p[g] = 0.0;
      p.kind[g] = Kind::fluid;
      p.group[g] = fluid_group_;
    }
  columns_ = steps_back;
}

}  // namespace mps
