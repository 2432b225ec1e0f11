#pragma once
/// \file
/// Components a scene adds to the step (Simulation::add), each a self-contained treatment hooked in at named
/// points; the last three the simulation adds itself from its configuration. docs/step.md says which hooks each
/// uses and why each exists.
#include <cstddef>
#include <functional>
#include <vector>

#include "mps/boundary.hpp"
#include "mps/step.hpp"

namespace mps {

/// Moves walls: called after the predictor with the particles and the new time (RigidMotion, PushingPlate, ...).
class BoundaryMotion : public StepComponent {
 public:
  using Motion = std::function<void(Particles&, double time)>;  ///< moves particles to their place at `time`
  /// Same, told that particles [0, owned) are this process's own (Simulation::owned_particles; PushingPlate)
  using OwnedMotion = std::function<void(Particles&, double time, std::size_t owned)>;
  explicit BoundaryMotion(Motion motion);                                      ///< calls `motion` every step
  explicit BoundaryMotion(OwnedMotion motion) : motion_(std::move(motion)) {}  ///< calls `motion` every step
  void after_predictor(StepContext& c) override;

 private:
  OwnedMotion motion_;
};

/// No-slip by mirror velocities (see MirrorWall): the wall's particles take the mirrored fluid velocity for the
/// viscous term, and the wall's own velocity for the projection (no penetration).
class MirrorNoSlip : public StepComponent {
 public:
  explicit MirrorNoSlip(const MirrorWall& wall);  ///< throws std::invalid_argument for a bad wall
  void before_predictor(StepContext& c) override;
  void before_projection(StepContext& c) override;
  [[nodiscard]] const MirrorWall& wall() const { return wall_; }  ///< the wall it applies

 private:
  MirrorWall wall_;
};

/// An open outlet through an outflow buffer (see OutflowBuffer): its particles are held at P = 0, and its fluid
/// leaves at the upstream fluid's velocity, unmoved by viscosity, the pressure gradient and shifting.
class OpenOutlet : public StepComponent {
 public:
  explicit OpenOutlet(const OutflowBuffer& buffer);  ///< throws std::invalid_argument for a bad buffer
  void before_predictor(StepContext& c) override;
  void before_source(StepContext& c) override;
  void before_assembly(StepContext& c) override;
  void after_pressure(StepContext& c) override;
  /// The buffer's thickness plus twice the gradient kernel's radius: a buffer particle's velocity is sampled that far
  /// upstream (apply_outflow_velocity).
  [[nodiscard]] double reach(const Simulation& sim) const override;
  [[nodiscard]] const OutflowBuffer& buffer() const { return buffer_; }  ///< the buffer it applies

 private:
  OutflowBuffer buffer_;
  std::vector<char> in_buffer_;  // this step's buffer particles, by position at its start
};

/// Where a free surface may exist: outside it no particle is flagged free surface, since in a confined liquid a low
/// n* is a void for the source term to close, not a surface to hold at P = 0.
class SurfaceRegion : public StepComponent {
 public:
  using Region = std::function<bool(double x, double y)>;  ///< true where a free surface may be
  explicit SurfaceRegion(Region region) : region_(std::move(region)) {}  ///< free surface only where region() holds
  void before_source(StepContext& c) override;

 private:
  Region region_;
};

/// Free surface by the neighbours' distribution as well as their density (Khayyer et al. 2009): fluid whose neighbours
/// within the surface kernel lie one-sided, |sum w r/|r|| / n0 above `fraction` of a flat surface's value, is free
/// surface too. The density test misses particles whose kernel is full on one side only: the toe of a surge along
/// a wall, a thin jet.
class AsymmetrySurface : public StepComponent {
 public:
  explicit AsymmetrySurface(double fraction) : fraction_(fraction) {}  ///< threshold, a fraction of a flat surface's
  void before_source(StepContext& c) override;

 private:
  double fraction_;
  std::vector<double> asymmetry_;
};

/// Walls wetted by the liquid's interior: a wall particle the density test flags as dry (free surface) becomes an
/// unknown of the PPE when a fluid particle within the surface kernel is not itself free surface. In a violent flow the
/// liquid pressed against a wall is disordered, its walls' number density falls below beta n0, and a dry wall reads 0
/// and carries no pressure where the liquid is at several rho g H (docs/dambreak.md).
class WetWalls : public StepComponent {
 public:
  void before_source(StepContext& c) override;

 private:
  std::vector<char> wet_;
};

/// Collisions of close pairs after the predictor (collision_velocity_changes, pairs nearer than `distance` l0): the
/// pressure then need not stop a pair that nearly touches within one step, which gave single PPE rows spurious
/// pressures and stopped every dam-break run (docs/dambreak.md).
class ParticleCollision : public StepComponent {
 public:
  /// Pairs nearer than distance l0 collide, keeping `restitution` (in [0, 1]) of their approach speed.
  ParticleCollision(double distance, double restitution) : distance_(distance), restitution_(restitution) {}
  void after_predictor(StepContext& c) override;

 private:
  double distance_, restitution_;
  std::vector<char> movable_;
  std::vector<double> du_, dv_;
};

/// Fluid that leaves `inside` (spray over a tank's walls) becomes a ghost at rest and is counted, instead of running
/// on until the guard stops the run at the domain's edge.
class RemoveEscaped : public StepComponent {
 public:
  using Region = std::function<bool(double x, double y)>;  ///< true where fluid may stay
  explicit RemoveEscaped(Region inside) : inside_(std::move(inside)) {}  ///< fluid outside inside() is removed
  void after_corrector(StepContext& c) override;
  [[nodiscard]] long removed() const { return removed_; }  ///< fluid particles removed so far

 private:
  Region inside_;
  long removed_ = 0;
};

/// SimulationConfig::hydrostatic_split: the body force (fx, fy) along non-periodic axes is balanced by
/// P_h = rho f . r; the predictor leaves it out, the PPE solves for P - P_h, free-surface particles are held at
/// P = rho |f| l0/2 (the surface lies half a spacing above them) and take their own P' as gradient reference.
class HydrostaticSplit : public StepComponent {
 public:
  HydrostaticSplit(double fx, double fy) : fx_(fx), fy_(fy) {}  ///< the body force per unit mass [m/s^2]
  void before_predictor(StepContext& c) override;
  void before_assembly(StepContext& c) override;

 private:
  double fx_, fy_;
};

/// SimulationConfig::initial_reference_density: the source reads each wall particle's number density against its
/// own at t = 0, and the fluid's against the fluid's t = 0 mean.
class InitialReferenceDensity : public StepComponent {
 public:
  /// Measures the t = 0 number densities of `initial` with the density kernel (binning `grid` with them).
  InitialReferenceDensity(const Particles& initial, const Domain& domain, CellGrid& grid, const Kernel& density);
  void before_source(StepContext& c) override;

 private:
  std::vector<double> reference_;  // by particle id
};

/// SimulationConfig::shifting: after the corrector, fluid that is not prescribed moves down the concentration gradient
/// (shift_particles); fluid on or beside a free surface (which it would be pushed out through) stays, or moves along
/// the surface only with SimulationConfig::shift_along_free_surface.
class ParticleShifting : public StepComponent {
 public:
  /// Shifting coefficient A (see SimulationConfig::shifting). along_surface: particles on or next to a free surface
  /// shift too, along the surface only (mps::surface_normals); otherwise they stay where they are.
  explicit ParticleShifting(double coefficient, bool along_surface = false)
      : coefficient_(coefficient), along_surface_(along_surface) {}
  void shift_positions(StepContext& c) override;

 private:
  double coefficient_;
  bool along_surface_;
  std::vector<char> movable_, near_surface_;
  std::vector<double> normal_x_, normal_y_;
};

}  // namespace mps
