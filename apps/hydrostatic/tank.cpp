#include "tank.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <string>

#include "mps/geometry.hpp"

namespace tank {

mps::Particles make_particles(const Params& p) {
  mps::Particles particles;
  mps::fill_rectangle(particles, {0.0, 0.0, p.width, p.water_height}, p.l0, mps::Kind::fluid);
  // Walls rise 20 % above the water so the surface never reaches their top.
  const mps::Rect inner{0.0, 0.0, p.width, 1.2 * p.water_height};
  mps::add_rectangle_walls(particles, inner, p.l0, mps::left | mps::right | mps::bottom, 1, 4);
  return particles;
}

mps::Domain make_domain(const Params& p) {
  const double margin = 6.0 * p.l0;
  return {-margin, p.width + margin, -margin, 1.5 * p.water_height + margin};
}

mps::SimulationConfig make_config(const Params& p) {
  mps::SimulationConfig c;
  c.l0 = p.l0;
  c.rho = 1000.0;
  c.nu = 1e-6;
  c.fy = -p.g;
  c.gamma = p.gamma;
  c.dt_max = p.dt;
  c.solver = p.solver;
  c.dt_option = "--dt";
  return c;
}

namespace {
std::string fmt(double v) {
  char s[32];
  std::snprintf(s, sizeof s, "%g", v);
  return s;
}

const Params& checked(const Params& p) {
  if (!(p.end_time > p.window) || !(p.window > 0.0))
    throw std::invalid_argument("tank: need end_time > window > 0, got end_time " + fmt(p.end_time) +
                                " s and window " + fmt(p.window) + " s");
  // At least one band of pressures, and every band at least one spacing high.
  if (!(p.band >= 1.0 && p.band * p.l0 <= p.water_height))
    throw std::invalid_argument("tank: the averaging band must be from 1 to H / l0 = " +
                                fmt(p.water_height / p.l0) + " spacings high, got " + fmt(p.band));
  return p;
}
}  // namespace

Tank::Tank(const Params& p)
    : params_(checked(p)),
      initial_(make_particles(p)),
      sim_(initial_, make_domain(p), make_config(p)),
      band_h_(p.band * p.l0),
      sum_(static_cast<std::size_t>(std::ceil(p.water_height / band_h_ - 1e-9)), 0.0),
      samples_(sum_.size(), 0) {}

void Tank::step() {
  sim_.step();
  if (sim_.time() < params_.end_time - params_.window) return;
  const mps::Particles& s = sim_.particles();
  const int top = static_cast<int>(sum_.size()) - 1;
  for (std::size_t i = 0; i < s.size(); ++i) {
    if (s.kind[i] != mps::Kind::fluid || s.y[i] < 0.0) continue;
    const auto b = static_cast<std::size_t>(std::min(top, static_cast<int>(s.y[i] / band_h_)));
    sum_[b] += s.p[i];
    ++samples_[b];
  }
}

Result Tank::result() const {
  const Params& p = params_;
  Result r;
  const double rho = sim_.config().rho;
  for (std::size_t b = 0; b < sum_.size(); ++b) {
    const double y0 = static_cast<double>(b) * band_h_;
    const double y1 = std::min(p.water_height, y0 + band_h_);
    const double yc = 0.5 * (y0 + y1);
    Band band{yc, 0.0, rho * p.g * (p.water_height - yc), 0.0, samples_[b]};
    band.mean_pressure = band.samples > 0 ? sum_[b] / band.samples : 0.0;
    band.relative_error = std::abs(band.mean_pressure - band.exact_pressure) / band.exact_pressure;
    if (b + 1 < sum_.size()) r.max_error_below_top = std::max(r.max_error_below_top, band.relative_error);
    r.bands.push_back(band);
  }
  const mps::Particles& s = sim_.particles();
  for (std::size_t i = 0; i < s.size(); ++i) {
    if (s.kind[i] != mps::Kind::fluid) continue;
    const auto k = static_cast<std::size_t>(s.id[i]);
    r.max_displacement_l0 =
        std::max(r.max_displacement_l0, std::hypot(s.x[i] - initial_.x[k], s.y[i] - initial_.y[k]) / p.l0);
  }
  r.steps = sim_.last_step().step;
  r.time = sim_.time();
  r.dt_limit = sim_.last_step().dt_limit;
  r.fluid = static_cast<int>(s.count(mps::Kind::fluid));
  r.boundary = static_cast<int>(s.size()) - r.fluid;
  return r;
}

}  // namespace tank
