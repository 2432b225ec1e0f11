#include "plate.hpp"

#include <cmath>
#include <stdexcept>
#include <string>

#include "mps/geometry.hpp"

namespace fsi {

namespace {

int whole(double length, double l0, const char* what) {
  const double n = length / l0;
  if (std::abs(n - std::round(n)) > 1e-6 * n)
    throw std::invalid_argument(std::string("the spacing ") + std::to_string(l0) + " m does not divide the " + what +
                                " (" + std::to_string(length) + " m): pick one that does");
  return static_cast<int>(std::round(n));
}

}  // namespace

PlateScene::PlateScene(const PlateParams& p) : params_(p) {
  const int nx = whole(p.plate_thickness, p.l0, "plate's thickness"), ny = whole(p.plate_height, p.l0, "plate's height");
  if (nx < 3) throw std::invalid_argument("the plate needs at least 3 particles across: lower --dx");
  dambreak::Params d = dambreak::defaults(dambreak::Column::classic);
  d.l0 = p.l0;
  width_ = std::round(p.column_width / p.l0) * p.l0;
  d.width = width_;
  d.height = 2 * width_;
  d.tank_length = 4 * p.column_width;
  d.end_time = p.end_time;
  d.solver = p.solver;
  mps::SimulationConfig c = dambreak::make_config(d);
  c.hydrostatic_split = false;  // the structure must feel the whole pressure through the corrector's pairs

  mps::Particles particles;
  mps::fill_rectangle(particles, {0.0, 0.0, d.width, d.height}, p.l0, mps::Kind::fluid);
  mps::add_rectangle_walls(particles, {0.0, 0.0, d.tank_length, d.tank_height}, p.l0, mps::left | mps::right | mps::bottom,
                           1, 4);
  // The plate: the face layers and the top row are wall particles (PPE unknowns), the inside dummies.
  const double x0 = 2 * p.column_width;
  const int first_id = static_cast<int>(particles.size());
  mps::ElasticBody body;
  body.spacing = p.l0;
  const int clamp = 3;  // rows below the floor line held: the solid's kernel radius is 3 spacings
  for (int j = -clamp; j < ny; ++j)
    for (int i = 0; i < nx; ++i) {
      const double x = x0 + (i + 0.5) * p.l0, y = (j + 0.5) * p.l0;
      body.add(x, y, p.l0 * p.l0, j < 0);
      if (j < 0) continue;  // the floor's own walls are there for the fluid
      const bool face = i == 0 || i == nx - 1 || j == ny - 1;
      particles.add(x, y, face ? mps::Kind::wall : mps::Kind::dummy, p.rigid ? 0 : 1);
    }
  plate_particles_ = static_cast<std::size_t>(nx * ny);

  mps::Domain domain = dambreak::make_domain(d);
  sim_ = std::make_unique<mps::Simulation>(std::move(particles), domain, c);
  sim_->add<mps::ParticleCollision>(d.collision, d.restitution);
  sim_->add<mps::AsymmetrySurface>(d.asymmetry);
  const double L = d.tank_length, top = d.tank_height, ceiling = domain.ymax - 2 * p.l0;
  sim_->add<mps::RemoveEscaped>([=](double x, double y) { return y < ceiling && (y < top || (x > 0.0 && x < L)); });
  if (!p.rigid) {
    mps::ElasticConfig ec;
    ec.material = {p.plate_density, p.youngs_modulus, p.poisson_ratio, mps::ElasticModel::saint_venant_kirchhoff};
    ec.cfl = p.solid_cfl;
    ec.gravity_y = -d.g;
    const double t = p.plate_thickness, h = p.plate_height;
    structure_ = &sim_->add<mps::ElasticStructure>(mps::ElasticSolid(body, ec), 1, first_id,
                                                   [=](double X, double Y) { return X > x0 && X < x0 + t && Y > 0 && Y < h; },
                                                   p.relaxation);
  }
  sample();
}

void PlateScene::step() {
  sim_->step();
  sample();
}

void PlateScene::sample() {
  PlateSample s{sim_->time(), 0.0, 0.0, 0.0};
  if (structure_) {
    const auto d = structure_->solid().displacement_at(2 * params_.column_width + 0.5 * params_.plate_thickness,
                                                        params_.plate_height);
    s.tip_x = d[0];
    s.tip_y = d[1];
    s.force_x = structure_->load()[0];
  }
  samples_.push_back(s);
}

}  // namespace fsi
