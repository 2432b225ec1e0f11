#pragma once
/// \file
/// Components a scene adds to the step (Simulation::add), each a self-contained treatment hooked in at named
/// points; the last three the simulation adds itself from its configuration. docs/step.md says which hooks each
/// uses and why each exists.
#include <cstddef>
#include <array>
#include <functional>
#include <vector>

#include "mps/boundaries/boundary.hpp"
#include "mps/core/state.hpp"
#include "mps/step/step.hpp"

namespace mps {

// Components that work in D = 2 and 3 are class templates BasicX<D>, with X the 2-D one and X3 the 3-D one.

/// Moves walls: called after the predictor with the particles and the new time (RigidMotion, PushingPlate, ...).
template <int D>
class BasicBoundaryMotion : public BasicStepComponent<D> {
 public:
  using typename BasicStepComponent<D>::StepContext;
  /// moves particles to their place at `time`
  using Motion = std::function<void(BasicParticles<D>&, double time)>;
  /// Same, told that particles [0, owned) are this process's own (Simulation::owned_particles; PushingPlate)
  using OwnedMotion = std::function<void(BasicParticles<D>&, double time, std::size_t owned)>;
  /// Calls `motion` every step.
  explicit BasicBoundaryMotion(Motion motion)
      : motion_([motion = std::move(motion)](BasicParticles<D>& p, double time, std::size_t) { motion(p, time); }) {}
  explicit BasicBoundaryMotion(OwnedMotion motion) : motion_(std::move(motion)) {}  ///< calls `motion` every step
  void after_predictor(StepContext& c) override { motion_(c.particles, c.fields.time, c.sim.owned_particles()); }

 private:
  OwnedMotion motion_;
};
using BoundaryMotion = BasicBoundaryMotion<2>;   ///< 2-D
using BoundaryMotion3 = BasicBoundaryMotion<3>;  ///< 3-D

/// No-slip by mirror velocities (see MirrorWall; in 3-D its line or circle extruded along z): the wall's particles take
/// the mirrored fluid velocity for the viscous term, and the wall's own velocity for the projection (no penetration).
template <int D>
class BasicMirrorNoSlip : public BasicStepComponent<D> {
 public:
  using typename BasicStepComponent<D>::StepContext;
  explicit BasicMirrorNoSlip(const MirrorWall& wall) : wall_(wall) { wall_.validate(); }  ///< checked
  void before_predictor(StepContext& c) override {
    apply_mirror_velocity(wall_, c.sim.grid(), c.sim.gradient_kernel().re, c.particles);
  }
  void before_projection(StepContext& c) override;
  [[nodiscard]] const MirrorWall& wall() const { return wall_; }  ///< the wall it applies

 private:
  MirrorWall wall_;
};
using MirrorNoSlip = BasicMirrorNoSlip<2>;   ///< 2-D
using MirrorNoSlip3 = BasicMirrorNoSlip<3>;  ///< 3-D: a plane or cylinder along z

/// No-slip at a flat wall in D dimensions (see MirrorPlane), as MirrorNoSlip does for MirrorWall: the wall's particles
/// take the mirrored fluid velocity for the viscous term, and the wall's own velocity for the projection.
template <int D>
class BasicMirrorPlaneNoSlip : public BasicStepComponent<D> {
 public:
  using typename BasicStepComponent<D>::StepContext;
  explicit BasicMirrorPlaneNoSlip(const MirrorPlane<D>& wall) : wall_(wall) { wall_.validate(); }  ///< checked
  void before_predictor(StepContext& c) override {
    apply_mirror_velocity(wall_, c.sim.grid(), c.sim.gradient_kernel().re, c.particles);
  }
  void before_projection(StepContext& c) override;
  [[nodiscard]] const MirrorPlane<D>& wall() const { return wall_; }  ///< the wall it applies

 private:
  MirrorPlane<D> wall_;
};
using MirrorPlaneNoSlip = BasicMirrorPlaneNoSlip<2>;   ///< 2-D
using MirrorPlaneNoSlip3 = BasicMirrorPlaneNoSlip<3>;  ///< 3-D

/// An open outlet through an outflow buffer (see OutflowBuffer): its particles are held at P = 0, and its fluid
/// leaves at the upstream fluid's velocity, unmoved by viscosity, the pressure gradient and shifting.
template <int D>
class BasicOpenOutlet : public BasicStepComponent<D> {
 public:
  using typename BasicStepComponent<D>::StepContext;
  explicit BasicOpenOutlet(const BasicOutflowBuffer<D>& buffer);  ///< throws std::invalid_argument for a bad buffer
  void before_predictor(StepContext& c) override;
  void before_source(StepContext& c) override;
  void before_assembly(StepContext& c) override;
  void after_pressure(StepContext& c) override;
  /// The buffer's thickness plus twice the gradient kernel's radius: a buffer particle's velocity is sampled that far
  /// upstream (apply_outflow_velocity).
  [[nodiscard]] double reach(const BasicSimulation<D>& sim) const override;
  /// After a HydrostaticSplit: the buffer is held at P = 0 through the split's pressure offset.
  [[nodiscard]] bool runs_after(const BasicStepComponent<D>& other) const override;
  [[nodiscard]] const BasicOutflowBuffer<D>& buffer() const { return buffer_; }  ///< the buffer it applies

 private:
  BasicOutflowBuffer<D> buffer_;
  std::vector<char> in_buffer_;  // this step's buffer particles, by position at its start
};
using OpenOutlet = BasicOpenOutlet<2>;   ///< 2-D
using OpenOutlet3 = BasicOpenOutlet<3>;  ///< 3-D

/// Where a free surface may exist: outside it no particle is flagged free surface, since in a confined liquid a low
/// n* is a void for the source term to close, not a surface to hold at P = 0.
template <int D>
class BasicSurfaceRegion : public BasicStepComponent<D> {
 public:
  using typename BasicStepComponent<D>::StepContext;
  using Region = std::function<bool(const Vec<D>& r)>;  ///< true where a free surface may be
  explicit BasicSurfaceRegion(Region region) : region_(std::move(region)) {}  ///< free surface only where region() holds
  /// 2-D: the region as a function of (x, y).
  explicit BasicSurfaceRegion(std::function<bool(double x, double y)> region)
    requires(D == 2)
      : region_([region = std::move(region)](const Vec<2>& r) { return region(r[0], r[1]); }) {}
  void before_source(StepContext& c) override;

 private:
  Region region_;
};
using SurfaceRegion = BasicSurfaceRegion<2>;   ///< 2-D
using SurfaceRegion3 = BasicSurfaceRegion<3>;  ///< 3-D

/// Free surface by the neighbours' distribution as well as their density (Khayyer et al. 2009): fluid whose neighbours
/// within the surface kernel lie one-sided, |sum w r/|r|| / n0 above `fraction` of a flat surface's value, is free
/// surface too. The density test misses particles whose kernel is full on one side only: the toe of a surge along
/// a wall, a thin jet.
/// `interior_density` (0: no limit): fluid whose number density at the surface kernel is at least this many n0 is not
/// flagged, however one-sided its neighbours lie. At 1, fluid pressed onto a wall, whose nearest wall particles
/// outweigh the fluid above, keeps its pressure instead of being held at 0 and sinking into the wall
/// (docs/dambreak3d.md).
template <int D>
class BasicAsymmetrySurface : public BasicStepComponent<D> {
 public:
  using typename BasicStepComponent<D>::StepContext;
  /// `fraction` of a flat surface's value; throws std::invalid_argument for a negative or non-finite interior_density
  explicit BasicAsymmetrySurface(double fraction, double interior_density = 0.0);
  void before_source(StepContext& c) override;

 private:
  double fraction_, interior_density_;
  std::vector<double> asymmetry_;
  std::vector<char> fluid_;  // the rows asymmetry_ is made for: only fluid is flagged
};
using AsymmetrySurface = BasicAsymmetrySurface<2>;   ///< 2-D
using AsymmetrySurface3 = BasicAsymmetrySurface<3>;  ///< 3-D

/// Walls wetted by the liquid's interior: a wall particle the density test flags as dry (free surface) becomes an
/// unknown of the PPE when a fluid particle within the surface kernel is not itself free surface. In a violent flow the
/// liquid pressed against a wall is disordered, its walls' number density falls below beta n0, and a dry wall reads 0
/// and carries no pressure where the liquid is at several rho g H (docs/dambreak.md).
template <int D>
class BasicWetWalls : public BasicStepComponent<D> {
 public:
  using typename BasicStepComponent<D>::StepContext;
  void before_source(StepContext& c) override;

 private:
  std::vector<char> wet_;
};
using WetWalls = BasicWetWalls<2>;   ///< 2-D
using WetWalls3 = BasicWetWalls<3>;  ///< 3-D

/// Collisions of close pairs after the predictor (collision_velocity_changes, pairs nearer than `distance` l0): the
/// pressure then need not stop a pair that nearly touches within one step, which gave single PPE rows spurious
/// pressures and stopped every dam-break run (docs/dambreak.md).
template <int D>
class BasicParticleCollision : public BasicStepComponent<D> {
 public:
  using typename BasicStepComponent<D>::StepContext;
  /// Pairs nearer than distance l0 collide, keeping `restitution` (in [0, 1]) of their approach speed.
  BasicParticleCollision(double distance, double restitution) : distance_(distance), restitution_(restitution) {}
  void after_predictor(StepContext& c) override;

 private:
  double distance_, restitution_;
  std::vector<char> movable_;
  std::array<std::vector<double>, D> change_;
};
using ParticleCollision = BasicParticleCollision<2>;   ///< 2-D
using ParticleCollision3 = BasicParticleCollision<3>;  ///< 3-D

/// Fluid that leaves `inside` (spray over a tank's walls) becomes a ghost at rest and is counted, instead of running
/// on until the guard stops the run at the domain's edge.
template <int D>
class BasicRemoveEscaped : public BasicStepComponent<D> {
 public:
  using typename BasicStepComponent<D>::StepContext;
  using Region = std::function<bool(const Vec<D>& r)>;  ///< true where fluid may stay
  explicit BasicRemoveEscaped(Region inside) : inside_(std::move(inside)) {}  ///< fluid outside inside() is removed
  /// 2-D: the region as a function of (x, y).
  explicit BasicRemoveEscaped(std::function<bool(double x, double y)> inside)
    requires(D == 2)
      : inside_([inside = std::move(inside)](const Vec<2>& r) { return inside(r[0], r[1]); }) {}
  void after_corrector(StepContext& c) override;
  [[nodiscard]] long removed() const { return removed_; }  ///< fluid particles removed so far
  [[nodiscard]] nlohmann::json save_state() const override { return {{"removed", removed_}}; }  ///< the count
  void restore_state(const nlohmann::json& state) override { removed_ = unpack_value<long>(state, "removed"); }  ///< same
  /// the counts added up
  [[nodiscard]] nlohmann::json merge_states(const std::vector<const nlohmann::json*>& parts) const override {
    return summed(parts, "removed");
  }

 private:
  Region inside_;
  long removed_ = 0;
};
using RemoveEscaped = BasicRemoveEscaped<2>;   ///< 2-D
using RemoveEscaped3 = BasicRemoveEscaped<3>;  ///< 3-D

/// Fluid that crosses a solid's face is put back on it and loses its velocity into the solid: a backstop for wall
/// lattices with holes. In 3-D a fluid particle pressed into the middle of four wall particles is only 0.71 l0 from
/// each, nearer than collisions act, and sinks through the wall (docs/dambreak3d.md). The solids are axis-aligned
/// boxes: a tank (fluid below its top kept inside; the last axis' upper face is open) and obstacles (fluid kept out).
template <int D>
class BasicWallBackstop : public BasicStepComponent<D> {
 public:
  using typename BasicStepComponent<D>::StepContext;
  /// An axis-aligned box.
  struct AxisBox {
    Vec<D> lo;  ///< lower corner [m]
    Vec<D> hi;  ///< upper corner [m]
  };
  /// Fluid is kept inside `tank` below its top and outside every obstacle (an obstacle whose bottom lies on the tank's
  /// floor is left by its sides or top only). Fluid less than `slack` [m] past a face is left where it is (pressed
  /// against a wall; the 2-D columns allow l0/2, up to the first wall layer's centres); further, it is put on the face.
  BasicWallBackstop(AxisBox tank, std::vector<AxisBox> obstacles, double slack = 0.0);
  void after_corrector(StepContext& c) override;
  [[nodiscard]] long returned() const { return returned_; }  ///< fluid particles put back so far (one per step each)
  [[nodiscard]] nlohmann::json save_state() const override { return {{"returned", returned_}}; }  ///< the count
  void restore_state(const nlohmann::json& state) override { returned_ = unpack_value<long>(state, "returned"); }  ///< same
  /// the counts added up
  [[nodiscard]] nlohmann::json merge_states(const std::vector<const nlohmann::json*>& parts) const override {
    return summed(parts, "returned");
  }

 private:
  AxisBox tank_;
  std::vector<AxisBox> obstacles_;
  double slack_;
  long returned_ = 0;
};
using WallBackstop = BasicWallBackstop<2>;   ///< 2-D
using WallBackstop3 = BasicWallBackstop<3>;  ///< 3-D

/// SimulationConfig::hydrostatic_split: the body force (fx, fy) along non-periodic axes is balanced by
/// P_h = rho f . r; the predictor leaves it out, the PPE solves for P - P_h, free-surface particles are held at
/// P = rho |f| l0/2 (the surface lies half a spacing above them) and take their own P' as gradient reference.
template <int D>
class BasicHydrostaticSplit : public BasicStepComponent<D> {
 public:
  using typename BasicStepComponent<D>::StepContext;
  explicit BasicHydrostaticSplit(const Vec<D>& force) : force_(force) {}  ///< the body force per unit mass [m/s^2]
  /// 2-D: the body force as (fx, fy).
  BasicHydrostaticSplit(double fx, double fy)
    requires(D == 2)
      : force_{fx, fy} {}
  void before_predictor(StepContext& c) override;
  void before_assembly(StepContext& c) override;

 private:
  Vec<D> force_;
};
using HydrostaticSplit = BasicHydrostaticSplit<2>;   ///< 2-D
using HydrostaticSplit3 = BasicHydrostaticSplit<3>;  ///< 3-D

/// SimulationConfig::initial_reference_density: the source reads each wall particle's number density against its
/// own at t = 0, and the fluid's against the fluid's t = 0 mean.
template <int D>
class BasicInitialReferenceDensity : public BasicStepComponent<D> {
 public:
  using typename BasicStepComponent<D>::StepContext;
  /// Measures the t = 0 number densities of `initial` with the density kernel (binning `grid` with them).
  BasicInitialReferenceDensity(const BasicParticles<D>& initial, const BasicDomain<D>& domain, BasicCellGrid<D>& grid,
                               const Kernel& density);
  void before_source(StepContext& c) override;

 private:
  std::vector<double> reference_;  // by particle id
};
using InitialReferenceDensity = BasicInitialReferenceDensity<2>;   ///< 2-D
using InitialReferenceDensity3 = BasicInitialReferenceDensity<3>;  ///< 3-D

/// SimulationConfig::shifting: after the corrector, fluid that is not prescribed moves down the concentration gradient
/// (shift_particles); fluid on or beside a free surface (which it would be pushed out through) stays, or moves along
/// the surface only with SimulationConfig::shift_along_free_surface.
template <int D>
class BasicParticleShifting : public BasicStepComponent<D> {
 public:
  using typename BasicStepComponent<D>::StepContext;
  /// Shifting coefficient A (see SimulationConfig::shifting). along_surface: particles on or next to a free surface
  /// shift too, along the surface only (mps::surface_normals); otherwise they stay where they are.
  explicit BasicParticleShifting(double coefficient, bool along_surface = false)
      : coefficient_(coefficient), along_surface_(along_surface) {}
  void shift_positions(StepContext& c) override;

 private:
  double coefficient_;
  bool along_surface_;
  std::vector<char> movable_, near_surface_;
  std::array<std::vector<double>, D> normal_;
};
using ParticleShifting = BasicParticleShifting<2>;   ///< 2-D
using ParticleShifting3 = BasicParticleShifting<3>;  ///< 3-D

/// SimulationConfig::continuous_free_surface: every fluid particle is an unknown of the PPE, none is held at P = 0.
/// The part of an unknown's Laplacian support that no particle fills (Kernel::laplacian_weight_sum less what its
/// neighbours give) is one ghost neighbour at that part's centroid, its pressure extrapolated through the surface's
/// value half a spacing beyond the nearest free-surface particle (the ghost fluid method's Dirichlet condition,
/// Gibou et al. 2002): the value a held surface would have, so a liquid at rest stays exact. With no surface particle
/// in reach, the surface lies where a flat cut of the lattice leaves the same empty weight, along the centroid. A
/// surface particle's pressure goes to that value with its support, smoothly, instead of flipping between held and
/// solved as the surface test decides; the matrix stays symmetric. The flags still drop the density term next to the
/// surface and steer shifting. docs/pressure.md.
template <int D>
class BasicContinuousFreeSurface : public BasicStepComponent<D> {
 public:
  using typename BasicStepComponent<D>::StepContext;
  void before_assembly(StepContext& c) override;
  /// After a HydrostaticSplit: the surface's value is the one the split holds a surface particle at.
  [[nodiscard]] bool runs_after(const BasicStepComponent<D>& other) const override;
  /// Where no surface particle is in reach: the distance [m] to a flat surface that leaves `empty` of the kernel's
  /// Laplacian weight outside it on the perfect lattice (linear between the half-spacings at which the cut passes
  /// between rows); `table` caches the cuts' weights.
  [[nodiscard]] static double surface_distance(const Kernel& k, double empty, std::vector<double>& table);

 private:
  std::vector<double> cut_weight_;  // the empty weight of each cut, for surface_distance
};
using ContinuousFreeSurface = BasicContinuousFreeSurface<2>;   ///< 2-D
using ContinuousFreeSurface3 = BasicContinuousFreeSurface<3>;  ///< 3-D

extern template class BasicOpenOutlet<2>;
extern template class BasicOpenOutlet<3>;
extern template class BasicMirrorNoSlip<2>;
extern template class BasicMirrorNoSlip<3>;
extern template class BasicMirrorPlaneNoSlip<2>;
extern template class BasicMirrorPlaneNoSlip<3>;
extern template class BasicSurfaceRegion<2>;
extern template class BasicSurfaceRegion<3>;
extern template class BasicAsymmetrySurface<2>;
extern template class BasicAsymmetrySurface<3>;
extern template class BasicWetWalls<2>;
extern template class BasicWetWalls<3>;
extern template class BasicParticleCollision<2>;
extern template class BasicParticleCollision<3>;
extern template class BasicRemoveEscaped<2>;
extern template class BasicRemoveEscaped<3>;
extern template class BasicWallBackstop<2>;
extern template class BasicWallBackstop<3>;
extern template class BasicHydrostaticSplit<2>;
extern template class BasicHydrostaticSplit<3>;
extern template class BasicInitialReferenceDensity<2>;
extern template class BasicInitialReferenceDensity<3>;
extern template class BasicParticleShifting<2>;
extern template class BasicParticleShifting<3>;
extern template class BasicContinuousFreeSurface<2>;
extern template class BasicContinuousFreeSurface<3>;

}  // namespace mps
