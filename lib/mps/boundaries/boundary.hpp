#pragma once
/// \file
/// Boundary conditions beyond "wall particles at the wall's velocity": mirror no-slip walls, rigidly moving
/// wall groups, and the pushing-plate inlet with its open outlet.
#include <array>
#include <cstddef>
#include <functional>
#include <span>
#include <stdexcept>
#include <vector>

#include "mps/core/errors.hpp"
#include "mps/core/neighbors.hpp"
#include "mps/core/particles.hpp"
#include "mps/core/state.hpp"
#include "mps/core/vec.hpp"

namespace mps {

/// A flat no-slip wall by mirror velocities (seed 004): every wall and dummy particle of `group` takes
/// 2 U - u(m), u(m) the fluid velocity at its mirror image m across the wall line, so the fluid's velocity passes
/// through U on the line itself. A circular wall (radius > 0, centre (px, py)) mirrors along the radius,
/// r -> 2 R - r; omega adds a rigid rotation about (px, py) to the wall velocity. Why: docs/step.md.
/// In 3-D the wall is the 2-D one extruded along z: a line is a plane parallel to z, a circle a cylinder about the
/// axis through (px, py) along z; the wall does not move along z.
struct MirrorWall {
  /// @{ a point of the wall line; a circle's centre
  double px = 0, py = 0;  /// @}
  /// @{ unit normal pointing into the fluid (lines only)
  double nx = 0, ny = 1;  /// @}
  /// @{ wall velocity U (tangential: a sliding wall; its particles need not move)
  double u = 0, v = 0;  /// @}
  int group = 0;          ///< the wall and dummy particles this applies to
  double radius = 0;      ///< > 0: a circular wall
  bool fluid_inside = false;  ///< circles: the fluid is inside the circle (else outside)
  double omega = 0;       ///< rotation rate of the wall velocity about (px, py) [rad/s]
  void validate() const;  ///< throws std::invalid_argument unless the normal has unit length, radius >= 0
  /// The wall's velocity at a point (x, y) of the wall or of its particles.
  [[nodiscard]] std::array<double, 2> velocity_at(double x, double y) const {
    return {u - omega * (y - py), v + omega * (x - px)};
  }
};

/// u(m) is the Shepard average of the fluid within `radius` of m, weighted by the bounded weight
/// re/(0.85 r + 0.15 re) - 1 (a mirror point may coincide with a fluid particle, where re/r - 1 is infinite);
/// a mirror point with no fluid in reach takes u(m) = U. `grid` must have been binned with `particles`. In 3-D the mirror
/// image keeps the particle's z, and the velocity along z is mirrored about 0.
template <int D>
void apply_mirror_velocity(const MirrorWall& wall, const BasicCellGrid<D>& grid, double radius,
                           BasicParticles<D>& particles);

/// How a MirrorPlane continues the fluid's velocity to its wall and dummy particles.
enum class MirrorExtension {
  /// 2 U - u(m), u(m) the Shepard average of the fluid around the mirror image m (Lan, Zhao & Wan 2022): the odd extension.
  /// It flips the velocity's curvature across the wall, and the average is one-sided beside the wall.
  odd,
  /// The quadratic equal to U on the plane, least-squares fitted to the fluid around m, at the particle: the smooth
  /// continuation, exact for every quadratic field that is U on the wall. Why: docs/method.md (the square duct).
  quadratic,
};

/// A flat no-slip wall in D dimensions by mirror velocities: MirrorWall's plane case (a line in 2-D, a plane in 3-D),
/// for every dimension. Every wall and dummy particle of `group` takes the fluid's velocity continued across the plane
/// (`extension`): by default 2 U - u(m), u(m) the fluid velocity at its mirror image m across the plane.
template <int D>
struct MirrorPlane {
  Vec<D> point{};     ///< a point of the plane [m]
  Vec<D> normal{};    ///< unit normal pointing into the fluid
  Vec<D> velocity{};  ///< the wall's velocity U (tangential: a sliding wall) [m/s]
  int group = 0;      ///< the wall and dummy particles it applies to
  MirrorExtension extension = MirrorExtension::odd;  ///< how the fluid's velocity is continued behind the plane
  void validate() const;  ///< throws std::invalid_argument unless finite with a unit normal
};

/// u(m) as apply_mirror_velocity's (the Shepard average of the fluid within `radius` of m). With
/// MirrorExtension::quadratic the fit takes the fluid within `radius` of m, with the same weights; where those
/// particles do not determine it (fewer than D + 1 independent ones), the particle takes the odd extension.
template <int D>
void apply_mirror_velocity(const MirrorPlane<D>& wall, const BasicCellGrid<D>& grid, double radius,
                           BasicParticles<D>& particles);

/// An open outlet with an outflow buffer: the layer of `thickness` upstream of the outlet line, and everything
/// beyond it, is held at gauge pressure 0, and its fluid leaves at the velocity of the fluid just upstream, along the
/// outflow direction, unmoved by the pressure gradient and the viscous term. Why not free-surface particles at
/// P = 0: docs/step.md.
template <int D>
struct BasicOutflowBuffer {
  Vec<D> point{};  ///< a point of the outlet line (a plane in 3-D), where fluid leaves [m]
  /// unit normal of the outlet, pointing out of the fluid (the outflow direction); +x by default
  Vec<D> normal = [] {
    Vec<D> x{};
    x[0] = 1.0;
    return x;
  }();
  double thickness = 0;   ///< [m] how far upstream of the outlet the buffer reaches; at least the largest kernel radius
  void validate() const;  ///< throws std::invalid_argument unless the normal has unit length and thickness > 0
  /// Signed distance past the buffer's upstream edge: > 0 inside the buffer (or beyond the outlet).
  [[nodiscard]] double depth(const Vec<D>& r) const {
    double s = 0.0;
    for (std::size_t a = 0; a < D; ++a) s += (r[a] - point[a]) * normal[a];
    return s + thickness;
  }
  [[nodiscard]] bool contains(const Vec<D>& r) const { return depth(r) > 0.0; }  ///< depth(r) > 0
};
using OutflowBuffer = BasicOutflowBuffer<2>;   ///< 2-D
using OutflowBuffer3 = BasicOutflowBuffer<3>;  ///< 3-D

/// Sets the velocity of every fluid particle i with in_buffer[i] != 0: the Shepard average (bounded weight) of
/// the fluid outside the buffer within `radius` of the point `radius` upstream of the buffer's edge, level with
/// i, its component along the outflow normal only; a particle with no such fluid in reach keeps its velocity's
/// normal component. `grid` must have been binned with `particles`.
template <int D>
void apply_outflow_velocity(const BasicOutflowBuffer<D>& buffer, const BasicCellGrid<D>& grid, double radius,
                            std::span<const char> in_buffer, BasicParticles<D>& particles);

/// Where a rigid body is at time t, relative to t = 0: rotated by `angle` (counter-clockwise) about its centre,
/// then shifted by (dx, dy); and how fast: omega = d angle/dt, (vx, vy) = d(dx, dy)/dt.
struct RigidPose {
  /// @{ angle [rad], omega [rad/s], shift (dx, dy) [m] and its rate (vx, vy) [m/s], as above
  double angle = 0, omega = 0, dx = 0, dy = 0, vx = 0, vy = 0;  /// @}
};
/// A rigid body's pose as a function of time.
using RigidPath = std::function<RigidPose(double time)>;
/// Constant rates from t = 0: angle = omega t and shift = v t, in closed form (no accumulated steps).
RigidPath steady_path(double omega, double vx = 0.0, double vy = 0.0);

/// A wall group (its wall and dummy particles) moved rigidly about the centre (cx, cy): each step its particles
/// are put at the pose of `path` applied to their positions at construction, and take the rigid velocity
/// omega z x (r - c - d) + v of the velocity path at their new positions. The positions come from the initial
/// ones each time, so a rotation stays exact (no drift of radius or angle over many steps).
/// The velocity path is the position path unless velocity_from() sets another: seed 000's barrel particles over
/// the channel opening follow the channel but are at rest (velocity path: steady_path(0)), and in its fixed-
/// boundary model the barrel stays put while its particles carry the barrel's relative rotation (position path:
/// steady_path(0), velocity path: steady_path(omega)). Call it from a BoundaryMotion component, and
/// once at t = 0 so the walls start with their velocity.
class RigidMotion {
 public:
  /// Moves the wall and dummy particles of `group` in `initial` (remembered by id) along `path` about (cx, cy).
  RigidMotion(const Particles& initial, int group, double cx, double cy, RigidPath path);
  RigidMotion& velocity_from(RigidPath path);  ///< a velocity path other than the position path; returns *this
  /// Puts the group's particles at the pose of time `time` with its rigid velocity; throws SimulationError if the
  /// path is not finite there.
  void operator()(Particles& particles, double time) const;
  [[nodiscard]] int group() const { return group_; }  ///< the group it moves
  [[nodiscard]] std::size_t size() const { return moved_; }  ///< wall and dummy particles it moves

 private:
  int group_;
  double cx_, cy_;
  RigidPath path_, velocity_path_;
  std::vector<double> x0_, y0_;  // by particle id: position at construction (NaN for particles not moved)
  std::size_t moved_ = 0;
};

/// Where a 3-D rigid body is at time t, relative to t = 0: rotated by `angle` about its axis (right-handed), then
/// shifted by `shift`; and how fast: omega = d angle/dt, velocity = d shift/dt.
struct RigidPose3 {
  /// @{ angle [rad] and omega [rad/s] about the axis
  double angle = 0, omega = 0;  /// @}
  /// @{ shift [m] and its rate [m/s]
  Vec<3> shift{}, velocity{};  /// @}
};
/// A 3-D rigid body's pose as a function of time.
using RigidPath3 = std::function<RigidPose3(double time)>;
/// Constant rates from t = 0: angle = omega t and shift = velocity t, in closed form.
RigidPath3 steady_path3(double omega, const Vec<3>& velocity = {});

/// RigidMotion in 3-D: a wall group turned about the axis through `centre` along `axis` (any length but zero) and
/// shifted, by the pose of `path` applied to its positions at construction (Rodrigues' rotation), with the rigid
/// velocity omega a x (r - c - shift) + velocity of the velocity path. A translation is a path with omega = 0.
class RigidMotion3 {
 public:
  /// Moves the wall and dummy particles of `group` in `initial` (remembered by id) along `path`; throws
  /// std::invalid_argument for a zero or non-finite axis, a non-finite centre or a group without such particles.
  RigidMotion3(const Particles3& initial, int group, const Vec<3>& centre, const Vec<3>& axis, RigidPath3 path);
  RigidMotion3& velocity_from(RigidPath3 path);  ///< a velocity path other than the position path; returns *this
  /// Puts the group's particles at the pose of time `time` with its rigid velocity; throws SimulationError if the
  /// path is not finite there.
  void operator()(Particles3& particles, double time) const;
  [[nodiscard]] int group() const { return group_; }  ///< the group it moves
  [[nodiscard]] std::size_t size() const { return moved_; }  ///< wall and dummy particles it moves
  [[nodiscard]] const Vec<3>& axis() const { return axis_; }  ///< the unit axis

 private:
  int group_;
  Vec<3> centre_, axis_;
  RigidPath3 path_, velocity_path_;
  std::vector<Vec<3>> start_;  // by particle id: position at construction (NaN for particles not moved)
  std::size_t moved_ = 0;
};

/// The constant-flow inlet and open outlet of a channel along +x (seed 004, Fig. 1). The plate, the wall and
/// dummy particles of `plate_group`, moves at `speed` from its starting position; whenever it has advanced one
/// spacing l0 it steps back by l0 and, one spacing ahead of its wall layer, a column of ghosts becomes fluid
/// moving at `speed` (one particle per plate wall particle, at its height: the ghosts of lowest id, taken in the wall
/// particles' id order, so that the choice does not depend on the particles' order). Fluid past `outlet_x` then
/// becomes a ghost parked one spacing behind the plate's last layer, at its height: the pool the inlet draws from in
/// later steps, kept beside the plate so that a partition by position keeps both on one process.
/// With the outlet open, the fluid next to it is free surface (P = 0).
/// Call it from a BoundaryMotion component (after the predictor, with the new time).
/// In 3-D the channel's cross-section is the plate's (y, z) layout: a column is one particle per plate wall particle.
template <int D>
class BasicPushingPlate {
 public:
  /// The plate is the wall and dummy particles of `plate_group` in `initial`; fluid it adds joins `fluid_group`.
  BasicPushingPlate(const BasicParticles<D>& initial, int plate_group, double speed, double l0, double outlet_x,
                    int fluid_group = 0);
  /// Moves the plate, adds the columns due and removes the outflow. Particles [0, owned) are this process's own, the
  /// rest halo copies of other processes' (a distributed step): copies are moved alike, but only owned ghosts fill a
  /// column, and only owned particles are counted. Throws SimulationError if the ghost pool runs dry (the scene must
  /// start with more ghosts) or if this process owns some of the plate's wall particles but not all.
  void operator()(BasicParticles<D>& particles, double time, std::size_t owned = static_cast<std::size_t>(-1));
  /// Fluid columns added so far: the plate's steps back, the same on every process.
  [[nodiscard]] int columns_added() const { return columns_; }
  /// Fluid particles turned to ghosts so far: this process's own only, so the sum over processes is the total.
  [[nodiscard]] long particles_removed() const { return removed_; }
  /// Where a ghost is parked: one spacing behind the plate's rearmost particle at the start [m].
  [[nodiscard]] double parking_x() const { return parking_x_; }
  /// @{ The counts a checkpoint holds (the rest follows from the particles and the time); a scene keeps the plate
  /// and saves it beside Simulation::checkpoint().
  [[nodiscard]] nlohmann::json save_state() const { return {{"columns", columns_}, {"removed", removed_}}; }
  void restore_state(const nlohmann::json& state) {
    columns_ = unpack_value<int>(state, "columns");
    removed_ = unpack_value<long>(state, "removed");
  }
  /// @}

 private:
  int fluid_group_;
  double speed_, l0_, outlet_x_, parking_x_ = 0;
  std::vector<double> start_x_;  // by particle id: the plate's particles' starting x (NaN for others)
  int walls_ = 0;                // the plate's wall particles
  int columns_ = 0;
  long removed_ = 0;
};
using PushingPlate = BasicPushingPlate<2>;   ///< 2-D
using PushingPlate3 = BasicPushingPlate<3>;  ///< 3-D
extern template class BasicPushingPlate<2>;
extern template class BasicPushingPlate<3>;

}  // namespace mps
