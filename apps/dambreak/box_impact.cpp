#include "box_impact.hpp"

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstring>
#include <fstream>
#include <sstream>
#include <stdexcept>

namespace dambreak {

namespace {
// A gauge's water stands on the floor: its lowest particle within this many l0 of the floor (the first layer's centre
// is l0/2 above it), each next one no more than kGaugeGap l0 above the one below (a disordered column's layers, seen
// through a line l0 wide, lie closer; a sheet thrown over the line lies further).
constexpr double kGaugeFloorReach = 1.5, kGaugeGap = 2.0;

std::string fmt(double v) {
  char s[32];
  std::snprintf(s, sizeof s, "%g", v);
  return s;
}

std::vector<std::string> split_csv(const std::string& line) {
  std::vector<std::string> fields;
  std::stringstream in(line);
  for (std::string f; std::getline(in, f, ',');) {
    const auto b = f.find_first_not_of(" \t\r"), e = f.find_last_not_of(" \t\r");
    fields.push_back(b == std::string::npos ? std::string() : f.substr(b, e - b + 1));
  }
  return fields;
}

double number(const std::string& text, const std::string& where) {
  char* end = nullptr;
  errno = 0;
  const double v = std::strtod(text.c_str(), &end);
  if (text.empty() || *end != '\0' || errno != 0 || !std::isfinite(v))
    throw std::runtime_error(where + ": '" + text + "' is not a finite number");
  return v;
}

// Calls row(fields, where) for each data line of a CSV file: blank lines, '#' comments and the header (the line
// starting with `header`) skipped; `where` names the file and line for messages.
template <class Row>
void for_each_row(const std::string& path, const std::string& what, const std::string& header, Row row) {
  std::ifstream in(path);
  if (!in) throw std::runtime_error("cannot read " + what + " " + path + ": " + std::strerror(errno));
  std::string line;
  for (int n = 1; std::getline(in, line); ++n) {
    if (line.empty() || line[0] == '#' || line.rfind(header, 0) == 0) continue;
    row(split_csv(line), path + " line " + std::to_string(n));
  }
}

int lattice_count(double length, double l0) { return std::max(1, static_cast<int>(std::lround(length / l0))); }
double on_lattice(double x, double l0) { return static_cast<double>(std::lround(x / l0)) * l0; }
}  // namespace

BoxImpactSensors read_box_impact_sensors(const std::string& path) {
  BoxImpactSensors out;
  for_each_row(path, "the sensor positions", "name,", [&](const std::vector<std::string>& f, const std::string& where) {
    if (f.size() != 5) throw std::runtime_error(where + ": need name,x,y,z,face (face: front, top or gauge)");
    Sensor s{f[0], number(f[1], where), number(f[2], where), number(f[3], where), f[4]};
    if (s.face == "gauge") out.height.push_back(s);
    else if (s.face == "front" || s.face == "top") out.pressure.push_back(s);
    else throw std::runtime_error(where + ": face '" + s.face + "' is none of front, top, gauge");
  });
  if (out.pressure.empty() || out.height.empty())
    throw std::runtime_error(path + " lists no pressure sensor or no height gauge");
  return out;
}

BoxImpactGeometry box_impact_geometry(double l0, const BoxImpactSize& z) {
  const double L = lattice_count(z.tank_length, l0) * l0, W = lattice_count(z.tank_width, l0) * l0;
  BoxImpactGeometry g;
  g.tank = {0.0, 0.0, 0.0, L, W, lattice_count(z.tank_height, l0) * l0};
  g.column = {L - lattice_count(z.column_length, l0) * l0, 0.0, 0.0, L, W, lattice_count(z.column_height, l0) * l0};
  const double face = on_lattice(z.box_x1, l0);
  g.box = {face - lattice_count(z.box_x1 - z.box_x0, l0) * l0, on_lattice(z.box_y0, l0), 0.0, face,
           on_lattice(z.box_y1, l0), lattice_count(z.box_height, l0) * l0};
  return g;
}

Params box_impact_defaults() {
  Params p = defaults(Column::classic);
  const BoxImpactSize z;
  p.column = Column::spheric2;
  p.width = z.column_length;
  p.height = z.column_height;
  p.tank_length = z.tank_length;
  p.tank_height = z.tank_height;
  p.l0 = 0.04;
  p.end_time = 0.7;  // past the first impact's peak, in a few minutes (the run to 6 s: docs/dambreak3d.md)
  p.asymmetry_interior_density = 1.0;  // without it a crushed layer formed on the floor (docs/dambreak3d.md)
  p.level_probes.clear();
  p.pressure_probes.clear();
  return p;
}

mps::Particles3 make_box_impact_particles(const BoxImpactGeometry& g, double l0) {
  mps::Particles3 s;
  mps::fill_box(s, g.column, l0, mps::Kind::fluid);
  mps::add_box_walls(s, g.tank, l0, mps::x_low | mps::x_high | mps::y_low | mps::y_high | mps::z_low, 1, 4);
  // The box: one layer of wall particles under its sides and top, dummies inside (it stands on the tank's floor).
  const std::size_t first = s.size();
  mps::fill_box(s, g.box, l0, mps::Kind::dummy);
  const mps::Box& b = g.box;
  for (std::size_t i = first; i < s.size(); ++i)
    if (s.x[i] - b.x0 < l0 || b.x1 - s.x[i] < l0 || s.y[i] - b.y0 < l0 || b.y1 - s.y[i] < l0 || b.z1 - s.z[i] < l0)
      s.kind[i] = mps::Kind::wall;
  return s;
}

double box_face_pressure(const mps::Particles3& s, const BoxImpactGeometry& g, const Sensor& sensor, double reach,
                         double radius) {
  const mps::Box& b = g.box;
  const bool front = sensor.face == "front";
  double sum = 0.0;
  int count = 0;
  for (std::size_t i = 0; i < s.size(); ++i) {
    if (s.kind[i] != mps::Kind::fluid && s.kind[i] != mps::Kind::wall) continue;
    // Across the face (its normal) and along it: the front face is x = x1, the top z = z1.
    const double across = front ? s.x[i] - b.x1 : s.z[i] - b.z1;
    const double a = front ? s.y[i] - sensor.y : s.x[i] - sensor.x, c = front ? s.z[i] - sensor.z : s.y[i] - sensor.y;
    const bool on_face = front ? s.y[i] > b.y0 && s.y[i] < b.y1 && s.z[i] > b.z0 && s.z[i] < b.z1
                               : s.x[i] > b.x0 && s.x[i] < b.x1 && s.y[i] > b.y0 && s.y[i] < b.y1;
    if (std::abs(across) < reach && std::hypot(a, c) < radius && on_face) {
      sum += s.p[i];
      ++count;
    }
  }
  return count > 0 ? sum / count : 0.0;
}

double water_height(const mps::Particles3& s, double x, double y, double l0) {
  std::vector<double> line;
  for (std::size_t i = 0; i < s.size(); ++i)
    if (s.kind[i] == mps::Kind::fluid && std::hypot(s.x[i] - x, s.y[i] - y) < l0) line.push_back(s.z[i]);
  std::sort(line.begin(), line.end());
  if (line.empty() || line.front() > kGaugeFloorReach * l0) return 0.0;
  double top = line.front();
  for (double z : line) {
    if (z - top > kGaugeGap * l0) break;
    top = z;
  }
  return top + 0.5 * l0;
}

mps::Domain3 box_impact_domain(const BoxImpactGeometry& g, double l0) {
  const double margin = 6.0 * l0;
  return {g.tank.x0 - margin, g.tank.x1 + margin, g.tank.y0 - margin,
          g.tank.y1 + margin, g.tank.z0 - margin, g.tank.z1 + 0.5 * g.column.z1 + margin};
}

void add_box_impact_components(mps::Simulation3& sim, const Params& p, const BoxImpactGeometry& g) {
  const mps::Box t = g.tank, b = g.box;
  const double ceiling = sim.domain().zmax - 2 * p.l0;
  add_dam_break_components<3>(sim, p, [=](const mps::Vec<3>& r) {
    return r[2] < ceiling && (r[2] < t.z1 || (r[0] > t.x0 && r[0] < t.x1 && r[1] > t.y0 && r[1] < t.y1));
  });
  // The cubic wall lattice lets pressed fluid through its holes (docs/dambreak3d.md): put it back on the face.
  sim.add<mps::WallBackstop3>(mps::WallBackstop3::AxisBox{{t.x0, t.y0, t.z0}, {t.x1, t.y1, t.z1}},
                              std::vector<mps::WallBackstop3::AxisBox>{{{b.x0, b.y0, b.z0}, {b.x1, b.y1, b.z1}}});
}

namespace {
const Params& checked(const Params& p) {
  if (!(p.l0 > 0.0 && p.l0 <= 0.1))
    throw std::invalid_argument("3-D dam break: the spacing must be in (0, 0.1] m (the box is 0.161 m high), got " +
                                fmt(p.l0));
  if (!(p.end_time > 0.0)) throw std::invalid_argument("3-D dam break: the end time must be positive");
  return p;
}

std::unique_ptr<mps::Simulation3> make_simulation(const Params& p, const BoxImpactGeometry& g,
                                                  const mps::Particles3& particles, std::optional<int> comm) {
  const mps::Domain3 domain = box_impact_domain(g, p.l0);
  if (comm) {
    mps::DistributedOptions options;
    options.kind_weights = box_impact_kind_weights;
    return std::make_unique<mps::Simulation3>(particles, domain, make_config(p, 3),
                                              std::make_unique<mps::RankExchange3>(*comm, options));
  }
  return std::make_unique<mps::Simulation3>(particles, domain, make_config(p, 3));
}
}  // namespace

BoxImpact::BoxImpact(const Params& p, BoxImpactSensors sensors, std::optional<int> comm)
    : params_(checked(p)), sensors_(std::move(sensors)), geometry_(box_impact_geometry(p.l0)) {
  const mps::Particles3 particles = make_box_impact_particles(geometry_, p.l0);
  initial_fluid_ = static_cast<long>(particles.count(mps::Kind::fluid));
  sim_ = make_simulation(p, geometry_, particles, comm);
  distributed_ = dynamic_cast<const mps::RankExchange3*>(&sim_->exchange());
  add_box_impact_components(*sim_, p, geometry_);
  sample();
}

long BoxImpact::backstop_returns() const {
  return static_cast<long>(sim_->exchange().sum(sim_->find<mps::WallBackstop3>()->returned()));
}

long BoxImpact::removed() const {
  return static_cast<long>(sim_->exchange().sum(sim_->find<mps::RemoveEscaped3>()->removed()));
}

void BoxImpact::step() {
  sim_->step();
  sample();
  if (removed() >= initial_fluid_)
    throw mps::SimulationError("step " + std::to_string(sim_->last_step().step) + " (t = " + fmt(sim_->time()) +
                               " s): every fluid particle has left the tank as spray; the flow blew up: lower --cfl");
}

void BoxImpact::sample() {
  if (distributed_) {
    gathered_ = distributed_->gather(sim_->particles());
    if (distributed_->rank() != 0) return;
  }
  const mps::Particles3& s = all_particles();
  const double l0 = params_.l0;
  BoxImpactSample sample{sim_->time(), {}, {}};
  for (const Sensor& sensor : sensors_.pressure)
    sample.pressures.push_back(box_face_pressure(s, geometry_, sensor, patch_reach(), patch_radius()));
  for (const Sensor& gauge : sensors_.height) sample.heights.push_back(water_height(s, gauge.x, gauge.y, l0));
  samples_.push_back(std::move(sample));
  // Below the walls' top, fluid past a wall's or the box's surface is pressed into it; past the first layer's centres
  // (half a spacing further) it is inside.
  const mps::Box t = geometry_.tank, b = geometry_.box;
  long inside = 0;
  for (std::size_t i = 0; i < s.size(); ++i) {
    if (s.kind[i] != mps::Kind::fluid || s.z[i] >= t.z1) continue;
    double depth = std::max({t.x0 - s.x[i], s.x[i] - t.x1, t.y0 - s.y[i], s.y[i] - t.y1, t.z0 - s.z[i]});
    depth = std::max(depth, std::min({s.x[i] - b.x0, b.x1 - s.x[i], s.y[i] - b.y0, b.y1 - s.y[i], b.z1 - s.z[i]}));
    deepest_past_wall_ = std::max(deepest_past_wall_, depth);
    inside += depth > 0.5 * l0;
  }
  most_inside_walls_ = std::max(most_inside_walls_, inside);
}

BoxImpactRecord read_box_impact_record(const std::string& path) {
  BoxImpactRecord r;
  for_each_row(path, "the experiment's record", "time", [&](const std::vector<std::string>& f, const std::string& where) {
    if (f.size() != 4) throw std::runtime_error(where + ": need time, P1, H2, H4");
    r.time.push_back(number(f[0], where));
    r.p1.push_back(number(f[1], where));
    r.h2.push_back(number(f[2], where));
    r.h4.push_back(number(f[3], where));
    if (r.time.size() > 1 && !(r.time.back() > r.time[r.time.size() - 2]))
      throw std::runtime_error(where + ": the times must increase");
  });
  if (r.time.size() < 2) throw std::runtime_error(path + " holds fewer than two records");
  return r;
}

double mean_absolute_error(const std::vector<double>& run_time, const std::vector<double>& run,
                           const std::vector<double>& time, const std::vector<double>& record, double t0, double t1) {
  double sum = 0.0;
  int n = 0;
  for (std::size_t k = 0; k < time.size(); ++k) {
    const double t = time[k];
    if (t < t0 || t > t1 || run_time.empty() || t < run_time.front() || t > run_time.back()) continue;
    const auto hi = std::lower_bound(run_time.begin(), run_time.end(), t);
    const auto j = static_cast<std::size_t>(hi - run_time.begin());
    double value = run[j];
    if (j > 0 && run_time[j] > t) {
      const double w = (t - run_time[j - 1]) / (run_time[j] - run_time[j - 1]);
      value = (1 - w) * run[j - 1] + w * run[j];
    }
    sum += std::abs(value - record[k]);
    ++n;
  }
  return n > 0 ? sum / n : std::nan("");
}

}  // namespace dambreak
