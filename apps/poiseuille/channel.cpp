#include "channel.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <stdexcept>

#include "mps/geometry.hpp"

namespace poiseuille {

Mode parse_mode(const std::string& name) {
  if (name == "body-force") return Mode::body_force;
  if (name == "couette") return Mode::couette;
  throw std::invalid_argument("unknown mode '" + name + "': use body-force or couette");
}

std::string to_string(Mode mode) { return mode == Mode::body_force ? "body-force" : "couette"; }

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
  if (!(gamma >= 0.0 && gamma <= 1.0)) fail("gamma must be in [0, 1]");
  if (!positive(dt_factor)) fail("dt_factor must be positive");
}

double exact_velocity(const Params& p, double y, double t) {
  const double pi = std::numbers::pi, D = p.D, nu = p.nu, U = p.U();
  double u = 0.0;
  if (p.mode == Mode::body_force) {
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

mps::Particles make_particles(const Params& p) {
  p.validate();
  const double l0 = p.l0(), L = p.length_l0 * l0;
  mps::Particles particles;
  mps::fill_rectangle(particles, {0.0, 0.0, L, p.D}, l0, mps::Kind::fluid, 0);
  mps::add_rectangle_walls(particles, {0.0, 0.0, L, p.D}, l0, mps::bottom, 1, 4, 1);
  mps::add_rectangle_walls(particles, {0.0, 0.0, L, p.D}, l0, mps::top, 1, 4, 2);
  return particles;
}

mps::Simulation make_simulation(const Params& p) {
  const double l0 = p.l0();
  const mps::Domain domain{0.0, p.length_l0 * l0, -6.0 * l0, p.D + 6.0 * l0, true, false};
  mps::SimulationConfig c;
  c.l0 = l0;
  c.rho = p.rho;
  c.nu = p.nu;
  c.gamma = p.gamma;
  c.fx = p.mode == Mode::body_force ? p.force() : 0.0;
  // The CFL and viscous limits set dt; dt_max, ten times the larger, never binds (were it equal, the guard
  // would name it instead of the limit that really set dt).
  c.dt_max = 10.0 * p.dt_factor * std::max(c.cfl * l0 / (1.5 * p.U()), c.viscous_number * l0 * l0 / p.nu);
  c.cfl *= p.dt_factor;
  c.viscous_number *= p.dt_factor;
  c.solver = p.solver;
  mps::Simulation sim(make_particles(p), domain, c);
  const double top_speed = p.mode == Mode::couette ? p.U() : 0.0;
  sim.add_mirror_wall({0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 1});
  sim.add_mirror_wall({0.0, p.D, 0.0, -1.0, top_speed, 0.0, 2});
  return sim;
}

Profile measure_profile(const Params& p, const mps::Simulation& sim) {
  const double l0 = p.l0();
  const auto rows = static_cast<std::size_t>(std::lround(p.across));
  std::vector<double> sum(rows, 0.0);
  std::vector<int> count(rows, 0);
  Profile out;
  out.time = sim.time();
  const mps::Particles& s = sim.particles();
  for (std::size_t i = 0; i < s.size(); ++i) {
    if (s.kind[i] != mps::Kind::fluid) continue;
    out.max_abs_v = std::max(out.max_abs_v, std::abs(s.v[i]));
    const auto k = static_cast<std::size_t>(std::clamp(std::floor(s.y[i] / l0), 0.0, static_cast<double>(rows - 1)));
    sum[k] += s.u[i];
    ++count[k];
  }
  double e2 = 0.0, x2 = 0.0, q = 0.0, q_exact = 0.0, peak = 0.0, peak_exact = 0.0;
  for (std::size_t k = 0; k < rows; ++k) {
    const double y = (static_cast<double>(k) + 0.5) * l0;
    const double u = count[k] > 0 ? sum[k] / count[k] : 0.0;
    const double ue = exact_velocity(p, y, sim.time());
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
  const int fine = 100 * static_cast<int>(rows);
  for (int k = 0; k < fine; ++k) q_exact += exact_velocity(p, (k + 0.5) * p.D / fine, sim.time()) * p.D / fine;
  out.l2_error = x2 > 0.0 ? std::sqrt(e2 / x2) : 0.0;
  out.peak_error = peak_exact > 0.0 ? std::abs(peak - peak_exact) / peak_exact : 0.0;
  out.flow_rate_error = q_exact > 0.0 ? std::abs(q - q_exact) / q_exact : 0.0;
  return out;
}

}  // namespace poiseuille
