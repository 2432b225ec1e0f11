#pragma once
// Boundary conditions beyond "wall particles at the wall's velocity": mirror no-slip walls, and the
// pushing-plate inlet with its open outlet.
#include <span>
#include <stdexcept>
#include <vector>

#include "mps/neighbors.hpp"
#include "mps/particles.hpp"

namespace mps {

// A step that could not be completed: unstable motion, a failed solve, an inlet out of particles. The
// simulation's state is that of the last good step.
class SimulationError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// A flat no-slip wall by mirror velocities (seed 004): every wall and dummy particle of `group` takes
// 2 U - u(m), u(m) the fluid velocity at its mirror image m across the wall line. The fluid's velocity then
// passes through U on the line itself. Wall particles at U alone pin the velocity at their own row, half a
// spacing outside the line, and the dummy rows behind them at U flatten the near-wall Laplacian: a body-force
// channel comes out ~20 % too fast (README, "Poiseuille"). The mirror values serve the viscous term only;
// the projection takes the wall at U (no penetration).
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

// The constant-flow inlet and open outlet of a channel along +x (seed 004, Fig. 1). The plate, the wall and
// dummy particles of `plate_group`, moves at `speed` from its starting position; whenever it has advanced one
// spacing l0 it steps back by l0 and, one spacing ahead of its wall layer, a column of ghosts becomes fluid
// moving at `speed` (one particle per plate wall particle, at its height). Fluid past `outlet_x` becomes ghosts,
// the pool the inlet draws from. With the outlet open, the fluid next to it is free surface (P = 0).
// Pass it to Simulation::set_boundary_motion; it is called after the predictor with the new time.
class PushingPlate {
 public:
  PushingPlate(const Particles& initial, int plate_group, double speed, double l0, double outlet_x, int fluid_group = 0);
  // Throws SimulationError if the ghost pool runs dry (the scene must start with more ghosts).
  void operator()(Particles& particles, double time);
  [[nodiscard]] int columns_added() const { return columns_; }
  [[nodiscard]] long particles_removed() const { return removed_; }

 private:
  int fluid_group_;
  double speed_, l0_, outlet_x_;
  std::vector<double> start_x_;  // by particle id: the plate's particles' starting x (NaN for others)
  int columns_ = 0;
  long removed_ = 0;
};

}  // namespace mps
