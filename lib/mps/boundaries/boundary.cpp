#include "mps/boundaries/boundary.hpp"
#include "mps/core/threads.hpp"

#include "mps/core/kernel.hpp"
#include "mps/core/vec.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <optional>
#include <stdexcept>
#include <string>

namespace mps {

namespace {
// The Shepard average (bounded weight) of the velocity of the fluid particles within `radius` of r that `takes(j)`
// accepts; nullopt if none is in reach. Mirror walls and the outflow buffer both sample the fluid so.
template <int D, class Takes>
std::optional<Vec<D>> fluid_velocity_near(const BasicCellGrid<D>& grid, const Kernel& shepard, const Vec<D>& r,
                                          const BasicParticles<D>& p, Takes takes) {
  const auto vel = p.velocities();
  double sw = 0.0;
  Vec<D> su{};
  grid.for_each_near(r, shepard.re, [&](int j, const Vec<D>& d) {
    const auto jj = static_cast<std::size_t>(j);
    if (p.kind[jj] != Kind::fluid || !takes(jj)) return;
    const double w = shepard.w(norm<D>(d));
    sw += w;
    for (std::size_t a = 0; a < D; ++a) su[a] += w * (*vel[a])[jj];
  });
  if (!(sw > 0.0)) return std::nullopt;
  Vec<D> out;
  for (std::size_t a = 0; a < D; ++a) out[a] = su[a] / sw;
  return out;
}
}  // namespace

void MirrorWall::validate() const {
  if (!std::isfinite(px) || !std::isfinite(py) || !std::isfinite(u) || !std::isfinite(v))
    throw std::invalid_argument("mirror wall: point and velocity must be finite");
  if (!(radius >= 0.0) || !std::isfinite(radius) || !std::isfinite(omega))
    throw std::invalid_argument("mirror wall: radius must be >= 0 (0: a line) and omega finite");
  if (radius == 0.0 && !(std::abs(std::hypot(nx, ny) - 1.0) < 1e-9))
    throw std::invalid_argument("mirror wall: the normal (nx, ny) must have unit length");
}

template <int D>
void apply_mirror_velocity(const MirrorWall& wall, const BasicCellGrid<D>& grid, double radius, BasicParticles<D>& p) {
  wall.validate();
  if (!(radius > 0.0) || radius > grid.cell_size() * (1.0 + 1e-12))
    throw std::invalid_argument("apply_mirror_velocity: radius must be in (0, the grid's cell size]");
  const Kernel shepard{Weight::bounded, radius, 0.0, 0.0, 0, D};
  const auto n = static_cast<std::ptrdiff_t>(p.size());
  // Writes go to walls and dummies, reads come from fluid only: the loop has no dependence between particles.
#pragma omp parallel for schedule(static) if (detail::worth_threads(n))
  for (std::ptrdiff_t ii = 0; ii < n; ++ii) {
    const auto i = static_cast<std::size_t>(ii);
    if ((p.kind[i] != Kind::wall && p.kind[i] != Kind::dummy) || p.group[i] != wall.group) continue;
    double nx = wall.nx, ny = wall.ny, depth = 0.0;  // depth < 0 behind the wall
    if (wall.radius > 0.0) {
      const double dx = p.x[i] - wall.px, dy = p.y[i] - wall.py, r = std::hypot(dx, dy);
      if (r == 0.0) continue;  // the centre has no radial direction (and no business being a wall particle)
      const double sign = wall.fluid_inside ? -1.0 : 1.0;
      nx = sign * dx / r;
      ny = sign * dy / r;
      depth = sign * (r - wall.radius);
    } else {
      depth = (p.x[i] - wall.px) * nx + (p.y[i] - wall.py) * ny;
    }
    Vec<D> mirror = p.position(i);  // in 3-D at the particle's own z: the wall is extruded along z
    mirror[0] = p.x[i] - 2.0 * depth * nx;
    mirror[1] = p.y[i] - 2.0 * depth * ny;
    const auto U = wall.velocity_at(p.x[i] - depth * nx, p.y[i] - depth * ny);  // at the foot on the wall
    const auto m = fluid_velocity_near<D>(grid, shepard, mirror, p, [](std::size_t) { return true; });
    const double um = m ? (*m)[0] : U[0], vm = m ? (*m)[1] : U[1];
    p.u[i] = 2.0 * U[0] - um;
    p.v[i] = 2.0 * U[1] - vm;
    if constexpr (D == 3) p.w[i] = m ? -(*m)[2] : 0.0;  // the wall does not move along z
  }
}

template void apply_mirror_velocity(const MirrorWall&, const BasicCellGrid<2>&, double, BasicParticles<2>&);
template void apply_mirror_velocity(const MirrorWall&, const BasicCellGrid<3>&, double, BasicParticles<3>&);

namespace {
// MirrorExtension::quadratic at a particle `depth` (< 0) behind the plane, m its mirror image: the fluid within
// shepard.re of m fits u - U = s (c0 + c . q) by weighted least squares, q the offset from the particle's foot on the
// plane and s = q . n its depth into the fluid (D + 1 unknowns: s, s^2 and s times each tangential offset span every
// quadratic that is U on the plane); the fit is then read at the particle, q = depth n. nullopt where the normal
// equations are singular to round-off (too few fluid particles, or all at one depth).
template <int D>
std::optional<Vec<D>> quadratic_continuation(const MirrorPlane<D>& wall, const BasicCellGrid<D>& grid,
                                             const Kernel& shepard, const Vec<D>& mirror, double depth,
                                             const BasicParticles<D>& p) {
  constexpr std::size_t n = D + 1;
  const auto vel = p.velocities();
  const double scale = 1.0 / shepard.re;  // offsets in units of the radius keep the normal equations O(1)
  std::array<std::array<double, n>, n> m{};
  std::array<Vec<D>, n> b{};  // right-hand side, one column per velocity component
  // basis(q) = (s, s q_0, ..., s q_{D-1}), q in units of the radius
  const auto basis = [&](const Vec<D>& q) {
    const double s = dot<D>(q, wall.normal);
    std::array<double, n> phi{};
    phi[0] = s;
    for (std::size_t a = 0; a < D; ++a) phi[a + 1] = s * q[a];
    return phi;
  };
  grid.for_each_near(mirror, shepard.re, [&](int j, const Vec<D>& d) {
    const auto jj = static_cast<std::size_t>(j);
    if (p.kind[jj] != Kind::fluid) return;
    const double w = shepard.w(norm<D>(d));
    Vec<D> q;  // from the foot, which lies depth n from the mirror image towards the wall
    for (std::size_t a = 0; a < D; ++a) q[a] = (d[a] - depth * wall.normal[a]) * scale;
    const auto phi = basis(q);
    for (std::size_t r = 0; r < n; ++r) {
      for (std::size_t c = 0; c < n; ++c) m[r][c] += w * phi[r] * phi[c];
      for (std::size_t a = 0; a < D; ++a) b[r][a] += w * phi[r] * ((*vel[a])[jj] - wall.velocity[a]);
    }
  });
  // Gaussian elimination with partial pivoting; a pivot below round-off of the largest diagonal means singular.
  double largest = 0.0;
  for (std::size_t r = 0; r < n; ++r) largest = std::max(largest, m[r][r]);
  if (!(largest > 0.0)) return std::nullopt;
  for (std::size_t k = 0; k < n; ++k) {
    std::size_t pivot = k;
    for (std::size_t r = k + 1; r < n; ++r)
      if (std::abs(m[r][k]) > std::abs(m[pivot][k])) pivot = r;
    if (!(std::abs(m[pivot][k]) > 1e-10 * largest)) return std::nullopt;
    std::swap(m[k], m[pivot]);
    std::swap(b[k], b[pivot]);
    for (std::size_t r = k + 1; r < n; ++r) {
      const double f = m[r][k] / m[k][k];
      for (std::size_t c = k; c < n; ++c) m[r][c] -= f * m[k][c];
      for (std::size_t a = 0; a < D; ++a) b[r][a] -= f * b[k][a];
    }
  }
  std::array<Vec<D>, n> coef{};
  for (std::size_t k = n; k-- > 0;) {
    Vec<D> x = b[k];
    for (std::size_t c = k + 1; c < n; ++c)
      for (std::size_t a = 0; a < D; ++a) x[a] -= m[k][c] * coef[c][a];
    for (std::size_t a = 0; a < D; ++a) coef[k][a] = x[a] / m[k][k];
  }
  Vec<D> at;  // the particle, from its foot
  for (std::size_t a = 0; a < D; ++a) at[a] = depth * wall.normal[a] * scale;
  const auto phi = basis(at);
  Vec<D> u = wall.velocity;
  for (std::size_t k = 0; k < n; ++k)
    for (std::size_t a = 0; a < D; ++a) u[a] += phi[k] * coef[k][a];
  return u;
}
}  // namespace

template <int D>
void MirrorPlane<D>::validate() const {
  for (std::size_t a = 0; a < D; ++a)
    if (!std::isfinite(point[a]) || !std::isfinite(velocity[a]) || !std::isfinite(normal[a]))
      throw std::invalid_argument("mirror plane: point, normal and velocity must be finite");
  if (!(std::abs(norm<D>(normal) - 1.0) < 1e-9)) throw std::invalid_argument("mirror plane: the normal must have unit length");
}

template <int D>
void apply_mirror_velocity(const MirrorPlane<D>& wall, const BasicCellGrid<D>& grid, double radius,
                           BasicParticles<D>& p) {
  wall.validate();
  if (!(radius > 0.0) || radius > grid.cell_size() * (1.0 + 1e-12))
    throw std::invalid_argument("apply_mirror_velocity: radius must be in (0, the grid's cell size]");
  const Kernel shepard{Weight::bounded, radius, 0.0, 0.0, 0, D};
  const auto n = static_cast<std::ptrdiff_t>(p.size());
  const auto vel = p.velocities();
  // Writes go to walls and dummies, reads come from fluid only: the loop has no dependence between particles.
#pragma omp parallel for schedule(static) if (detail::worth_threads(n))
  for (std::ptrdiff_t ii = 0; ii < n; ++ii) {
    const auto i = static_cast<std::size_t>(ii);
    if ((p.kind[i] != Kind::wall && p.kind[i] != Kind::dummy) || p.group[i] != wall.group) continue;
    const Vec<D> r = p.position(i);
    Vec<D> offset;
    for (std::size_t a = 0; a < D; ++a) offset[a] = r[a] - wall.point[a];
    const double depth = dot<D>(offset, wall.normal);  // < 0 behind the wall
    Vec<D> mirror, sum{};
    for (std::size_t a = 0; a < D; ++a) mirror[a] = r[a] - 2.0 * depth * wall.normal[a];
    if (wall.extension == MirrorExtension::quadratic) {
      if (const auto u = quadratic_continuation<D>(wall, grid, shepard, mirror, depth, p)) {
        for (std::size_t a = 0; a < D; ++a) (*vel[a])[i] = (*u)[a];
        continue;
      }
    }
    double sw = 0.0;
    grid.for_each_near(mirror, shepard.re, [&](int j, const Vec<D>& d) {
      const auto jj = static_cast<std::size_t>(j);
      if (p.kind[jj] != Kind::fluid) return;
      const double w = shepard.w(norm<D>(d));
      sw += w;
      for (std::size_t a = 0; a < D; ++a) sum[a] += w * (*vel[a])[jj];
    });
    for (std::size_t a = 0; a < D; ++a)
      (*vel[a])[i] = 2.0 * wall.velocity[a] - (sw > 0.0 ? sum[a] / sw : wall.velocity[a]);
  }
}

template struct MirrorPlane<2>;
template struct MirrorPlane<3>;
template void apply_mirror_velocity(const MirrorPlane<2>&, const BasicCellGrid<2>&, double, BasicParticles<2>&);
template void apply_mirror_velocity(const MirrorPlane<3>&, const BasicCellGrid<3>&, double, BasicParticles<3>&);

template <int D>
void BasicOutflowBuffer<D>::validate() const {
  double length2 = 0.0;
  for (std::size_t a = 0; a < D; ++a) {
    if (!std::isfinite(point[a])) throw std::invalid_argument("outflow buffer: point must be finite");
    length2 += normal[a] * normal[a];
  }
  if (!(std::abs(std::sqrt(length2) - 1.0) < 1e-9))
    throw std::invalid_argument("outflow buffer: the normal must have unit length");
  if (!(thickness > 0.0) || !std::isfinite(thickness))
    throw std::invalid_argument("outflow buffer: thickness must be positive");
}

template <int D>
void apply_outflow_velocity(const BasicOutflowBuffer<D>& buffer, const BasicCellGrid<D>& grid, double radius,
                            std::span<const char> in_buffer, BasicParticles<D>& p) {
  buffer.validate();
  if (!(radius > 0.0) || radius > grid.cell_size() * (1.0 + 1e-12))
    throw std::invalid_argument("apply_outflow_velocity: radius must be in (0, the grid's cell size]");
  if (in_buffer.size() != p.size()) throw std::invalid_argument("apply_outflow_velocity: one flag per particle");
  const Kernel shepard{Weight::bounded, radius, 0.0, 0.0, 0};
  const auto vel = p.velocities();
  const auto n = static_cast<std::ptrdiff_t>(p.size());
  // Writes go to buffer particles, reads come from fluid outside it only: no dependence between particles.
#pragma omp parallel for schedule(static) if (detail::worth_threads(n))
  for (std::ptrdiff_t ii = 0; ii < n; ++ii) {
    const auto i = static_cast<std::size_t>(ii);
    if (p.kind[i] != Kind::fluid || !in_buffer[i]) continue;
    const Vec<D> r = p.position(i);
    const double back = buffer.depth(r) + radius;
    Vec<D> upstream;
    for (std::size_t a = 0; a < D; ++a) upstream[a] = r[a] - back * buffer.normal[a];
    const auto m = fluid_velocity_near<D>(grid, shepard, upstream, p, [&](std::size_t j) { return !in_buffer[j]; });
    double un = 0.0;
    for (std::size_t a = 0; a < D; ++a) un += (m ? (*m)[a] : (*vel[a])[i]) * buffer.normal[a];
    for (std::size_t a = 0; a < D; ++a) (*vel[a])[i] = un * buffer.normal[a];
  }
}

template struct BasicOutflowBuffer<2>;
template struct BasicOutflowBuffer<3>;
template void apply_outflow_velocity(const BasicOutflowBuffer<2>&, const BasicCellGrid<2>&, double,
                                     std::span<const char>, BasicParticles<2>&);
template void apply_outflow_velocity(const BasicOutflowBuffer<3>&, const BasicCellGrid<3>&, double,
                                     std::span<const char>, BasicParticles<3>&);

RigidPath steady_path(double omega, double vx, double vy) {
  if (!std::isfinite(omega) || !std::isfinite(vx) || !std::isfinite(vy))
    throw std::invalid_argument("steady_path: omega and velocity must be finite");
  return [=](double t) { return RigidPose{omega * t, omega, vx * t, vy * t, vx, vy}; };
}

RigidMotion::RigidMotion(const Particles& initial, int group, double cx, double cy, RigidPath path)
    : group_(group), cx_(cx), cy_(cy), path_(std::move(path)), velocity_path_(path_) {
  if (!path_) throw std::invalid_argument("rigid motion: no path given");
  if (!std::isfinite(cx) || !std::isfinite(cy)) throw std::invalid_argument("rigid motion: centre must be finite");
  int max_id = -1;
  for (std::size_t i = 0; i < initial.size(); ++i) max_id = std::max(max_id, initial.id[i]);
  x0_.assign(static_cast<std::size_t>(max_id + 1), std::nan(""));
  y0_ = x0_;
  for (std::size_t i = 0; i < initial.size(); ++i) {
    if (initial.group[i] != group || (initial.kind[i] != Kind::wall && initial.kind[i] != Kind::dummy)) continue;
    x0_[static_cast<std::size_t>(initial.id[i])] = initial.x[i];
    y0_[static_cast<std::size_t>(initial.id[i])] = initial.y[i];
    ++moved_;
  }
  if (moved_ == 0)
    throw std::invalid_argument("rigid motion: group " + std::to_string(group) + " has no wall or dummy particles");
}

RigidMotion& RigidMotion::velocity_from(RigidPath path) {
  if (!path) throw std::invalid_argument("rigid motion: no velocity path given");
  velocity_path_ = std::move(path);
  return *this;
}

void RigidMotion::operator()(Particles& p, double time) const {
  const RigidPose at = path_(time), vel = velocity_path_(time);
  if (!std::isfinite(at.angle) || !std::isfinite(at.dx) || !std::isfinite(at.dy) || !std::isfinite(vel.omega) ||
      !std::isfinite(vel.vx) || !std::isfinite(vel.vy))
    throw SimulationError("rigid motion of group " + std::to_string(group_) + ": the path is not finite at t = " +
                          std::to_string(time) + " s");
  const double c = std::cos(at.angle), s = std::sin(at.angle);
  for (std::size_t i = 0; i < p.size(); ++i) {
    const auto id = static_cast<std::size_t>(p.id[i]);
    if (id >= x0_.size() || std::isnan(x0_[id])) continue;
    const double rx = x0_[id] - cx_, ry = y0_[id] - cy_;
    p.x[i] = cx_ + at.dx + c * rx - s * ry;
    p.y[i] = cy_ + at.dy + s * rx + c * ry;
    // The velocity path's centre has moved with its own shift, not necessarily with the positions'.
    const double qx = p.x[i] - cx_ - vel.dx, qy = p.y[i] - cy_ - vel.dy;
    p.u[i] = vel.vx - vel.omega * qy;
    p.v[i] = vel.vy + vel.omega * qx;
  }
}

RigidPath3 steady_path3(double omega, const Vec<3>& velocity) {
  return [omega, velocity](double t) {
    return RigidPose3{omega * t, omega, {velocity[0] * t, velocity[1] * t, velocity[2] * t}, velocity};
  };
}

RigidMotion3::RigidMotion3(const Particles3& initial, int group, const Vec<3>& centre, const Vec<3>& axis,
                           RigidPath3 path)
    : group_(group), centre_(centre), path_(std::move(path)), velocity_path_(path_) {
  if (!path_) throw std::invalid_argument("rigid motion: no path given");
  const double length = norm<3>(axis);
  if (!(length > 0.0) || !std::isfinite(length))
    throw std::invalid_argument("rigid motion: the axis must be a finite, non-zero vector");
  for (std::size_t a = 0; a < 3; ++a) {
    axis_[a] = axis[a] / length;
    if (!std::isfinite(centre[a])) throw std::invalid_argument("rigid motion: centre must be finite");
  }
  int max_id = -1;
  for (std::size_t i = 0; i < initial.size(); ++i) max_id = std::max(max_id, initial.id[i]);
  const double nan = std::nan("");
  start_.assign(static_cast<std::size_t>(max_id + 1), Vec<3>{nan, nan, nan});
  for (std::size_t i = 0; i < initial.size(); ++i) {
    if (initial.group[i] != group || (initial.kind[i] != Kind::wall && initial.kind[i] != Kind::dummy)) continue;
    start_[static_cast<std::size_t>(initial.id[i])] = initial.position(i);
    ++moved_;
  }
  if (moved_ == 0)
    throw std::invalid_argument("rigid motion: group " + std::to_string(group) + " has no wall or dummy particles");
}

RigidMotion3& RigidMotion3::velocity_from(RigidPath3 path) {
  if (!path) throw std::invalid_argument("rigid motion: no velocity path given");
  velocity_path_ = std::move(path);
  return *this;
}

namespace {
Vec<3> cross(const Vec<3>& a, const Vec<3>& b) {
  return {a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]};
}
bool finite(const Vec<3>& v) { return std::isfinite(v[0]) && std::isfinite(v[1]) && std::isfinite(v[2]); }
}  // namespace

// Rodrigues: R r = r cos + (a x r) sin + a (a . r)(1 - cos).
void RigidMotion3::operator()(Particles3& p, double time) const {
  const RigidPose3 at = path_(time), vel = velocity_path_(time);
  if (!std::isfinite(at.angle) || !finite(at.shift) || !std::isfinite(vel.omega) || !finite(vel.shift) ||
      !finite(vel.velocity))
    throw SimulationError("rigid motion of group " + std::to_string(group_) + ": the path is not finite at t = " +
                          std::to_string(time) + " s");
  const double c = std::cos(at.angle), s = std::sin(at.angle);
  for (std::size_t i = 0; i < p.size(); ++i) {
    const auto id = static_cast<std::size_t>(p.id[i]);
    if (id >= start_.size() || std::isnan(start_[id][0])) continue;
    Vec<3> r;
    for (std::size_t a = 0; a < 3; ++a) r[a] = start_[id][a] - centre_[a];
    const Vec<3> axr = cross(axis_, r);
    const double along = dot<3>(axis_, r) * (1.0 - c);
    Vec<3> q;
    for (std::size_t a = 0; a < 3; ++a) {
      const double turned = r[a] * c + axr[a] * s + axis_[a] * along;
      (a == 0 ? p.x : a == 1 ? p.y : p.z)[i] = centre_[a] + at.shift[a] + turned;
      // The velocity path's centre has moved with its own shift, not necessarily with the positions'.
      q[a] = turned + at.shift[a] - vel.shift[a];
    }
    const Vec<3> spin = cross(axis_, q);
    p.u[i] = vel.velocity[0] + vel.omega * spin[0];
    p.v[i] = vel.velocity[1] + vel.omega * spin[1];
    p.w[i] = vel.velocity[2] + vel.omega * spin[2];
  }
}

template <int D>
BasicPushingPlate<D>::BasicPushingPlate(const BasicParticles<D>& initial, int plate_group, double speed, double l0,
                                        double outlet_x, int fluid_group)
    : fluid_group_(fluid_group), speed_(speed), l0_(l0), outlet_x_(outlet_x) {
  if (!(speed > 0.0) || !std::isfinite(speed)) throw std::invalid_argument("pushing plate: speed must be positive");
  if (!(l0 > 0.0) || !std::isfinite(l0)) throw std::invalid_argument("pushing plate: spacing l0 must be positive");
  if (!std::isfinite(outlet_x)) throw std::invalid_argument("pushing plate: outlet_x must be finite");
  int max_id = -1;
  for (std::size_t i = 0; i < initial.size(); ++i) max_id = std::max(max_id, initial.id[i]);
  start_x_.assign(static_cast<std::size_t>(max_id + 1), std::nan(""));
  double rearmost = std::numeric_limits<double>::infinity();
  for (std::size_t i = 0; i < initial.size(); ++i) {
    if (initial.group[i] != plate_group || (initial.kind[i] != Kind::wall && initial.kind[i] != Kind::dummy)) continue;
    start_x_[static_cast<std::size_t>(initial.id[i])] = initial.x[i];
    walls_ += initial.kind[i] == Kind::wall;
    rearmost = std::min(rearmost, initial.x[i]);
  }
  if (walls_ == 0)
    throw std::invalid_argument("pushing plate: group " + std::to_string(plate_group) + " has no wall particles");
  parking_x_ = rearmost - l0;
}

template <int D>
void BasicPushingPlate<D>::operator()(BasicParticles<D>& p, double time, std::size_t owned) {
  owned = std::min(owned, p.size());
  const auto r = p.positions();
  const auto vel = p.velocities();
  // The plate's velocity (speed along x) on particle i, and a particle's velocity and pressure cleared.
  auto set_velocity = [&](std::size_t i, double u) {
    (*vel[0])[i] = u;
    for (std::size_t a = 1; a < D; ++a) (*vel[a])[i] = 0.0;
  };
  // The plate has stepped back floor(U t / l0) times; each step back leaves a gap of one column.
  const int steps_back = static_cast<int>(std::floor(speed_ * time / l0_));
  const double advance = speed_ * time - steps_back * l0_;
  std::vector<std::size_t> plate_walls;
  for (std::size_t i = 0; i < p.size(); ++i) {
    const auto id = static_cast<std::size_t>(p.id[i]);
    if (id >= start_x_.size() || std::isnan(start_x_[id])) continue;
    p.x[i] = start_x_[id] + advance;
    set_velocity(i, speed_);
    if (p.kind[i] == Kind::wall && i < owned) plate_walls.push_back(i);
  }
  const int new_columns = steps_back - columns_;
  // The columns come from the pool as the step found it (before this step's outflow joins it), the lowest ids first:
  // the same ghosts whichever process holds the plate and whatever the particles' order.
  if (new_columns > 0 && !plate_walls.empty()) {
    if (plate_walls.size() != static_cast<std::size_t>(walls_))
      throw SimulationError("pushing plate: this process owns " + std::to_string(plate_walls.size()) + " of the plate's " +
                            std::to_string(walls_) + " wall particles; the partition must keep the plate (and the " +
                            "ghosts parked behind it) on one process");
    auto by_id = [&](std::size_t a, std::size_t b) { return p.id[a] < p.id[b]; };
    std::sort(plate_walls.begin(), plate_walls.end(), by_id);
    std::vector<std::size_t> ghosts;
    for (std::size_t i = 0; i < owned; ++i)
      if (p.kind[i] == Kind::ghost) ghosts.push_back(i);
    const std::size_t needed = plate_walls.size() * static_cast<std::size_t>(new_columns);
    if (ghosts.size() < needed)
      throw SimulationError("pushing plate: the inlet needs " + std::to_string(needed) + " ghost particles for its " +
                            "new column but only " + std::to_string(ghosts.size()) + " are left; start the scene " +
                            "with a larger ghost pool");
    std::partial_sort(ghosts.begin(), ghosts.begin() + static_cast<std::ptrdiff_t>(needed), ghosts.end(), by_id);
    std::size_t next = 0;
    for (int c = 1; c <= new_columns; ++c)
      for (std::size_t w : plate_walls) {  // a column at the plate's wall particles' heights (y, and z in 3-D)
        const std::size_t g = ghosts[next++];
        p.x[g] = p.x[w] + c * l0_;
        for (std::size_t a = 1; a < D; ++a) (*r[a])[g] = (*r[a])[w];
        set_velocity(g, speed_);
        p.p[g] = 0.0;
        p.kind[g] = Kind::fluid;
        p.group[g] = fluid_group_;
      }
  }
  columns_ = std::max(columns_, steps_back);
  // Copies are removed alike (their owners do the same), but counted by their owners only.
  for (std::size_t i = 0; i < p.size(); ++i)
    if (p.kind[i] == Kind::fluid && p.x[i] > outlet_x_) {
      p.kind[i] = Kind::ghost;
      p.x[i] = parking_x_;
      set_velocity(i, 0.0);
      p.p[i] = 0.0;
      removed_ += i < owned;
    }
}

template class BasicPushingPlate<2>;
template class BasicPushingPlate<3>;

}  // namespace mps
