#include "channel.hpp"

#include <mpi.h>

#include <algorithm>
#include <cmath>
#include <memory>
#include <numbers>
#include <stdexcept>

#include "mps/boundaries/geometry.hpp"
#include "mps/step/components.hpp"

namespace poiseuille {

Mode parse_mode(const std::string& name) {
  if (name == "inlet") return Mode::inlet;
  if (name == "body-force") return Mode::body_force;
  if (name == "couette") return Mode::couette;
  throw std::invalid_argument("unknown mode '" + name + "': use inlet, body-force or couette");
}

std::string to_string(Mode mode) {
  return mode == Mode::inlet ? "inlet" : mode == Mode::body_force ? "body-force" : "couette";
}

namespace {
constexpr int kPlateGroup = 3;
// Inlet: the wall particles alongside the plate's stroke (x < kConveyorL0 l0) form a conveyor moving with the
// plate. Fixed walls there would have the plate scrape the slow near-wall fluid along them: it lagged, the
// plate caught up with it, and the squeezed corner broke the lattice within 20 steps. The boundary layers
// start at the conveyor's end, a few l0 downstream of the plate.
constexpr double kConveyorL0 = 3;
constexpr int kBottomConveyorGroup = 4, kTopConveyorGroup = 5;
// The outlet (its buffer, or its free surface) disturbs the last few l0; the station must stay clear of it and of
// the plate.
constexpr double kStationMarginL0 = 8;
constexpr double kLargestRadiusL0 = 4.1;  // the Laplacian's and the PPE source's
constexpr double kPlateParkingL0 = -5.5;  // one spacing behind the plate's last dummy layer (PushingPlate::parking_x)
}  // namespace

void Params::validate() const {
  auto positive = [](double v) { return v > 0.0 && std::isfinite(v); };
  auto fail = [](const std::string& what) { throw std::invalid_argument("channel: " + what); };
  if (!positive(D)) fail("width D must be positive");
  if (!positive(re)) fail("Reynolds number must be positive");
  if (!positive(rho) || !positive(nu)) fail("rho and nu must be positive");
  if (!(across >= 4.0) || std::abs(across - std::round(across)) > 1e-9)
    fail("particles across the channel must be a whole number >= 4, got " + std::to_string(across));
  if (!(length_l0 >= 13.0) || std::abs(length_l0 - std::round(length_l0)) > 1e-9)
    fail("periodic length must be a whole number of l0 >= 13 (three cells of the 4.1 l0 search), got " +
         std::to_string(length_l0));
  if (!(outlet_buffer_l0 == 0.0 || (outlet_buffer_l0 >= kLargestRadiusL0 && std::isfinite(outlet_buffer_l0))))
    fail("the outlet buffer must be 0 (none) or at least " + std::to_string(kLargestRadiusL0) +
         " l0 thick (the fluid before it needs full kernels), got " + std::to_string(outlet_buffer_l0));
  if (mode == Mode::inlet) {
    if (!positive(length_D)) fail("channel length must be positive");
    const double outlet_margin = std::max(kStationMarginL0, outlet_buffer_l0 + 2.0);
    if (!(station_D * across >= kStationMarginL0 && (length_D - station_D) * across >= outlet_margin))
      fail("the measuring station x = " + std::to_string(station_D) + " D must be at least " +
           std::to_string(kStationMarginL0) + " l0 from the plate and " + std::to_string(outlet_margin) +
           " l0 from the outlet at " + std::to_string(length_D) + " D");
  }
  if (!(gamma >= 0.0 && gamma <= 1.0)) fail("gamma must be in [0, 1]");
  if (!(compression >= 0.0 && compression < 1.0)) fail("compression must be in [0, 1)");
  if (!(shifting >= 0.0 && std::isfinite(shifting))) fail("shifting must be >= 0 (0: off)");
  if (!positive(dt_factor)) fail("dt_factor must be positive");
}

double Params::sound_speed() const {
  if (compression <= 0.0) return 0.0;
  const double umax = 1.5 * U();
  const double length = periodic() ? length_l0 * l0() : length_D * D;
  const double drop = 12.0 * rho * nu * U() * length / (D * D);  // Poiseuille: dP/dx = 12 mu U / D^2
  return std::sqrt(std::max(umax * umax, drop / rho) / compression);
}

double exact_velocity(const Params& p, double y, double t) {
  const double pi = std::numbers::pi, D = p.D, nu = p.nu, U = p.U();
  double u = 0.0;
  if (p.mode == Mode::inlet) {
    u = 6.0 * U * (y / D) * (1.0 - y / D);
  } else if (p.mode == Mode::body_force) {
    const double F = p.force();
    u = F / (2.0 * nu) * y * (D - y);
    for (int n = 0; n < 100000; ++n) {
      const double k = 2.0 * n + 1.0;
      const double term = 4.0 * F * D * D / (nu * pi * pi * pi * k * k * k) * std::exp(-k * k * pi * pi * nu * t / (D * D));
      u -= term * std::sin(k * pi * y / D);
      if (term < 1e-14 * U) break;
    }
  } else {
    u = U * y / D;
    for (int n = 1; n <= 100000; ++n) {
      const double term = 2.0 * U / (n * pi) * std::exp(-n * n * pi * pi * nu * t / (D * D));
      u += (n % 2 == 0 ? term : -term) * std::sin(n * pi * y / D);
      if (term < 1e-14 * U) break;
    }
  }
  return u;
}

namespace {
double channel_length(const Params& p) {
  return p.periodic() ? p.length_l0 * p.l0() : std::round(p.length_D * p.across) * p.l0();
}
}  // namespace

mps::Particles make_particles(const Params& p) {
  p.validate();
  const double l0 = p.l0(), L = channel_length(p);
  mps::Particles particles;
  mps::fill_rectangle(particles, {0.0, 0.0, L, p.D}, l0, mps::Kind::fluid, 0);
  // Inlet: the walls reach past the plate's dummies and past the outlet, so that the fluid at either end
  // has its full wall support.
  const double reach = p.periodic() ? 0.0 : 5.0 * l0;
  const mps::Rect walled{-reach, 0.0, L + reach, p.D};
  mps::add_rectangle_walls(particles, walled, l0, mps::bottom, 1, 4, 1);
  mps::add_rectangle_walls(particles, walled, l0, mps::top, 1, 4, 2);
  if (!p.periodic()) {
    for (std::size_t i = 0; i < particles.size(); ++i)
      if (particles.x[i] < kConveyorL0 * l0 && (particles.group[i] == 1 || particles.group[i] == 2))
        particles.group[i] = particles.group[i] == 1 ? kBottomConveyorGroup : kTopConveyorGroup;
    // The plate starts impulsively; incompressible fluid answers at once with plug flow at U.
    for (std::size_t i = 0; i < particles.size(); ++i)
      if (particles.kind[i] == mps::Kind::fluid) particles.u[i] = p.U();
    mps::add_rectangle_walls(particles, {0.0, 0.0, L, p.D}, l0, mps::left, 1, 4, kPlateGroup);
    // Ghosts, parked behind the plate where PushingPlate parks the outflow (a partition by position then keeps the
    // pool with the plate): outflow and inflow balance on average, and three columns cover the column the plate adds
    // at once while the outlet drains continuously. Three to a row's height, so that no two coincide.
    const int pool = 3 * static_cast<int>(std::lround(p.across));
    for (int k = 0; k < pool; ++k) particles.add(kPlateParkingL0 * l0, (k + 0.5) * p.D / pool, mps::Kind::ghost, 0);
  }
  return particles;
}

double estimated_particles(const Params& p) {
  const double rows = p.across + 10.0;  // fluid and both walls' five layers
  return rows * (p.periodic() ? p.length_l0 : p.length_D * p.across + 20.0);
}

double initial_dt(const Params& p) {
  const double l0 = p.l0(), cfl_dt = 0.2 * l0 / (1.5 * p.U()), viscous_dt = 0.2 * l0 * l0 / p.nu;
  return p.dt_factor * (p.implicit_viscosity ? cfl_dt : std::min(cfl_dt, viscous_dt));
}

mps::Domain make_domain(const Params& p) {
  const double l0 = p.l0(), L = channel_length(p);
  return p.periodic() ? mps::Domain{0.0, L, -6.0 * l0, p.D + 6.0 * l0, true, false}
                      : mps::Domain{-6.0 * l0, L + 6.0 * l0, -6.0 * l0, p.D + 6.0 * l0};
}

mps::SimulationConfig make_config(const Params& p) {
  const double l0 = p.l0();
  mps::SimulationConfig c;
  c.l0 = l0;
  c.rho = p.rho;
  c.nu = p.nu;
  c.gamma = p.gamma;
  c.fx = p.mode == Mode::body_force ? p.force() : 0.0;
  // The CFL and viscous limits set dt; dt_max, ten times the larger, never binds (were it equal, the guard
  // would name it instead of the limit that really set dt).
  c.dt_max = 10.0 * p.dt_factor * std::max(c.cfl * l0 / (1.5 * p.U()), c.viscous_number * l0 * l0 / p.nu);
  // Implicit viscosity leaves the CFL limit alone, and a channel starting at rest sets none: dt_max is then
  // that limit at the developed peak speed 1.5 U.
  c.implicit_viscosity = p.implicit_viscosity;
  c.shifting = p.shifting;
  if (p.implicit_viscosity) c.dt_max = p.dt_factor * c.cfl * l0 / (1.5 * p.U());
  c.cfl *= p.dt_factor;
  c.viscous_number *= p.dt_factor;
  c.solver = p.solver;
  c.dt_option = "--dt-factor";
  c.warm_start = p.warm_start;
  c.sound_speed = p.periodic() ? 0.0 : p.sound_speed();  // the periodic channels are closed: the gauge serves them
  // The outlet is an open end at gauge pressure 0, not a liquid surface: the confined liquid may hold a
  // negative gauge pressure, and clamping it would leave every push of the plate unanswered (measured: the
  // flow rate at the station ran 47 % above U D by t = 0.25 D/U).
  c.clamp_negative_pressure = false;
  return c;
}

std::shared_ptr<mps::PushingPlate> add_components(const Params& p, const mps::Particles& initial,
                                                  mps::Simulation& sim) {
  const double l0 = p.l0(), L = channel_length(p);
  std::shared_ptr<mps::PushingPlate> plate;
  if (!p.periodic()) plate = std::make_shared<mps::PushingPlate>(initial, kPlateGroup, p.U(), l0, L);
  if (plate)
    sim.add<mps::BoundaryMotion>(
        [plate](mps::Particles& s, double t, std::size_t owned) { (*plate)(s, t, owned); });
  // The liquid is confined but for its open outlet (and the dry wall ends behind the plate). A void opened by
  // the shear elsewhere, read as free surface, stayed open at P = 0 and was carried downstream until the
  // inrush blew up (15 D at Re 40, 20 across: stopped at 4.5 D/U); left to the source term, it closes.
  // An outflow buffer holds the outlet at P = 0 itself; without one the outlet's fluid is free surface.
  const bool buffer = !p.periodic() && p.outlet_buffer_l0 > 0.0;
  const double outlet_zone = L - 4.0 * l0;
  if (p.periodic())
    sim.add<mps::SurfaceRegion>([](double, double) { return false; });
  else if (buffer)
    sim.add<mps::SurfaceRegion>([](double x, double) { return x < 0.0; });
  else
    sim.add<mps::SurfaceRegion>([outlet_zone](double x, double) { return x < 0.0 || x > outlet_zone; });
  // The walls run 5 l0 past the outlet line, so that the buffer's last particles keep their wall support.
  if (buffer) sim.add<mps::OpenOutlet>(mps::OutflowBuffer{{L, 0.0}, {1.0, 0.0}, p.outlet_buffer_l0 * l0});
  const double top_speed = p.mode == Mode::couette ? p.U() : 0.0;
  sim.add<mps::MirrorNoSlip>(mps::MirrorWall{0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 1});
  sim.add<mps::MirrorNoSlip>(mps::MirrorWall{0.0, p.D, 0.0, -1.0, top_speed, 0.0, 2});
  if (!p.periodic()) {
    sim.add<mps::MirrorNoSlip>(mps::MirrorWall{0.0, 0.0, 0.0, 1.0, p.U(), 0.0, kBottomConveyorGroup});
    sim.add<mps::MirrorNoSlip>(mps::MirrorWall{0.0, p.D, 0.0, -1.0, p.U(), 0.0, kTopConveyorGroup});
  }
  return plate;
}

mps::Simulation make_simulation(const Params& p, std::optional<int> comm, std::shared_ptr<mps::PushingPlate>* plate) {
  mps::Particles particles = make_particles(p);
  const mps::Particles initial = particles;
  mps::Simulation sim = comm ? mps::Simulation(std::move(particles), make_domain(p), make_config(p),
                                               std::make_unique<mps::RankExchange>(*comm))
                             : mps::Simulation(std::move(particles), make_domain(p), make_config(p));
  const std::shared_ptr<mps::PushingPlate> added = add_components(p, initial, sim);
  if (plate != nullptr) *plate = added;
  return sim;
}

ProfileSampler::ProfileSampler(const Params& p)
    : p_(p), sum_(static_cast<std::size_t>(std::lround(p.across)), 0.0), count_(sum_.size(), 0) {}

void ProfileSampler::clear() {
  std::fill(sum_.begin(), sum_.end(), 0.0);
  std::fill(count_.begin(), count_.end(), 0);
  samples_ = 0;
  max_abs_v_ = 0.0;
}

nlohmann::json ProfileSampler::save_state() const {
  return {{"sum", mps::pack_array(sum_)}, {"count", mps::pack_array(count_)}, {"samples", samples_},
          {"max_abs_v", max_abs_v_}};
}

void ProfileSampler::restore_state(const nlohmann::json& state) {
  mps::unpack_array_same_size(state, "sum", sum_);
  mps::unpack_array_same_size(state, "count", count_);
  samples_ = mps::unpack_value<int>(state, "samples");
  max_abs_v_ = mps::unpack_value<double>(state, "max_abs_v");
}

void ProfileSampler::add(const mps::Simulation& sim) {
  const double l0 = p_.l0(), station = p_.station_D * p_.D;
  const double last_row = static_cast<double>(sum_.size() - 1);
  const mps::Particles& s = sim.particles();
  for (std::size_t i = 0; i < s.size(); ++i) {
    if (s.kind[i] != mps::Kind::fluid || (!p_.periodic() && std::abs(s.x[i] - station) >= l0)) continue;
    max_abs_v_ = std::max(max_abs_v_, std::abs(s.v[i]));
    const auto k = static_cast<std::size_t>(std::clamp(std::floor(s.y[i] / l0), 0.0, last_row));
    sum_[k] += s.u[i];
    ++count_[k];
  }
  ++samples_;
}

void ProfileSampler::sum_over_ranks(int comm) {
  const MPI_Comm c = MPI_Comm_f2c(comm);
  MPI_Allreduce(MPI_IN_PLACE, sum_.data(), static_cast<int>(sum_.size()), MPI_DOUBLE, MPI_SUM, c);
  MPI_Allreduce(MPI_IN_PLACE, count_.data(), static_cast<int>(count_.size()), MPI_LONG, MPI_SUM, c);
  MPI_Allreduce(MPI_IN_PLACE, &max_abs_v_, 1, MPI_DOUBLE, MPI_MAX, c);
}

Profile ProfileSampler::result(double time) const {
  const double l0 = p_.l0();
  Profile out;
  out.time = time;
  out.samples = samples_;
  out.max_abs_v = max_abs_v_;
  double e2 = 0.0, x2 = 0.0, q = 0.0, q_exact = 0.0, peak = 0.0, peak_exact = 0.0;
  for (std::size_t k = 0; k < sum_.size(); ++k) {
    const double y = (static_cast<double>(k) + 0.5) * l0;
    const double u = count_[k] > 0 ? sum_[k] / static_cast<double>(count_[k]) : 0.0;
    const double ue = exact_velocity(p_, y, time);
    out.y.push_back(y);
    out.u.push_back(u);
    out.exact.push_back(ue);
    e2 += (u - ue) * (u - ue);
    x2 += ue * ue;
    q += u * l0;
    peak = std::max(peak, u);
    peak_exact = std::max(peak_exact, ue);
  }
  // The exact flow rate by the midpoint rule on a 100x finer grid.
  const int fine = 100 * static_cast<int>(sum_.size());
  for (int k = 0; k < fine; ++k) q_exact += exact_velocity(p_, (k + 0.5) * p_.D / fine, time) * p_.D / fine;
  out.l2_error = x2 > 0.0 ? std::sqrt(e2 / x2) : 0.0;
  out.peak_error = peak_exact > 0.0 ? std::abs(peak - peak_exact) / peak_exact : 0.0;
  out.flow_rate_error = q_exact > 0.0 ? std::abs(q - q_exact) / q_exact : 0.0;
  return out;
}

Profile measure_profile(const Params& p, const mps::Simulation& sim) {
  ProfileSampler sampler(p);
  sampler.add(sim);
  return sampler.result(sim.time());
}

}  // namespace poiseuille
