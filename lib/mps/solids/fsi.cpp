#include "mps/solids/fsi.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <sstream>
#include <stdexcept>

#include "mps/core/state.hpp"
#include "mps/numerics/operators.hpp"

namespace mps {
namespace {
void require_whole_pressure(const StepFields& f) {
  if (!f.pressure_offset.empty())
    throw std::invalid_argument("a structure's pressure force needs the whole pressure: set hydrostatic_split = false "
                                "(the split leaves the hydrostatic part out of the solved pressure)");
}

// Multiplies the per-particle values by `scale` and returns the sum of the forces.
std::array<double, 2> scaled_total(double scale, std::span<double> fx, std::span<double> fy) {
  std::array<double, 2> total{0.0, 0.0};
  for (std::size_t j = 0; j < fx.size(); ++j) {
    fx[j] *= scale;
    fy[j] *= scale;
    total[0] += fx[j];
    total[1] += fy[j];
  }
  return total;
}
}  // namespace

std::array<double, 2> pressure_force_on(const StepContext& context, std::span<const char> target, std::span<double> fx,
                                        std::span<double> fy) {
  const Simulation& sim = context.sim;
  const StepFields& f = context.fields;
  const Particles& p = context.particles;
  require_whole_pressure(f);
  const Kernel& k = sim.gradient_kernel();
  gradient({p, sim.domain(), sim.neighbors_at_star(k), k}, p.p, fx, fy, GradientVariant::corrected, f.carriers);
  for (std::size_t j = 0; j < p.size(); ++j)
    if (!target[j]) fx[j] = fy[j] = 0.0;
  return scaled_total(-sim.config().l0 * sim.config().l0, fx, fy);
}

std::array<double, 2> pressure_reaction_on(const StepContext& context, std::span<const char> target,
                                           std::span<double> fx, std::span<double> fy) {
  const Simulation& sim = context.sim;
  const StepFields& f = context.fields;
  const Particles& p = context.particles;
  if (sim.config().pressure_gradient != GradientVariant::conservative)
    throw std::invalid_argument("a structure's pressure force is the reaction of the fluid's pressure pairs, which "
                                "only the conservative gradient makes equal and opposite: set pressure_gradient = "
                                "conservative (now " + std::string(to_string(sim.config().pressure_gradient)) + ")");
  require_whole_pressure(f);
  std::vector<char> moved(p.size(), 0);  // the fluid the corrector moves
  for (std::size_t i = 0; i < p.size(); ++i) moved[i] = p.kind[i] == Kind::fluid && !f.prescribed[i];
  const Kernel& k = sim.gradient_kernel();
  conservative_gradient_terms({p, sim.domain(), sim.neighbors_at_star(k), k}, p.p, moved, target, f.carriers, fx, fy);
  return scaled_total(sim.config().l0 * sim.config().l0, fx, fy);
}

std::array<double, 2> structure_load(const StepContext& context, std::span<const char> target, std::span<double> fx,
                                     std::span<double> fy) {
  return context.sim.config().pressure_gradient == GradientVariant::conservative
             ? pressure_reaction_on(context, target, fx, fy)
             : pressure_force_on(context, target, fx, fy);
}

namespace {
// The force on a structure's particle is the pressure gradient at it, summed over its row: a dummy's row too.
void mark_group_rows(const Particles& p, int group, std::span<char> rows) {
  for (std::size_t i = 0; i < p.size(); ++i)
    if (p.group[i] == group && p.kind[i] == Kind::dummy) rows[i] = 1;
}
}  // namespace

void WallForce::mark_rows_read(const Particles& particles, std::span<char> rows) const {
  mark_group_rows(particles, group_, rows);
}

void WallForce::after_pressure(StepContext& context) {
  const Particles& p = context.particles;
  target_.assign(p.size(), 0);
  for (std::size_t i = 0; i < p.size(); ++i)
    target_[i] = p.group[i] == group_ && (p.kind[i] == Kind::wall || p.kind[i] == Kind::dummy);
  fx_.assign(p.size(), 0.0);
  fy_.assign(p.size(), 0.0);
  force_ = structure_load(context, target_, fx_, fy_);
}

ElasticStructure::ElasticStructure(ElasticSolid solid, int group, int first_id,
                                   std::function<bool(double, double)> inside_reference, double relaxation)
    : solid_(std::move(solid)), group_(group), first_id_(first_id), inside_reference_(std::move(inside_reference)),
      relaxation_(relaxation) {
  if (!(relaxation_ > 0.0 && relaxation_ <= 1.0))
    throw std::invalid_argument("ElasticStructure: the load relaxation must lie in (0, 1], got " +
                                std::to_string(relaxation_));
  if (!inside_reference_) throw std::invalid_argument("ElasticStructure: the body's inside test is missing");
  load_x_.assign(solid_.size(), 0.0);
  load_y_.assign(solid_.size(), 0.0);
}

// Reorders move particles around: find the structure's fluid particles by id each step.
void ElasticStructure::map_particles(const Particles& p) {
  fluid_of_solid_.assign(solid_.size(), -1);
  std::size_t found = 0;
  for (std::size_t i = 0; i < p.size(); ++i) {
    if (p.group[i] != group_ || p.kind[i] == Kind::fluid || p.kind[i] == Kind::ghost) continue;
    // ElasticSolid puts the moving particles first, in body order: the k-th of them is the fluid's first_id + k.
    const int k = p.id[i] - first_id_;
    if (k < 0 || k >= static_cast<int>(solid_.moving()))
      throw std::invalid_argument("ElasticStructure: particle id " + std::to_string(p.id[i]) + " of group " +
                                  std::to_string(group_) + " is not one of the body's");
    fluid_of_solid_[static_cast<std::size_t>(k)] = static_cast<int>(i);
    ++found;
  }
  if (found != solid_.moving())
    throw std::invalid_argument("ElasticStructure: the fluid holds " + std::to_string(found) + " particles of group " +
                                std::to_string(group_) + ", the body moves " + std::to_string(solid_.moving()));
}

namespace {
double seconds_since(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}
}  // namespace

void ElasticStructure::before_predictor(StepContext& context) {
  const auto start = std::chrono::steady_clock::now();
  map_particles(context.particles);
  coupling_seconds_ += seconds_since(start);
}

void ElasticStructure::after_predictor(StepContext& context) {
  const double duration = context.fields.time - solid_.time();
  const auto start = std::chrono::steady_clock::now();
  substeps_ = solid_.advance(duration);
  solid_seconds_ += seconds_since(start);
  Particles& p = context.particles;
  for (std::size_t k = 0; k < solid_.moving(); ++k) {
    const auto i = static_cast<std::size_t>(fluid_of_solid_[k]);
    p.x[i] = solid_.x()[k];
    p.y[i] = solid_.y()[k];
    p.u[i] = solid_.u()[k];
    p.v[i] = solid_.v()[k];
  }
}

void ElasticStructure::mark_rows_read(const Particles& particles, std::span<char> rows) const {
  mark_group_rows(particles, group_, rows);
}

void ElasticStructure::after_pressure(StepContext& context) {
  const auto start = std::chrono::steady_clock::now();
  const std::size_t n = context.particles.size();
  target_.assign(n, 0);
  for (std::size_t k = 0; k < solid_.moving(); ++k) target_[static_cast<std::size_t>(fluid_of_solid_[k])] = 1;
  fx_.assign(n, 0.0);
  fy_.assign(n, 0.0);
  on_structure_ = structure_load(context, target_, fx_, fy_);
  for (std::size_t k = 0; k < solid_.moving(); ++k) {
    const auto i = static_cast<std::size_t>(fluid_of_solid_[k]);
    load_x_[k] += relaxation_ * (fx_[i] - load_x_[k]);
    load_y_[k] += relaxation_ * (fy_[i] - load_y_[k]);
  }
  solid_.set_external_force(load_x_, load_y_);
  coupling_seconds_ += seconds_since(start);
}

nlohmann::json ElasticStructure::save_state() const {
  return {{"solid", solid_.save_state()}, {"load_x", pack_array(load_x_)}, {"load_y", pack_array(load_y_)},
          {"on_structure", on_structure_}, {"substeps", substeps_}, {"solid_seconds", solid_seconds_},
          {"coupling_seconds", coupling_seconds_}};
}

void ElasticStructure::restore_state(const nlohmann::json& state) {
  std::vector<double> load_x, load_y;
  unpack_array(state, "load_x", load_x);
  unpack_array(state, "load_y", load_y);
  if (load_x.size() != load_x_.size() || load_y.size() != load_y_.size())
    throw std::runtime_error("checkpoint: the load of a structure of " + std::to_string(load_x.size()) +
                             " particles, this one has " + std::to_string(load_x_.size()));
  solid_.restore_state(state_part(state, "solid"));
  load_x_ = std::move(load_x);
  load_y_ = std::move(load_y);
  on_structure_ = unpack_value<std::array<double, 2>>(state, "on_structure");
  substeps_ = unpack_value<int>(state, "substeps");
  solid_seconds_ = unpack_value<double>(state, "solid_seconds");
  coupling_seconds_ = unpack_value<double>(state, "coupling_seconds");
}

std::array<double, 2> ElasticStructure::load() const {
  std::array<double, 2> total{0.0, 0.0};
  for (std::size_t k = 0; k < solid_.moving(); ++k) {
    total[0] += load_x_[k];
    total[1] += load_y_[k];
  }
  return total;
}

void ElasticStructure::after_corrector(StepContext& context) {
  // Fluid inside the body: map each fluid particle near the body back to the reference configuration through the
  // nearest structure particle's F, and ask the body's shape.
  const auto start = std::chrono::steady_clock::now();
  const Particles& p = context.particles;
  const auto& F = solid_.deformation_gradient();
  double xmin = 1e300, xmax = -1e300, ymin = 1e300, ymax = -1e300;
  for (std::size_t k = 0; k < solid_.moving(); ++k) {
    xmin = std::min(xmin, solid_.x()[k]);
    xmax = std::max(xmax, solid_.x()[k]);
    ymin = std::min(ymin, solid_.y()[k]);
    ymax = std::max(ymax, solid_.y()[k]);
  }
  const double margin = context.sim.config().l0;
  for (std::size_t i = 0; i < p.size(); ++i) {
    if (p.kind[i] != Kind::fluid || p.x[i] < xmin - margin || p.x[i] > xmax + margin || p.y[i] < ymin - margin ||
        p.y[i] > ymax + margin)
      continue;
    std::size_t nearest = 0;
    double best = 1e300;
    for (std::size_t k = 0; k < solid_.moving(); ++k) {
      const double d = std::hypot(p.x[i] - solid_.x()[k], p.y[i] - solid_.y()[k]);
      if (d < best) {
        best = d;
        nearest = k;
      }
    }
    const double a = F[0][nearest], b = F[1][nearest], c = F[2][nearest], d = F[3][nearest], det = a * d - b * c;
    const double dx = p.x[i] - solid_.x()[nearest], dy = p.y[i] - solid_.y()[nearest];
    const double X = solid_.reference_x()[nearest] + (d * dx - b * dy) / det;
    const double Y = solid_.reference_y()[nearest] + (-c * dx + a * dy) / det;
    if (inside_reference_(X, Y)) {
      std::ostringstream msg;
      msg << "fluid particle " << p.id[i] << " at (" << p.x[i] << ", " << p.y[i]
          << ") is inside the elastic structure (reference point (" << X << ", " << Y
          << ")): lower the time step or refine the structure";
      throw SimulationError(msg.str());
    }
  }
  coupling_seconds_ += seconds_since(start);
}

}  // namespace mps
