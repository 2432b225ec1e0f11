#include "tank.hpp"

#include "mps/core/state.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <string>

#include "mps/boundaries/geometry.hpp"

namespace tank {

template <int D>
mps::BasicParticles<D> make_particles(const Params& p) {
  mps::BasicParticles<D> particles;
  // Walls rise 20 % above the water so the surface never reaches their top.
  if constexpr (D == 2) {
    mps::fill_rectangle(particles, {0.0, 0.0, p.width, p.water_height}, p.l0, mps::Kind::fluid);
    const mps::Rect inner{0.0, 0.0, p.width, 1.2 * p.water_height};
    mps::add_rectangle_walls(particles, inner, p.l0, mps::left | mps::right | mps::bottom, 1, 4);
  } else {
    mps::fill_box(particles, {0.0, 0.0, 0.0, p.width, p.width, p.water_height}, p.l0, mps::Kind::fluid);
    const mps::Box inner{0.0, 0.0, 0.0, p.width, p.width, 1.2 * p.water_height};
    mps::add_box_walls(particles, inner, p.l0, mps::x_low | mps::x_high | mps::y_low | mps::y_high | mps::z_low, 1, 4);
  }
  return particles;
}

template <int D>
mps::BasicDomain<D> make_domain(const Params& p) {
  const double margin = 6.0 * p.l0;
  if constexpr (D == 2) return {-margin, p.width + margin, -margin, 1.5 * p.water_height + margin};
  else return {-margin, p.width + margin, -margin, p.width + margin, -margin, 1.5 * p.water_height + margin};
}

template <int D>
mps::SimulationConfig make_config(const Params& p) {
  mps::SimulationConfig c;
  c.l0 = p.l0;
  c.rho = 1000.0;
  c.nu = 1e-6;
  (D == 2 ? c.fy : c.fz) = -p.g;
  c.gamma = p.gamma;
  c.dt_max = p.dt;
  c.solver = p.solver;
  c.dt_option = "--dt";
  mps::set_pressure_treatment(c, p.pressure_treatment);
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

template <int D>
BasicTank<D>::BasicTank(const Params& p)
    : params_(checked(p)),
      initial_(make_particles<D>(p)),
      sim_(initial_, make_domain<D>(p), make_config<D>(p)),
      band_h_(p.band * p.l0),
      sum_(static_cast<std::size_t>(std::ceil(p.water_height / band_h_ - 1e-9)), 0.0),
      samples_(sum_.size(), 0) {}

// The height: y in 2-D, z in 3-D.
template <int D>
const std::vector<double>& heights(const mps::BasicParticles<D>& s) {
  return *s.positions()[D - 1];
}

template <int D>
void BasicTank<D>::step() {
  sim_.step();
  if (sim_.time() < params_.end_time - params_.window) return;
  const mps::BasicParticles<D>& s = sim_.particles();
  const std::vector<double>& height = heights(s);
  const int top = static_cast<int>(sum_.size()) - 1;
  for (std::size_t i = 0; i < s.size(); ++i) {
    if (s.kind[i] != mps::Kind::fluid || height[i] < 0.0) continue;
    const auto b = static_cast<std::size_t>(std::min(top, static_cast<int>(height[i] / band_h_)));
    sum_[b] += s.p[i];
    ++samples_[b];
  }
}

template <int D>
nlohmann::json BasicTank<D>::save_state() const {
  return {{"sum", mps::pack_array(sum_)}, {"samples", mps::pack_array(samples_)}};
}

template <int D>
void BasicTank<D>::restore_state(const nlohmann::json& state) {
  mps::unpack_array_same_size(state, "sum", sum_);
  mps::unpack_array_same_size(state, "samples", samples_);
}

template <int D>
Result BasicTank<D>::result() const {
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
  const mps::BasicParticles<D>& s = sim_.particles();
  for (std::size_t i = 0; i < s.size(); ++i) {
    if (s.kind[i] != mps::Kind::fluid) continue;
    const auto k = static_cast<std::size_t>(s.id[i]);
    mps::Vec<D> moved = s.position(i);
    for (std::size_t a = 0; a < D; ++a) moved[a] -= initial_.position(k)[a];
    r.max_displacement_l0 = std::max(r.max_displacement_l0, mps::norm<D>(moved) / p.l0);
  }
  r.steps = sim_.last_step().step;
  r.time = sim_.time();
  r.dt_limit = sim_.last_step().dt_limit;
  r.fluid = static_cast<int>(s.count(mps::Kind::fluid));
  r.boundary = static_cast<int>(s.size()) - r.fluid;
  return r;
}

template class BasicTank<2>;
template class BasicTank<3>;
template mps::BasicParticles<2> make_particles<2>(const Params&);
template mps::BasicParticles<3> make_particles<3>(const Params&);
template mps::BasicDomain<2> make_domain<2>(const Params&);
template mps::BasicDomain<3> make_domain<3>(const Params&);
template mps::SimulationConfig make_config<2>(const Params&);
template mps::SimulationConfig make_config<3>(const Params&);

}  // namespace tank
