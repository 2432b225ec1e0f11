#pragma once
// Wall boundary conditions beyond "wall particles at the wall's velocity".
#include <span>

#include "mps/neighbors.hpp"
#include "mps/particles.hpp"

namespace mps {

// A flat no-slip wall by mirror velocities (seed 004): every wall and dummy particle of `group` takes
// 2 U - u(m), u(m) the fluid velocity at its mirror image m across the wall line. The fluid's velocity then
// passes through U on the line itself. Wall particles at U alone pin the velocity at their own row, half a
// spacing outside the line, and the dummy rows behind them at U flatten the near-wall Laplacian: a body-force
// channel comes out ~20 % too fast (README, "Poiseuille").
struct MirrorWall {
  double px = 0, py = 0;  // a point of the wall line
  double nx = 0, ny = 1;  // unit normal pointing into the fluid
  double u = 0, v = 0;    // wall velocity U (tangential: a sliding wall; its particles need not move)
  int group = 0;          // the wall and dummy particles this applies to
  void validate() const;  // throws std::invalid_argument unless the normal has unit length
};

// u(m) is the Shepard average of the fluid within `radius` of m, weighted by the bounded weight
// re/(0.85 r + 0.15 re) - 1 (a mirror point may coincide with a fluid particle, where re/r - 1 is infinite);
// a mirror point with no fluid in reach takes u(m) = U. `grid` must have been binned with `particles`.
void apply_mirror_velocity(const MirrorWall& wall, const CellGrid& grid, double radius, Particles& particles);

}  // namespace mps
