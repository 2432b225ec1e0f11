#include "column.hpp"

#include <mpi.h>

#include <algorithm>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <limits>
#include <sstream>
#include <stdexcept>

#include "box_impact.hpp"
#include "mps/boundaries/geometry.hpp"
#include "mps/io/io.hpp"

namespace dambreak {

nlohmann::json pack_rows(const std::vector<std::vector<double>>& rows) {
  std::vector<double> flat;
  for (const auto& row : rows) flat.insert(flat.end(), row.begin(), row.end());
  return {{"width", rows.empty() ? 0 : rows.front().size()}, {"values", mps::pack_array(flat)}};
}

std::vector<std::vector<double>> unpack_rows(const nlohmann::json& state, std::size_t count) {
  std::vector<double> flat;
  mps::unpack_array(state, "values", flat);
  const auto width = mps::unpack_value<std::size_t>(state, "width");
  if (flat.size() != width * count) throw std::runtime_error("checkpoint: the samples' probe values do not add up");
  std::vector<std::vector<double>> rows(count);
  for (std::size_t k = 0; k < count; ++k) rows[k].assign(flat.begin() + static_cast<std::ptrdiff_t>(k * width),
                                                        flat.begin() + static_cast<std::ptrdiff_t>((k + 1) * width));
  return rows;
}

Column column_from_name(const std::string& name) {
  if (name == "classic") return Column::classic;
  if (name == "seed") return Column::seed;
  if (name == "spheric2") return Column::spheric2;
  throw std::invalid_argument("unknown column '" + name + "': choose classic, seed or spheric2 (3-D)");
}

std::string to_string(Column c) {
  switch (c) {
    case Column::classic: return "classic";
    case Column::seed: return "seed";
    case Column::spheric2: return "spheric2";
    case Column::file: break;
  }
  return "file";
}

Params defaults(Column c) {
  if (c == Column::spheric2) return box_impact_defaults();
  Params p;
  p.column = c;
  if (c == Column::classic) {
    const double a = 0.146;
    p.width = a;
    p.height = 2 * a;
    p.tank_length = 8 * a;  // the front never meets the far wall before T = 3.5 (at 4a it did at T ~ 3)
    p.tank_height = 3 * a;
    p.l0 = a / 40;  // at a/20 the higher-order source's front is 8 % slow (docs/dambreak.md)
    p.end_time = 3.5 / std::sqrt(2 * p.g / a);  // T = 3.5, the end of the front's developed-speed fit
    p.level_probes = {0.5, 1.0, 1.653};
    p.pressure_probes = {0.2};
  } else {
    const double H = 1.0;
    p.width = 2 * H;
    p.height = H;
    p.tank_length = 5.366 * H;
    p.tank_height = 3 * H;
    p.l0 = H / 25;
    p.end_time = 7.0 / std::sqrt(p.g / H);  // t sqrt(g/H) = 7: past Buchner's second impact (5.5-6.5)
    p.level_probes = {1.653};
    p.pressure_probes = {0.01, 0.05, 0.1, 0.2, 0.267};
  }
  return p;
}

void take_column_geometry(Params& p, Column c) {
  const Params base = defaults(c);
  p.column = c;
  p.width = base.width;
  p.height = base.height;
  p.tank_length = base.tank_length;
  p.tank_height = base.tank_height;
  p.level_probes = base.level_probes;
  p.pressure_probes = base.pressure_probes;
  p.end_time = base.end_time;
}

namespace {
std::string fmt(double v) {
  char s[32];
  std::snprintf(s, sizeof s, "%g", v);
  return s;
}

const Params& checked(const Params& p) {
  auto positive = [](double v) { return v > 0.0 && std::isfinite(v); };
  if (!positive(p.width) || !positive(p.height) || !positive(p.l0) || !positive(p.end_time) || !positive(p.g))
    throw std::invalid_argument("dam break: width, height, spacing, end time and g must be positive and finite");
  if (!(p.width + 2 * p.l0 <= p.tank_length) || !(p.height + 2 * p.l0 <= p.tank_height))
    throw std::invalid_argument("dam break: the column (" + fmt(p.width) + " x " + fmt(p.height) +
                                " m) must fit in the tank (" + fmt(p.tank_length) + " x " + fmt(p.tank_height) + " m)");
  if (p.l0 > coarsest_spacing(p))
    throw std::invalid_argument("dam break: the column must be at least 4 spacings wide and high; lower the spacing (" +
                                fmt(p.l0) + " m)");
  const double first_step = p.cfl * p.l0 / std::sqrt(2 * p.g * p.height);  // make_config's dt_max
  if (!(p.end_time >= first_step))
    throw std::invalid_argument("dam break: the run (" + fmt(p.end_time) + " s) is shorter than its first step (" +
                                fmt(first_step) + " s); raise the end time");
  if (!(p.collision >= 0.0 && p.collision < 1.0))
    throw std::invalid_argument("dam break: the collision distance must be in [0, 1) l0 (0: off), got " + fmt(p.collision));
  if (!(p.stabilisation_distance > 0.0 && p.stabilisation_distance < 1.0))
    throw std::invalid_argument("dam break: the stabilisation distance must be in (0, 1) l0, got " +
                                fmt(p.stabilisation_distance));
  if (!(p.restitution >= 0.0 && p.restitution <= 1.0))
    throw std::invalid_argument("dam break: the restitution must be in [0, 1], got " + fmt(p.restitution));
  if (!(p.asymmetry >= 0.0 && p.asymmetry <= 10.0))
    throw std::invalid_argument("dam break: the asymmetry fraction must be in [0, 10] (0: off), got " + fmt(p.asymmetry));
  if (!(p.asymmetry_interior_density >= 0.0 && p.asymmetry_interior_density <= 10.0))
    throw std::invalid_argument("dam break: the asymmetry test's interior density must be in [0, 10] n0 (0: no limit), got " +
                                fmt(p.asymmetry_interior_density));
  if (!(p.pressure_patch >= 0.5 && p.pressure_patch <= 20))
    throw std::invalid_argument("dam break: the pressure patch radius must be in [0.5, 20] l0, got " +
                                fmt(p.pressure_patch));
  if (!(p.sensor_height >= 0.0 && p.sensor_height <= 1.0))
    throw std::invalid_argument("dam break: the pressure sensor's height must be in [0, 1] H (0: a disc), got " +
                                fmt(p.sensor_height));
  for (double d : p.level_probes)
    if (!(d > 0.0 && d * p.height < p.tank_length))
      throw std::invalid_argument("dam break: a level probe must lie inside the tank, got " + fmt(d) + " H");
  for (double h : p.pressure_probes)
    if (!(h >= 0.0 && h * p.height < p.tank_height))
      throw std::invalid_argument("dam break: a pressure probe must lie on the wall, got " + fmt(h) + " H");
  return p;
}

}  // namespace

double estimated_steps(const Params& p) {
  const mps::SimulationConfig c = make_config(p);
  return p.end_time / std::min(c.dt_max, c.viscous_number * c.l0 * c.l0 / c.nu);
}

double coarsest_spacing(const Params& p) { return std::min(p.width, p.height) / 4.0; }

mps::Particles make_particles(const Params& p) {
  mps::Particles particles;
  mps::fill_rectangle(particles, {0.0, 0.0, p.width, p.height}, p.l0, mps::Kind::fluid);
  mps::add_rectangle_walls(particles, {0.0, 0.0, p.tank_length, p.tank_height}, p.l0,
                           mps::left | mps::right | mps::bottom, 1, 4);
  return particles;
}

// Room above the walls for a splash to rise and fall back before it is removed.
mps::Domain make_domain(const Params& p) {
  const double margin = 6.0 * p.l0;
  return {-margin, p.tank_length + margin, -margin, p.tank_height + 0.5 * p.height + margin};
}

mps::SimulationConfig make_config(const Params& p, int dim) {
  mps::SimulationConfig c;
  c.l0 = p.l0;
  c.rho = 1000.0;
  c.nu = 1e-6;
  (dim == 2 ? c.fy : c.fz) = -p.g;
  c.gamma = p.gamma;
  c.cfl = p.cfl;
  c.dt_max = c.cfl * p.l0 / std::sqrt(2 * p.g * p.height);  // the CFL step at the free-fall speed from H
  c.pressure_gradient = p.gradient;
  c.stabilisation_distance = p.stabilisation_distance;  // kept by a treatment with "ds", dropped by one without
  mps::set_pressure_treatment(c, p.pressure_treatment);
  c.shifting = p.shifting;
  c.shift_along_free_surface = true;
  c.solver = p.solver;
  c.warm_start = p.warm_start;
  c.dt_option = "--cfl";
  return c;
}

double surge_front(const mps::Particles& s, double l0) {
  std::vector<std::size_t> fluid;
  for (std::size_t i = 0; i < s.size(); ++i)
    if (s.kind[i] == mps::Kind::fluid) fluid.push_back(i);
  const auto front = mps::outermost_with_fluid_neighbour<2>(s, std::move(fluid), s.x, 2.1 * l0);
  return front ? *front + 0.5 * l0 : 0.0;
}

mps::Domain make_domain(const Params& p, const mps::Particles& particles) {
  return widened_to_hold(make_domain(p), particles, p.l0);
}

double snapped(double length, double l0) {
  const double n = std::round(length / l0);
  return std::abs(length - n * l0) <= 1e-6 * l0 ? n * l0 : length;
}

double built_tank_length(const Params& p) {
  const double n = std::round(p.tank_length / p.l0);
  return std::abs(p.tank_length - n * p.l0) <= 1e-6 * p.l0 ? p.tank_length : n * p.l0;
}

double file_spacing(double median, double dx, std::string& how) {
  if (!std::isfinite(median)) throw std::invalid_argument("the particle file holds fewer than two particles");
  if (!(dx > 0)) {
    char text[32];
    std::snprintf(text, sizeof text, "%.12g", median);
    how = "the file's median nearest-neighbour distance";
    return std::strtod(text, nullptr);
  }
  if (std::abs(median - dx) > 0.2 * dx)
    throw std::invalid_argument("the particle file's particles lie " + fmt(median) +
                                " m apart (the median distance to the nearest one), but --dx is " + fmt(dx) +
                                " m: give the spacing the file was made with, or leave --dx out");
  how = "--dx";
  return dx;
}

template <int D>
bool same_particles_at_rest(const mps::BasicParticles<D>& file, const mps::BasicParticles<D>& built, double l0) {
  if (built.size() != file.size()) return false;
  // Each set sorted by its lattice cell (centres sit mid-cell), so that the two orders need not agree.
  auto by_cell = [&](const mps::BasicParticles<D>& s) {
    std::vector<std::size_t> order(s.size());
    std::vector<std::array<double, D>> cell(s.size());
    for (std::size_t i = 0; i < s.size(); ++i) {
      order[i] = i;
      const mps::Vec<D> r = s.position(i);
      for (int a = 0; a < D; ++a) cell[i][a] = std::floor(r[D - 1 - a] / l0);
    }
    std::sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) { return cell[a] < cell[b]; });
    return order;
  };
  const std::vector<std::size_t> mine = by_cell(file), theirs = by_cell(built);
  for (std::size_t k = 0; k < built.size(); ++k) {
    const std::size_t i = theirs[k], j = mine[k];
    if (built.kind[i] != file.kind[j] || built.group[i] != file.group[j] || file.p[j] != 0.0) return false;
    const mps::Vec<D> a = built.position(i), b = file.position(j), u = file.velocity(j);
    for (int d = 0; d < D; ++d)
      if (std::abs(a[d] - b[d]) > 1e-9 * l0 || u[d] != 0.0) return false;
  }
  return true;
}
template bool same_particles_at_rest(const mps::Particles&, const mps::Particles&, double);
template bool same_particles_at_rest(const mps::Particles3&, const mps::Particles3&, double);

// A file's velocities and pressures are a state a dam break could reach: a fall from the tank's top gives
// sqrt(2 g h) and rho g h; ten and a hundred times those are beyond any splash or impact (docs/particle-files.md).
template <int D>
void check_initial_state(const mps::BasicParticles<D>& s, const Params& p) {
  const double h = std::max(p.tank_height, p.height), speed = std::sqrt(2.0 * p.g * h), rho_g_h = 1000.0 * p.g * h;
  for (std::size_t i = 0; i < s.size(); ++i) {
    if (s.kind[i] == mps::Kind::ghost) continue;
    const mps::Vec<D> r = s.position(i), u = s.velocity(i);
    std::string at = "(";
    double v2 = 0.0;
    for (int d = 0; d < D; ++d) {
      at.append(d > 0 ? ", " : "").append(fmt(r[d]));
      v2 += u[d] * u[d];
    }
    at.append(")");
    const double v = std::sqrt(v2);
    if (!(v <= 10.0 * speed))
      throw std::invalid_argument("the particle file's particle at " + at + " moves at " + fmt(v) +
                                  " m/s, more than 10 times the speed of a fall from the tank's top (sqrt(2 g h) = " +
                                  fmt(speed) + " m/s): check its " + (D == 2 ? "u and v" : "u, v and w"));
    if (!(std::abs(s.p[i]) <= 100.0 * rho_g_h))
      throw std::invalid_argument("the particle file's particle at " + at + " holds the pressure " + fmt(s.p[i]) +
                                  " Pa, more than 100 times rho g h = " + fmt(rho_g_h) +
                                  " Pa of the tank's height: check its p");
  }
}
template void check_initial_state(const mps::Particles&, const Params&);
template void check_initial_state(const mps::Particles3&, const Params&);

namespace {
// Whether `particles` are the built-in column c's at spacing l0, in any order (a frame holds them in the step's order).
bool is_column(const mps::Particles& particles, Column c, double l0) {
  Params q = defaults(c);
  q.l0 = l0;
  // The column's count, about (water, and five layers of wall and dummies round three sides): a file far from it is not
  // built to find out.
  const double expected = (q.width / l0) * (q.height / l0) + 5.0 * (q.tank_length / l0 + 2.0 * q.tank_height / l0 + 10);
  if (!(expected < 2.0 * static_cast<double>(particles.size()) + 1000)) return false;
  return same_particles_at_rest(particles, make_particles(q), l0);
}
}  // namespace

FileScene from_particles(mps::Particles particles, double dx, const Params& options) {
  std::string how;
  const double l0 = file_spacing(mps::median_spacing(particles), dx, how);
  FileScene out{options, std::move(particles), ""};
  Params& p = out.params;
  p.l0 = l0;
  for (Column c : {Column::classic, Column::seed}) {
    if (!is_column(out.particles, c, l0)) continue;
    take_column_geometry(p, c);
    check_initial_state(out.particles, p);
    out.description = "spacing " + fmt(l0) + " m (" + how + "); the " + to_string(c) +
                      " column's particles: its tank, probes and experiments";
    return out;
  }
  mps::Particles& s = out.particles;
  const double inf = std::numeric_limits<double>::infinity();
  double wx0 = inf, wx1 = -inf, wy0 = inf, wy1 = -inf;
  for (std::size_t i = 0; i < s.size(); ++i)
    if (s.kind[i] == mps::Kind::wall) {
      wx0 = std::min(wx0, s.x[i]);
      wx1 = std::max(wx1, s.x[i]);
      wy0 = std::min(wy0, s.y[i]);
      wy1 = std::max(wy1, s.y[i]);
    }
  if (s.count(mps::Kind::fluid) == 0) throw std::invalid_argument("the particle file has no fluid particles");
  if (!(wx0 < inf)) throw std::invalid_argument("the particle file has no wall particles: a dam break needs a tank");
  // A bottom and two sides of wall particles span the tank one spacing apart: fewer cannot enclose a box this big.
  const double needed = (wx1 - wx0) / l0 + 2.0 * (wy1 - wy0) / l0;
  if (!(needed <= 1.5 * static_cast<double>(s.count(mps::Kind::wall))))
    throw std::invalid_argument("the particle file's " + std::to_string(s.count(mps::Kind::wall)) +
                                " wall particles span x from " + fmt(wx0) + " to " + fmt(wx1) + " m and y from " +
                                fmt(wy0) + " to " + fmt(wy1) + " m, a tank that would need about " + fmt(needed) +
                                " of them at spacing " + fmt(l0) +
                                " m: a wall particle lies far from the others (check the largest and smallest x, y)");
  // The walls' first layer sits half a spacing outside the tank's inner lines; the tank's top is its walls' top.
  const double x0 = wx0 + 0.5 * l0, y0 = wy0 + 0.5 * l0;
  if (std::abs(x0) > 1e-9 * l0 || std::abs(y0) > 1e-9 * l0)
    for (std::size_t i = 0; i < s.size(); ++i) {
      s.x[i] -= x0;
      s.y[i] -= y0;
    }
  p.column = Column::file;
  p.tank_length = snapped(wx1 - 0.5 * l0 - x0, l0);
  p.tank_height = snapped(wy1 + 0.5 * l0 - y0, l0);
  double fx1 = -inf, fy1 = -inf;
  for (std::size_t i = 0; i < s.size(); ++i) {
    if (s.kind[i] != mps::Kind::fluid) continue;
    if (!(s.x[i] > 0 && s.x[i] < p.tank_length && s.y[i] > 0))
      throw std::invalid_argument("the particle file's fluid particle at (" + fmt(s.x[i] + x0) + ", " +
                                  fmt(s.y[i] + y0) + ") lies outside the tank its wall particles enclose (x in [" +
                                  fmt(x0) + ", " + fmt(x0 + p.tank_length) + "], y above " + fmt(y0) +
                                  "): a dam break's tank has walls left, right and below its water");
    fx1 = std::max(fx1, s.x[i]);
    fy1 = std::max(fy1, s.y[i]);
  }
  p.width = snapped(fx1 + 0.5 * l0, l0);
  p.height = snapped(fy1 + 0.5 * l0, l0);
  const Params classic = defaults(Column::classic);
  p.level_probes.clear();
  p.pressure_probes.clear();
  for (double d : classic.level_probes)
    if (d * p.height < p.tank_length) p.level_probes.push_back(d);
  for (double h : classic.pressure_probes)
    if (h * p.height < p.tank_height) p.pressure_probes.push_back(h);
  p.end_time = 3.5 / std::sqrt(2 * p.g / p.width);  // T = 3.5, as the classic column
  check_initial_state(s, p);
  out.description = "spacing " + fmt(l0) + " m (" + how + "); tank " + fmt(p.tank_length) + " x " +
                    fmt(p.tank_height) + " m (the wall particles' inner box" +
                    (std::abs(x0) > 1e-9 * l0 || std::abs(y0) > 1e-9 * l0
                         ? ", moved by (" + fmt(-x0) + ", " + fmt(-y0) + ") m to put its corner at the origin"
                         : std::string()) +
                    "); water " + fmt(p.width) + " m wide and " + fmt(p.height) + " m high (the fluid's box)";
  return out;
}

Scene::Scene(const Params& p) : Scene(p, make_particles(p)) {}

namespace {
Params with_built_tank(Params p) {
  p.tank_length = built_tank_length(p);
  return p;
}

std::unique_ptr<mps::Simulation> make_simulation(const Params& p, const mps::Particles& particles,
                                                 std::optional<int> comm) {
  const mps::Domain domain = make_domain(p, particles);
  if (comm)
    return std::make_unique<mps::Simulation>(particles, domain, make_config(p), std::make_unique<mps::RankExchange>(*comm));
  return std::make_unique<mps::Simulation>(particles, domain, make_config(p));
}
}  // namespace

Scene::Scene(const Params& p, mps::Particles particles, std::optional<int> comm)
    : params_(checked(with_built_tank(p))),
      sim_(make_simulation(params_, particles, comm)),
      distributed_(dynamic_cast<const mps::RankExchange*>(&sim_->exchange())),
      initial_fluid_(static_cast<long>(particles.count(mps::Kind::fluid))) {
  const Params& q = params_;
  const double L = q.tank_length, top = q.tank_height, ceiling = sim_->domain().ymax - 2 * q.l0;
  // Spray over a wall's top, or up to the domain's ceiling, leaves the scene; fluid below a wall's top stays in
  // (a particle inside a wall is counted, not hidden).
  add_dam_break_components<2>(*sim_, q, [=](const mps::Vec<2>& r) {
    return r[1] < ceiling && (r[1] < top || (r[0] > 0.0 && r[0] < L));
  });
  // A surge driven into the corner at H/50 had slipped between the wall layers and stayed there, ten particles in the
  // sensor's patch (docs/dambreak.md). Fluid pressed up to the first wall layer is left alone, as before.
  using Box = mps::WallBackstop::AxisBox;
  sim_->add<mps::WallBackstop>(Box{{0.0, 0.0}, {L, top}}, std::vector<Box>{}, 0.5 * q.l0);
  sample();
}

long Scene::removed() const {
  return static_cast<long>(sim_->exchange().sum(sim_->find<mps::RemoveEscaped>()->removed()));
}

long Scene::backstop_returns() const {
  return static_cast<long>(sim_->exchange().sum(sim_->find<mps::WallBackstop>()->returned()));
}

void Scene::step() {
  sim_->step();
  sample();
  // With no fluid left there is nothing to simulate, and a summary of it would read as a completed run.
  if (removed() >= initial_fluid_)
    throw mps::SimulationError("step " + std::to_string(sim_->last_step().step) + " (t = " + fmt(sim_->time()) +
                               " s): every fluid particle (" + std::to_string(initial_fluid_) +
                               ") has left the tank as spray; the flow blew up: lower --cfl");
}

nlohmann::json Scene::save_state() const {
  std::vector<double> time, front;
  std::vector<std::vector<double>> levels, pressures;
  for (const Sample& s : samples_) {
    time.push_back(s.time);
    front.push_back(s.front);
    levels.push_back(s.levels);
    pressures.push_back(s.pressures);
  }
  return {{"time", mps::pack_array(time)}, {"front", mps::pack_array(front)}, {"levels", pack_rows(levels)},
          {"pressures", pack_rows(pressures)}, {"most_inside_walls", most_inside_walls_},
          {"deepest_past_wall_line", deepest_past_wall_line_}};
}

void Scene::restore_state(const nlohmann::json& state) {
  std::vector<double> time, front;
  mps::unpack_array(state, "time", time);
  mps::unpack_array(state, "front", front);
  if (front.size() != time.size()) throw std::runtime_error("checkpoint: the samples' series differ in length");
  const auto levels = unpack_rows(mps::state_part(state, "levels"), time.size());
  const auto pressures = unpack_rows(mps::state_part(state, "pressures"), time.size());
  samples_.clear();
  for (std::size_t k = 0; k < time.size(); ++k) samples_.push_back({time[k], front[k], levels[k], pressures[k]});
  most_inside_walls_ = mps::unpack_value<long>(state, "most_inside_walls");
  deepest_past_wall_line_ = mps::unpack_value<double>(state, "deepest_past_wall_line");
}

void Scene::sample() {
  if (distributed_) {
    gathered_ = distributed_->gather(sim_->particles());
    if (distributed_->rank() != 0) return;
  }
  const mps::Particles& s = all_particles();
  const Params& p = params_;
  Sample sample{sim_->time(), surge_front(s, p.l0), {}, {}};
  for (double d : p.level_probes) sample.levels.push_back(mps::water_level<2>(s, {p.tank_length - d * p.height, 0.0}, p.l0));
  // The probe's patch is centred on the wall line; the first wall layer sits l0/2 behind it.
  for (double h : p.pressure_probes)
    sample.pressures.push_back(mps::patch_pressure<2>(
        s, {{p.tank_length, h * p.height}, 0, p.pressure_patch * p.l0, 0.5 * p.sensor_height * p.height}));
  samples_.push_back(std::move(sample));
  // Below the walls' top, a fluid particle past a wall line is pressed towards the wall; past the first wall layer's
  // centres (half a spacing further) it is inside the wall.
  long inside = 0;
  for (std::size_t i = 0; i < s.size(); ++i) {
    if (s.kind[i] != mps::Kind::fluid || s.y[i] >= p.tank_height) continue;
    const double depth = std::max({-s.x[i], s.x[i] - p.tank_length, -s.y[i]});
    deepest_past_wall_line_ = std::max(deepest_past_wall_line_, depth);
    inside += depth > 0.5 * p.l0;
  }
  most_inside_walls_ = std::max(most_inside_walls_, inside);
}

Table read_table(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw std::runtime_error("cannot read the experimental data " + path + ": " + std::strerror(errno));
  Table table;
  std::string line;
  for (int number = 1; std::getline(in, line); ++number) {
    line = line.substr(0, line.find('#'));
    std::istringstream fields(line);
    std::array<double, 2> row{};
    std::string extra;
    if (!(fields >> row[0])) continue;  // blank or comment line
    if (!(fields >> row[1]) || (fields >> extra) || !std::isfinite(row[0]) || !std::isfinite(row[1]))
      throw std::runtime_error(path + ":" + std::to_string(number) + ": expected two finite numbers");
    table.push_back(row);
  }
  if (table.empty()) throw std::runtime_error(path + ": no data");
  return table;
}

namespace {
// The run's front at T (linear in time between samples; before the first sample, the first sample's front).
double front_at(const std::vector<Sample>& samples, double scale, double T) {
  const auto after = std::lower_bound(samples.begin(), samples.end(), T,
                                      [&](const Sample& s, double t) { return s.time * scale < t; });
  if (after == samples.begin()) return after->front;
  const Sample& before = *(after - 1);
  const double w = (T - before.time * scale) / ((after->time - before.time) * scale);
  return (1 - w) * before.front + w * after->front;
}

// The largest relative error of the run delayed by dT over the data's points with T <= t_max; points the delayed run
// does not reach are left out. NaN if no point is compared.
double delayed_front_error(const std::vector<Sample>& samples, const Params& p, const Table& data, double t_max,
                           double dT) {
  const double scale = front_time_scale(p);
  double worst = std::numeric_limits<double>::quiet_NaN();
  for (const auto& [T, x_exp] : data) {
    if (T > t_max || samples.empty() || T - dT > samples.back().time * scale) continue;
    const double error = std::abs(front_at(samples, scale, T - dT) / p.width - x_exp) / x_exp;
    if (!(worst >= error)) worst = error;
  }
  return worst;
}
}  // namespace

double max_front_error(const std::vector<Sample>& samples, const Params& p, const Table& data, double t_max) {
  return delayed_front_error(samples, p, data, t_max, 0.0);
}

FrontLine fit_front_line(const std::vector<double>& T, const std::vector<double>& x, double t0, double t1) {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  double st = 0, sx = 0, stt = 0, stx = 0;
  int n = 0;
  for (std::size_t k = 0; k < T.size(); ++k) {
    if (T[k] < t0 || T[k] > t1) continue;
    st += T[k];
    sx += x[k];
    stt += T[k] * T[k];
    stx += T[k] * x[k];
    ++n;
  }
  const double det = n * stt - st * st;
  if (n < 2 || !(det > 0.0)) return {nan, nan, n};
  const double speed = (n * stx - st * sx) / det;
  return {speed, (sx - speed * st) / n, n};
}

FrontOffset fit_front_offset(const std::vector<Sample>& samples, const Params& p, const Table& data, double t_max) {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  std::size_t within = 0;  // every point up to t_max must be compared, or a delay could drop the worst ones
  for (const auto& point : data) within += point[0] <= t_max ? 1 : 0;
  const double scale = front_time_scale(p);
  FrontOffset best{nan, nan};
  for (int k = -500; k <= 1000; ++k) {
    const double dT = 0.001 * k;
    std::size_t reached = 0;
    for (const auto& point : data)
      reached += point[0] <= t_max && !samples.empty() && point[0] - dT <= samples.back().time * scale ? 1 : 0;
    if (reached < within || within == 0) continue;
    const double error = delayed_front_error(samples, p, data, t_max, dT);
    if (!(best.error <= error)) best = {dT, error};
  }
  return best;
}

std::pair<std::vector<double>, std::vector<double>> sampled_at(const std::vector<double>& t,
                                                               const std::vector<double>& p,
                                                               const std::vector<double>& at) {
  std::pair<std::vector<double>, std::vector<double>> kept;
  if (t.empty()) return kept;
  std::size_t k = 0;
  for (std::size_t s = 0; s < at.size(); ++s) {
    const double from = s == 0 ? at[s] : 0.5 * (at[s - 1] + at[s]);
    const double to = s + 1 == at.size() ? at[s] : 0.5 * (at[s] + at[s + 1]);
    if (to > t.back()) break;  // a cut interval's mean would be another sample's
    while (k < t.size() && t[k] < from) ++k;
    double sum = 0.0;
    std::size_t n = 0;
    for (std::size_t j = k; j < t.size() && (t[j] < to || (s + 1 == at.size() && t[j] <= to)); ++j, ++n) sum += p[j];
    if (n == 0) continue;
    kept.first.push_back(at[s]);
    kept.second.push_back(sum / static_cast<double>(n));
  }
  return kept;
}

Impact impact(const std::vector<double>& t, const std::vector<double>& p, double threshold, double window,
              double smooth) {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  Impact r{nan, nan, nan, nan, nan, nan, nan};
  const auto first = std::find_if(p.begin(), p.end(), [&](double v) { return v >= threshold; });
  if (first == p.end()) return r;
  const auto k0 = static_cast<std::size_t>(first - p.begin());
  r.arrival = t[k0];
  std::vector<double> smoothed(p.size());
  std::size_t lo = 0, hi = 0;
  double sum = 0.0;
  for (std::size_t k = 0; k < p.size(); ++k) {  // moving window [t - smooth/2, t + smooth/2]
    while (hi < p.size() && t[hi] <= t[k] + 0.5 * smooth) sum += p[hi++];
    while (t[lo] < t[k] - 0.5 * smooth) sum -= p[lo++];
    smoothed[k] = sum / static_cast<double>(hi - lo);
  }
  double lowest = p[k0], highest = p[k0], square = 0.0;
  r.peak = smoothed[k0];
  for (std::size_t k = k0; k < p.size(); ++k) {
    if (t[k] <= r.arrival + window) r.peak = std::max(r.peak, smoothed[k]);
    lowest = std::min(lowest, p[k]);
    highest = std::max(highest, p[k]);
    square += (p[k] - smoothed[k]) * (p[k] - smoothed[k]);
  }
  const double rms = std::sqrt(square / static_cast<double>(p.size() - k0));
  r.noise = highest > lowest ? rms / (highest - lowest) : 0.0;
  r.noise_rms = rms;
  double plateau = 0.0;
  int count = 0;
  for (std::size_t k = 0; k < p.size(); ++k)
    if (t[k] >= 3.5 && t[k] <= 5.0) {
      plateau += smoothed[k];
      ++count;
    }
  if (count == 0 || t.back() < 5.0) return r;
  r.plateau = plateau / count;
  for (std::size_t k = 0; k < p.size(); ++k) {
    if (t[k] < 5.0) continue;
    if (std::isnan(r.second_arrival)) {
      if (smoothed[k] < r.plateau + 0.1) continue;
      r.second_arrival = t[k];
      r.second_peak = smoothed[k];
    }
    if (t[k] <= r.second_arrival + 1.0) r.second_peak = std::max(r.second_peak, smoothed[k]);
  }
  return r;
}

}  // namespace dambreak
