#include "mps/fsi.hpp"

#include <algorithm>
#include <cmath>
#include <sstream>
#include <stdexcept>

#include "mps/operators.hpp"

namespace mps {

ElasticStructure::ElasticStructure(ElasticSolid solid, int group, int first_id,
                                   std::function<bool(double, double)> inside_reference)
    : solid_(std::move(solid)), group_(group), first_id_(first_id), inside_reference_(std::move(inside_reference)) {
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

void ElasticStructure::before_predictor(StepContext& context) { map_particles(context.particles); }

void ElasticStructure::after_predictor(StepContext& context) {
  const double duration = context.fields.time - solid_.time();
  substeps_ = solid_.advance(duration);
  Particles& p = context.particles;
  for (std::size_t k = 0; k < solid_.moving(); ++k) {
    const auto i = static_cast<std::size_t>(fluid_of_solid_[k]);
    p.x[i] = solid_.x()[k];
    p.y[i] = solid_.y()[k];
    p.u[i] = solid_.u()[k];
    p.v[i] = solid_.v()[k];
  }
}

void ElasticStructure::after_pressure(StepContext& context) {
  const Simulation& sim = context.sim;
  const StepFields& f = context.fields;
  const Particles& p = context.particles;
  if (!f.pressure_offset.empty())
    throw std::invalid_argument("ElasticStructure needs the whole pressure in the corrector: set hydrostatic_split = "
                                "false (the split's hydrostatic part acts on no pair)");
  const std::size_t n = p.size();
  target_.assign(n, 0);
  acting_.assign(n, 0);
  for (std::size_t k = 0; k < solid_.moving(); ++k) target_[static_cast<std::size_t>(fluid_of_solid_[k])] = 1;
  for (std::size_t i = 0; i < n; ++i) acting_[i] = p.kind[i] == Kind::fluid && (f.prescribed.empty() || !f.prescribed[i]);
  fx_.assign(n, 0.0);
  fy_.assign(n, 0.0);
  const auto& c = sim.config();
  const double tilt = c.min_reference_tilt ? c.rho : 0.0;
  on_fluid_ = pressure_pair_reactions({p, sim.domain(), sim.neighbors_at_star(sim.gradient_kernel()), sim.gradient_kernel()},
                                      p.p, c.pressure_gradient, f.carriers,
                                      {tilt * (c.fx - f.balanced_fx), tilt * (c.fy - f.balanced_fy)},
                                      f.surface_own_reference ? std::span<const char>(f.surface) : std::span<const char>(),
                                      acting_, target_, c.l0 * c.l0, fx_, fy_);
  on_structure_ = {0.0, 0.0};
  double scale = 0.0;
  for (std::size_t k = 0; k < solid_.moving(); ++k) {
    const auto i = static_cast<std::size_t>(fluid_of_solid_[k]);
    load_x_[k] = fx_[i];
    load_y_[k] = fy_[i];
    on_structure_[0] += fx_[i];
    on_structure_[1] += fy_[i];
    scale += std::abs(fx_[i]) + std::abs(fy_[i]);
  }
  const double imbalance = std::hypot(on_structure_[0] + on_fluid_[0], on_structure_[1] + on_fluid_[1]);
  if (imbalance > 1e-9 * std::max(scale, 1e-300))
    throw SimulationError("fluid-structure forces out of balance by " + std::to_string(imbalance) + " N/m");
  solid_.set_external_force(load_x_, load_y_);
}

void ElasticStructure::after_corrector(StepContext& context) {
  // Fluid inside the body: map each fluid particle near the body back to the reference configuration through the
  // nearest structure particle's F, and ask the body's shape.
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
}

}  // namespace mps
