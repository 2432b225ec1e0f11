#include "scene.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

#include "mps/boundaries/geometry.hpp"
#include "mps/core/state.hpp"
#include "mps/io/probes.hpp"

namespace fsi {

namespace {

int whole(double length, double l0, const char* what) {
  const double n = length / l0;
  if (std::abs(n - std::round(n)) > 1e-6 * n)
    throw std::invalid_argument(std::string("the spacing ") + std::to_string(l0) + " m does not divide the " + what +
                                " (" + std::to_string(length) + " m): pick one that does");
  return static_cast<int>(std::round(n));
}

// Fluid, tank and the body's lattice (nx across, ny up, lower-left corner (x0, y0)); the body is held in `clamp`
// rows below (plate) or above (gate) itself. Its face layers facing the fluid are wall particles, the rest dummies.
struct Layout {
  mps::Particles particles;
  mps::ElasticBody body;
  int first_id = 0;
};

void add_body(Layout& l, double x0, double y0, int nx, int ny, double l0, bool clamp_below, bool bottom_is_face,
              bool top_is_face) {
  l.first_id = static_cast<int>(l.particles.size());
  // Held by 3 rows (the solid's kernel radius) inside the fluid's own walls (floor, rigid wall).
  l.body = mps::clamped_box_body({x0, y0, nx, ny, l0}, clamp_below ? mps::y_low : mps::y_high, 3);
  for (int j = 0; j < ny; ++j)
    for (int i = 0; i < nx; ++i) {
      const bool face = i == 0 || i == nx - 1 || (bottom_is_face && j == 0) || (top_is_face && j == ny - 1);
      l.particles.add(x0 + (i + 0.5) * l0, y0 + (j + 0.5) * l0, face ? mps::Kind::wall : mps::Kind::dummy, 1);
    }
}

}  // namespace

Case case_from_name(const std::string& name) {
  if (name == "plate") return Case::plate;
  if (name == "gate") return Case::gate;
  throw std::invalid_argument("unknown fsi scene '" + name + "': use plate or gate");
}

Params defaults(Case c) {
  Params p;
  p.scene = c;
  if (c == Case::gate) {
    const double k = 1.67e7, g = 3.57e6;
    p.l0 = 0.00125;
    p.youngs_modulus = 9 * k * g / (3 * k + g);
    p.poisson_ratio = (3 * k - 2 * g) / (2 * (3 * k + g));
    p.end_time = 0.4;
    // The gate holds still water, which the conservative gradient does not keep at rest (docs/fsi.md).
    p.pressure_gradient = mps::GradientVariant::min_reference;
  }
  return p;
}

Scene::Scene(const Params& p) : params_(p) {
  dambreak::Params d = dambreak::defaults(dambreak::Column::classic);
  d.pressure_treatment = p.pressure_treatment;
  d.stabilisation_distance = p.stabilisation_distance;
  d.l0 = p.l0;
  d.end_time = p.end_time;
  d.solver = p.solver;
  d.cfl = p.cfl;
  Layout l;
  mps::Domain domain;
  if (p.scene == Case::plate) {
    const int nx = whole(0.012, p.l0, "plate's thickness"), ny = whole(0.08, p.l0, "plate's height");
    if (nx < 3) throw std::invalid_argument("the plate needs at least 3 particles across: lower --dx");
    water_width = std::round(0.146 / p.l0) * p.l0;  // 0.144 at l0 = 0.004
    water_height = 2 * water_width;
    d.width = water_width;
    d.height = water_height;
    d.tank_length = 4 * 0.146;
    mps::fill_rectangle(l.particles, {0.0, 0.0, d.width, d.height}, p.l0, mps::Kind::fluid);
    mps::add_rectangle_walls(l.particles, {0.0, 0.0, d.tank_length, d.tank_height}, p.l0,
                             mps::left | mps::right | mps::bottom, 1, 4);
    body_x = 2 * 0.146;
    body_width = nx * p.l0;
    body_height = ny * p.l0;
    add_body(l, body_x, 0.0, nx, ny, p.l0, true, false, true);
    probe_x_ = body_x + 0.5 * body_width;
    probe_y_ = body_height;
    domain = dambreak::make_domain(d);
  } else {
    const int nx = whole(0.005, p.l0, "gate's thickness");
    if (nx < 3) throw std::invalid_argument("the gate needs at least 3 particles across: lower --dx");
    const int ny = static_cast<int>(std::round(0.079 / p.l0));  // 63 at l0 = 0.00125 (0.07875 m)
    water_width = std::round(0.1 / p.l0) * p.l0;
    water_height = std::round(0.14 / p.l0) * p.l0;
    body_x = water_width;
    body_width = nx * p.l0;
    body_height = ny * p.l0;
    const double tank = water_width + body_width + 0.15, wall_top = water_height + 0.04;
    d.width = water_width;
    d.height = water_height;
    d.tank_length = tank;
    d.tank_height = wall_top;
    mps::fill_rectangle(l.particles, {0.0, 0.0, water_width, water_height}, p.l0, mps::Kind::fluid);
    mps::add_rectangle_walls(l.particles, {0.0, 0.0, tank, wall_top}, p.l0, mps::left | mps::right | mps::bottom, 1, 4);
    // The rigid wall the gate hangs from: the gate's own lattice continued up to the walls' top, its face to the
    // water a wall layer, the rest dummies.
    for (int j = ny; body_height + (j - ny + 0.5) * p.l0 < wall_top; ++j)
      for (int i = 0; i < nx; ++i)
        l.particles.add(body_x + (i + 0.5) * p.l0, (j + 0.5) * p.l0, i == 0 ? mps::Kind::wall : mps::Kind::dummy, 0);
    add_body(l, body_x, 0.0, nx, ny, p.l0, false, true, false);
    probe_x_ = body_x + 0.5 * body_width;
    probe_y_ = 0.0;
    domain = {-6 * p.l0, tank + 6 * p.l0, -6 * p.l0, wall_top + 0.05};
  }
  body_particles_ = static_cast<std::size_t>(l.body.size() - static_cast<std::size_t>(std::count(l.body.clamped.begin(), l.body.clamped.end(), 1)));
  mps::SimulationConfig c = dambreak::make_config(d);
  c.pressure_gradient = p.pressure_gradient;
  c.hydrostatic_split = false;  // the body must feel the whole pressure
  sim_ = std::make_unique<mps::Simulation>(std::move(l.particles), domain, c);
  if (p.collision > 0) sim_->add<mps::ParticleCollision>(p.collision, d.restitution);
  if (p.asymmetry > 0) sim_->add<mps::AsymmetrySurface>(p.asymmetry);
  if (p.wet_walls) sim_->add<mps::WetWalls>();
  const double L = d.tank_length, top = d.tank_height, ceiling = domain.ymax - 2 * p.l0;
  sim_->add<mps::RemoveEscaped>([=](double x, double y) { return y < ceiling && (y < top || (x > 0.0 && x < L)); });
  if (p.rigid) {
    rigid_force_ = &sim_->add<mps::WallForce>(1);
  } else {
    mps::ElasticConfig ec;
    ec.material = {p.density, p.youngs_modulus, p.poisson_ratio, mps::ElasticModel::saint_venant_kirchhoff};
    ec.cfl = p.solid_cfl;
    ec.cfl_option = "--solid-cfl";
    ec.gravity_y = -d.g;
    const double x0 = body_x, y0 = body_y, w = body_width, h = body_height;
    structure_ = &sim_->add<mps::ElasticStructure>(
        mps::ElasticSolid(l.body, ec), 1, l.first_id,
        [=](double X, double Y) { return X > x0 && X < x0 + w && Y > y0 && Y < y0 + h; }, p.relaxation);
  }
  sample();
}

void Scene::step() {
  sim_->step();
  sample();
}

void Scene::sample() {
  Sample s{sim_->time(), 0.0, 0.0, 0.0, 0.0};
  if (structure_) {
    const auto d = structure_->solid().displacement_at(probe_x_, probe_y_);
    s.tip_x = d[0];
    s.tip_y = d[1];
    s.force_x = structure_->load()[0];
  }
  if (rigid_force_) s.force_x = rigid_force_->force()[0];
  if (params_.scene == Case::gate) s.level = mps::water_level<2>(sim_->particles(), {0.5 * water_width, 0.0}, params_.l0);
  samples_.push_back(s);
}

nlohmann::json Scene::save_state() const {
  std::vector<double> values;
  for (const Sample& s : samples_) values.insert(values.end(), {s.time, s.tip_x, s.tip_y, s.force_x, s.level});
  return {{"samples", mps::pack_array(values)}};
}

void Scene::restore_state(const nlohmann::json& state) {
  std::vector<double> values;
  mps::unpack_array(state, "samples", values);
  if (values.size() % 5 != 0) throw std::runtime_error("checkpoint: the samples do not add up (a damaged file?)");
  samples_.clear();
  for (std::size_t k = 0; k < values.size(); k += 5)
    samples_.push_back({values[k], values[k + 1], values[k + 2], values[k + 3], values[k + 4]});
}

}  // namespace fsi
