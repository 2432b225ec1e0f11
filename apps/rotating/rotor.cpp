#include "rotor.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <memory>
#include <numbers>
#include <stdexcept>

#include "mps/boundaries/boundary.hpp"
#include "mps/boundaries/geometry.hpp"
#include "mps/core/state.hpp"
#include "mps/step/components.hpp"

namespace rotating {

Scene parse_scene(const std::string& name) {
  if (name == "couette") return Scene::couette;
  if (name == "channel") return Scene::channel;
  throw std::invalid_argument("unknown scene '" + name + "': use couette or channel");
}

Model parse_model(const std::string& name) {
  if (name == "moving") return Model::moving;
  if (name == "fixed") return Model::fixed;
  throw std::invalid_argument("unknown model '" + name + "': use moving or fixed");
}

std::string to_string(Scene scene) { return scene == Scene::couette ? "couette" : "channel"; }
std::string to_string(Model model) { return model == Model::moving ? "moving" : "fixed"; }

namespace {
constexpr int kLayers = 5;  // one wall layer and four dummy layers: the 4.1 l0 Laplacian's reach
constexpr double kCentre = std::numbers::pi / 2;  // the channel's centre line at t = 0, in lab angle

// Ring k lies at R1 + (k + 1/2) l0; k < 0 the inner wall, k >= across the outer.
double ring_radius(const Params& p, int k) { return p.R1 + (k + 0.5) * p.l0(); }
// Particles a ring of the channel holds over the opening. r span / l0 is a half-integer on the barrel's wall ring,
// so the layout and every sampler of that ring must round the same radius, computed the same way.
int ring_count(const Params& p, double r) { return mps::annulus_ring_count(r, p.span, p.l0()); }
}  // namespace

void Params::validate() const {
  auto positive = [](double v) { return v > 0.0 && std::isfinite(v); };
  auto fail = [](const std::string& what) { throw std::invalid_argument("rotating: " + what); };
  if (!positive(R1) || !(R2 > R1) || !std::isfinite(R2))
    fail("radii must satisfy 0 < R1 < R2, got R1 = " + std::to_string(R1) + ", R2 = " + std::to_string(R2));
  if (!(across >= 4.0) || std::abs(across - std::round(across)) > 1e-9)
    fail("particles across the gap must be a whole number >= 4, got " + std::to_string(across));
  if (R1 - kLayers * l0() < 0.5 * l0())
    fail("the inner wall's five layers need R1 >= 5.5 l0: raise --across or R1");
  if (scene == Scene::channel && !(span > 0.0 && span * R1 >= 3.0 * l0() && span < 2.0 * std::numbers::pi - 0.5))
    fail("channel span must be in (3 l0/R1, 2 pi - 0.5) rad, got " + std::to_string(span));
  if (!positive(omega)) fail("omega must be positive (the sense of rotation is fixed by the scene)");
  if (!positive(rho) || !positive(nu)) fail("rho and nu must be positive");
  if (!(gamma >= 0.0 && gamma <= 1.0)) fail("gamma must be in [0, 1], got " + std::to_string(gamma));
  if (!positive(dt_factor)) fail("dt_factor must be positive");
  if (!(shifting >= 0.0 && std::isfinite(shifting))) fail("shifting must be >= 0 (0: off)");
  if (dim != 2 && dim != 3) fail("the dimension must be 2 or 3, got " + std::to_string(dim));
  if (dim == 3 && scene != Scene::couette) fail("the channel is 2-D only (its flights are planar): use --dim 2");
}

double couette_exact(const Params& p, double r) {
  const double a2 = p.R1 * p.R1, b2 = p.R2 * p.R2;
  const double A = -p.omega * a2 / (b2 - a2), B = p.omega * a2 * b2 / (b2 - a2);
  return A * r + B / r;
}

mps::Particles make_particles(const Params& p) {
  p.validate();
  mps::Particles s;
  mps::fill_walled_annulus(s, p.R1, static_cast<int>(std::lround(p.across)), p.l0(), 1, kLayers - 1,
                           p.scene == Scene::couette ? 2.0 * std::numbers::pi : p.span, kCentre,
                           {kFluidGroup, kInnerGroup, kOuterGroup, kFlightGroup});
  return s;
}

double frame_angle(const Params& p, double time) {
  return p.scene == Scene::channel && p.model == Model::moving ? -p.omega * time : 0.0;
}

double frame_rate(const Params& p) { return p.scene == Scene::channel && p.model == Model::moving ? -p.omega : 0.0; }

namespace {
mps::SimulationConfig make_config(const Params& p) {
  const double l0 = p.l0();
  mps::SimulationConfig c;
  c.l0 = l0;
  c.rho = p.rho;
  c.nu = p.nu;
  c.gamma = p.gamma;
  c.pressure_gradient = p.gradient;
  c.initial_reference_density = p.initial_reference;
  // The CFL and viscous limits set dt; dt_max, ten times the larger, never binds.
  c.dt_max = 10.0 * p.dt_factor * std::max(c.cfl * l0 / p.U(), c.viscous_number * l0 * l0 / p.nu);
  c.cfl *= p.dt_factor;
  c.viscous_number *= p.dt_factor;
  c.solver = p.solver;
  c.dt_option = "--dt-factor";
  c.warm_start = p.warm_start;
  c.shifting = p.shifting;
  if (p.dim == 3) c.radius_density = c.radius_laplacian = 3.1;
  return c;
}

// The walls' mirror circles (inner, outer) and their rotation rates; adds them when `mirror` is on.
template <int D>
void add_mirror_walls(const Params& p, double w_inner, double w_outer, mps::BasicSimulation<D>& sim) {
  if (!p.mirror) return;
  mps::MirrorWall inner, outer;
  inner.group = kInnerGroup;
  inner.radius = p.R1;
  inner.omega = w_inner;
  outer.group = kOuterGroup;
  outer.radius = p.R2;
  outer.fluid_inside = true;
  outer.omega = w_outer;
  sim.template add<mps::BasicMirrorNoSlip<D>>(inner);
  sim.template add<mps::BasicMirrorNoSlip<D>>(outer);
}
}  // namespace

mps::Simulation make_simulation(const Params& p) {
  const double l0 = p.l0(), half = p.R2 + (kLayers + 1) * l0;
  const mps::SimulationConfig c = make_config(p);
  mps::Particles particles = make_particles(p);
  std::vector<mps::RigidMotion> motions;
  // Mirror circles: the wall velocity as a rotation about the origin (inner, outer).
  double w_inner = 0.0, w_outer = 0.0;
  if (p.scene == Scene::couette) {
    motions.emplace_back(particles, kInnerGroup, 0.0, 0.0, mps::steady_path(p.omega));
    w_inner = p.omega;
  } else if (p.model == Model::moving) {
    motions.emplace_back(particles, kInnerGroup, 0.0, 0.0, mps::steady_path(-p.omega));
    motions.emplace_back(particles, kFlightGroup, 0.0, 0.0, mps::steady_path(-p.omega));
    motions.emplace_back(particles, kOuterGroup, 0.0, 0.0, mps::steady_path(-p.omega)).velocity_from(mps::steady_path(0.0));
    w_inner = -p.omega;
  } else {
    motions.emplace_back(particles, kOuterGroup, 0.0, 0.0, mps::steady_path(0.0)).velocity_from(mps::steady_path(p.omega));
    w_outer = p.omega;
  }
  for (const mps::RigidMotion& m : motions) m(particles, 0.0);  // walls start at their velocity
  mps::Simulation sim(std::move(particles), {-half, half, -half, half}, c);
  sim.add<mps::BoundaryMotion>([motions](mps::Particles& s, double t) {
    for (const mps::RigidMotion& m : motions) m(s, t);
  });
  // Closed: a low number density is a void for the source term to close, not a free surface at P = 0 (at small
  // gamma a few particles by the corners were flagged, which anchored the gauge and clamped their pressure).
  sim.add<mps::SurfaceRegion>([](double, double) { return false; });
  add_mirror_walls(p, w_inner, w_outer, sim);
  return sim;
}

int period_layers(const Params& p) {
  return static_cast<int>(std::ceil(3.0 * make_config(p).largest_radius() - 1e-9));
}

mps::Particles3 make_particles3(const Params& p) {
  if (p.scene != Scene::couette) throw std::invalid_argument("rotating: only the couette scene runs in 3-D");
  return mps::extrude(make_particles(p), 0.0, p.l0(), period_layers(p));
}

mps::Simulation3 make_simulation3(const Params& p) {
  const double l0 = p.l0(), half = p.R2 + (kLayers + 1) * l0;
  mps::Particles3 particles = make_particles3(p);
  const mps::RigidMotion3 inner(particles, kInnerGroup, {0.0, 0.0, 0.0}, {0.0, 0.0, 1.0}, mps::steady_path3(p.omega));
  inner(particles, 0.0);  // the inner cylinder starts at its velocity
  const mps::Domain3 domain{-half, half, -half, half, 0.0, period_layers(p) * l0, false, false, true};
  mps::Simulation3 sim(std::move(particles), domain, make_config(p));
  sim.add<mps::BoundaryMotion3>([inner](mps::Particles3& s, double t) { inner(s, t); });
  sim.add<mps::SurfaceRegion3>([](const mps::Vec<3>&) { return false; });  // closed, as in 2-D
  add_mirror_walls(p, p.omega, 0.0, sim);
  return sim;
}

void relative_velocity(const Params& p, const mps::Particles& s, std::vector<double>& ur, std::vector<double>& vr) {
  const double w = frame_rate(p);
  ur.resize(s.size());
  vr.resize(s.size());
  for (std::size_t i = 0; i < s.size(); ++i) {
    ur[i] = s.u[i] + w * s.y[i];
    vr[i] = s.v[i] - w * s.x[i];
  }
}

LineSampler::LineSampler(const Params& p, Line line) : p_(p), line_(line) {
  const double l0 = p.l0();
  if (line == Line::couette || line == Line::line1) {
    lo_ = p.R1;
    width_ = l0;
    sum_.assign(static_cast<std::size_t>(std::lround(p.across)), 0.0);
  } else {
    // Arc bins one ring spacing wide, on the arc's radius (arc 2) or on the barrel's wall ring.
    const double r = line == Line::arc2 ? 0.5 * (p.R1 + p.R2) : ring_radius(p, static_cast<int>(std::lround(p.across)));
    const int m = ring_count(p, r);
    width_ = p.span / m;
    const int extra = line == Line::barrel ? kLayers : 0;  // the barrel's wall ring reaches over the flights
    lo_ = -0.5 * p.span - extra * width_;
    sum_.assign(static_cast<std::size_t>(m + 2 * extra), 0.0);
  }
  count_.assign(sum_.size(), 0);
}

void LineSampler::clear() {
  std::fill(sum_.begin(), sum_.end(), 0.0);
  std::fill(count_.begin(), count_.end(), 0);
  samples_ = 0;
}

nlohmann::json LineSampler::save_state() const {
  return {{"sum", mps::pack_array(sum_)}, {"count", mps::pack_array(count_)}, {"samples", samples_}};
}

void LineSampler::restore_state(const nlohmann::json& state) {
  mps::unpack_array_same_size(state, "sum", sum_);
  mps::unpack_array_same_size(state, "count", count_);
  samples_ = mps::unpack_value<int>(state, "samples");
}

template <int D>
void LineSampler::add(const mps::BasicSimulation<D>& sim) {
  const mps::BasicParticles<D>& s = sim.particles();
  const double l0 = p_.l0(), a = frame_angle(p_, sim.time()), w = frame_rate(p_);
  const double ca = std::cos(a), sa = std::sin(a), U = p_.omega * p_.R2;
  const auto bins = static_cast<double>(sum_.size());
  for (std::size_t i = 0; i < s.size(); ++i) {
    const bool barrel_wall = s.kind[i] == mps::Kind::wall && s.group[i] == kOuterGroup;
    if (line_ == Line::barrel ? !barrel_wall : s.kind[i] != mps::Kind::fluid) continue;
    // Into the channel frame: rotate back by the frame angle; velocity less the frame's rotation.
    const double x = ca * s.x[i] + sa * s.y[i], y = -sa * s.x[i] + ca * s.y[i];
    const double ux = s.u[i] + w * s.y[i], uy = s.v[i] - w * s.x[i];
    const double u = ca * ux + sa * uy, v = -sa * ux + ca * uy;
    const double r = std::hypot(x, y), th = std::atan2(y, x);
    const double ut = (x * v - y * u) / r, urad = (x * u + y * v) / r;
    double axis = 0, value = 0;
    if (line_ == Line::couette) {
      axis = r;
      value = ut;
    } else {
      const double phi = std::remainder(th - kCentre, 2.0 * std::numbers::pi);
      if (line_ == Line::line1) {
        if (std::abs(r * std::sin(phi)) >= l0 || std::cos(phi) <= 0.0) continue;
        axis = r;
        value = ut / U;
      } else if (line_ == Line::arc2) {
        if (std::abs(r - 0.5 * (p_.R1 + p_.R2)) >= l0) continue;
        axis = phi;
        value = urad / U;
      } else {
        axis = phi;
        value = s.p[i];
      }
    }
    const double k = std::floor((axis - lo_) / width_);
    if (k < 0.0 || k >= bins) continue;
    sum_[static_cast<std::size_t>(k)] += value;
    ++count_[static_cast<std::size_t>(k)];
  }
  ++samples_;
}
template void LineSampler::add(const mps::BasicSimulation<2>&);
template void LineSampler::add(const mps::BasicSimulation<3>&);

Curve LineSampler::result() const {
  Curve c;
  for (std::size_t k = 0; k < sum_.size(); ++k) {
    const double axis = lo_ + (static_cast<double>(k) + 0.5) * width_;
    c.axis.push_back(axis);
    c.value.push_back(count_[k] > 0 ? sum_[k] / static_cast<double>(count_[k]) : std::nan(""));
    c.count.push_back(count_[k]);
    if (line_ == Line::couette) c.exact.push_back(couette_exact(p_, axis));
  }
  if (line_ == Line::barrel) {
    // The pressure's level is a gauge (zero mean over the fluid and walls) and, in the moving model, carries
    // the centrifugal rho omega^2 r^2/2 the fixed model lacks: the curve is taken relative to its mean over
    // |phi| <= 0.4 span, clear of the corners, whose singular values would set the mean.
    double sum = 0.0;
    long n = 0;
    for (std::size_t k = 0; k < c.axis.size(); ++k)
      if (std::abs(c.axis[k]) <= 0.4 * p_.span && !std::isnan(c.value[k])) {
        sum += c.value[k];
        ++n;
      }
    if (n > 0)
      for (double& v : c.value) v -= sum / static_cast<double>(n);
  }
  return c;
}

double couette_max_error(const Curve& c) {
  double e = 0.0;
  for (std::size_t k = 0; k < c.value.size() && k < c.exact.size(); ++k)
    if (!std::isnan(c.value[k])) e = std::max(e, std::abs(c.value[k] - c.exact[k]));
  return e;
}

namespace {
// Linear interpolation of (xs, ys) at x; NaN outside [xs.front(), xs.back()].
double interpolate(const std::vector<double>& xs, const std::vector<double>& ys, double x) {
  if (xs.empty() || x < xs.front() || x > xs.back()) return std::nan("");
  const auto it = std::upper_bound(xs.begin(), xs.end(), x);
  if (it == xs.end()) return ys.back();
  const auto j = static_cast<std::size_t>(it - xs.begin());
  if (j == 0) return ys.front();
  const double t = (x - xs[j - 1]) / (xs[j] - xs[j - 1]);
  return ys[j - 1] + t * (ys[j] - ys[j - 1]);
}
}  // namespace

double odd_defect(const Curve& c, double limit) {
  double d = 0.0;
  for (std::size_t k = 0; k < c.axis.size(); ++k) {
    if (std::abs(c.axis[k]) > limit || std::isnan(c.value[k])) continue;
    const double mirror = interpolate(c.axis, c.value, -c.axis[k]);
    if (!std::isnan(mirror)) d = std::max(d, std::abs(c.value[k] + mirror));
  }
  return d;
}

double max_difference(const Curve& f, const Curve& g) {
  double d = 0.0;
  for (std::size_t k = 0; k < f.axis.size(); ++k) {
    const double other = interpolate(g.axis, g.value, f.axis[k]);
    if (!std::isnan(other) && !std::isnan(f.value[k])) d = std::max(d, std::abs(f.value[k] - other));
  }
  return d;
}

double range(const Curve& c, double limit) {
  double lo = std::numeric_limits<double>::infinity(), hi = -lo;
  for (std::size_t k = 0; k < c.axis.size(); ++k)
    if (std::abs(c.axis[k]) <= limit && !std::isnan(c.value[k])) {
      lo = std::min(lo, c.value[k]);
      hi = std::max(hi, c.value[k]);
    }
  return hi >= lo ? hi - lo : 0.0;
}

template <int D>
long escaped_particles(const Params& p, const mps::BasicSimulation<D>& sim) {
  const mps::BasicParticles<D>& s = sim.particles();
  const double a = frame_angle(p, sim.time());
  long n = 0;
  for (std::size_t i = 0; i < s.size(); ++i) {
    if (s.kind[i] != mps::Kind::fluid) continue;
    const double r = std::hypot(s.x[i], s.y[i]);
    const double phi = std::remainder(std::atan2(s.y[i], s.x[i]) - a - kCentre, 2.0 * std::numbers::pi);
    n += r <= p.R1 || r >= p.R2 || (p.scene == Scene::channel && std::abs(phi) >= 0.5 * p.span);
  }
  return n;
}
template long escaped_particles(const Params&, const mps::BasicSimulation<2>&);
template long escaped_particles(const Params&, const mps::BasicSimulation<3>&);

double max_axial_speed(const mps::Simulation3& sim) {
  const mps::Particles3& s = sim.particles();
  double w = 0.0;
  for (std::size_t i = 0; i < s.size(); ++i)
    if (s.kind[i] == mps::Kind::fluid) w = std::max(w, std::abs(s.w[i]));
  return w;
}

}  // namespace rotating
