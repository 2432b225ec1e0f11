#include "mps/step/components.hpp"
#include "mps/core/threads.hpp"
#include "mps/core/vec.hpp"

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <limits>
#include <stdexcept>
#include <string>

namespace mps {

// Mirrored values in div u* would put the fluid's streamwise changes into the source wherever the flow develops
// or the wall changes speed (an inlet channel grew a period-2 pressure oscillation that way).
template <int D>
void BasicMirrorNoSlip<D>::before_projection(StepContext& c) {
  BasicParticles<D>& p = c.particles;
  for (std::size_t i = 0; i < p.size(); ++i)
    if ((p.kind[i] == Kind::wall || p.kind[i] == Kind::dummy) && p.group[i] == wall_.group) {
      const auto U = wall_.velocity_at(p.x[i], p.y[i]);
      p.u[i] = U[0];
      p.v[i] = U[1];
      if constexpr (D == 3) p.w[i] = 0.0;
    }
}

template <int D>
BasicOpenOutlet<D>::BasicOpenOutlet(const BasicOutflowBuffer<D>& buffer) : buffer_(buffer) {
  buffer_.validate();
}

template <int D>
void BasicOpenOutlet<D>::before_predictor(StepContext& c) {
  BasicParticles<D>& p = c.particles;
  in_buffer_.assign(p.size(), 0);
  for (std::size_t i = 0; i < p.size(); ++i)
    in_buffer_[i] = p.kind[i] != Kind::ghost && buffer_.contains(p.position(i));
  apply_outflow_velocity(buffer_, c.sim.grid(), c.sim.gradient_kernel().re, in_buffer_, p);
  for (std::size_t i = 0; i < p.size(); ++i)
    if (in_buffer_[i]) c.fields.prescribed[i] = 1;
}

template <int D>
double BasicOpenOutlet<D>::reach(const BasicSimulation<D>& sim) const {
  return buffer_.thickness + 2.0 * sim.gradient_kernel().re;
}

template <int D>
bool BasicOpenOutlet<D>::runs_after(const BasicStepComponent<D>& other) const {
  return dynamic_cast<const BasicHydrostaticSplit<D>*>(&other) != nullptr;
}

// Buffer fluid that crossed the outlet may have become a ghost (and a pushing plate may recycle it): left flagged, it
// was held at P = 0 and read as a carrier. Decided after the predictor's exchange, so that halo copies decide from
// their owners' r* and kinds as their owners do; copies appended after before_predictor (of particles that were
// ghosts at the step's start) were in no buffer.
template <int D>
void BasicOpenOutlet<D>::before_source(StepContext& c) {
  const BasicParticles<D>& p = c.particles;
  in_buffer_.resize(p.size(), 0);
  for (std::size_t i = 0; i < p.size(); ++i)
    if (in_buffer_[i] && (p.kind[i] == Kind::ghost || !buffer_.contains(p.position(i)))) {
      in_buffer_[i] = 0;
      c.fields.prescribed[i] = 0;
    }
}

// Held at P = 0 like a free surface, but no surface: the fluid beside it has full kernels, so its number density
// stays in the source.
template <int D>
void BasicOpenOutlet<D>::before_assembly(StepContext& c) {
  BasicStepFields<D>& f = c.fields;
  if (f.held.empty()) f.held = f.surface;
  for (std::size_t i = 0; i < in_buffer_.size(); ++i)
    if (in_buffer_[i]) {
      f.held[i] = 1;
      if (!f.held_value.empty()) f.held_value[i] = f.pressure_offset.empty() ? 0.0 : -f.pressure_offset[i];
    }
}

template <int D>
void BasicOpenOutlet<D>::after_pressure(StepContext& c) {
  for (std::size_t i = 0; i < in_buffer_.size(); ++i)
    if (in_buffer_[i]) {
      c.particles.p[i] = 0.0;
      c.fields.carriers[i] = 1;
    }
}

// Mirrored values in div u* would put the fluid's streamwise changes into the source (MirrorNoSlip's reason).
template <int D>
void BasicMirrorPlaneNoSlip<D>::before_projection(StepContext& c) {
  BasicParticles<D>& p = c.particles;
  const auto vel = p.velocities();
  for (std::size_t i = 0; i < p.size(); ++i)
    if ((p.kind[i] == Kind::wall || p.kind[i] == Kind::dummy) && p.group[i] == wall_.group)
      for (std::size_t a = 0; a < D; ++a) (*vel[a])[i] = wall_.velocity[a];
}

template <int D>
void BasicSurfaceRegion<D>::before_source(StepContext& c) {
  const BasicParticles<D>& p = c.particles;
  std::vector<char>& surface = c.fields.surface;
  for (std::size_t i = 0; i < surface.size(); ++i)
    if (surface[i] && !region_(p.position(i))) surface[i] = 0;
}

template <int D>
BasicAsymmetrySurface<D>::BasicAsymmetrySurface(double fraction, double interior_density)
    : fraction_(fraction), interior_density_(interior_density) {
  if (!(interior_density >= 0.0 && std::isfinite(interior_density)))
    throw std::invalid_argument("AsymmetrySurface: interior_density must be a finite number >= 0 (0: no limit), got " +
                                std::to_string(interior_density));
}

template <int D>
void BasicAsymmetrySurface<D>::before_source(StepContext& c) {
  const BasicParticles<D>& p = c.particles;
  const Kernel& k = c.sim.surface_kernel();
  fluid_.resize(p.size());
  for (std::size_t i = 0; i < p.size(); ++i) fluid_[i] = p.kind[i] == Kind::fluid ? 1 : 0;
  neighbour_asymmetry<D>({p, c.sim.domain(), c.sim.neighbors_at_star(k), k}, asymmetry_, fluid_);
  const double limit = fraction_ * asymmetry_of_flat_surface(k, c.sim.config().l0);
  const std::vector<double>& n = c.fields.n_at_surface_radius();
  const double n_interior = interior_density_ > 0.0 ? interior_density_ * k.n0 : HUGE_VAL;
  std::vector<char>& surface = c.fields.surface;
  for (std::size_t i = 0; i < p.size(); ++i)
    if (p.kind[i] == Kind::fluid && asymmetry_[i] > limit && n[i] < n_interior) surface[i] = 1;
}

template <int D>
void BasicWetWalls<D>::before_source(StepContext& c) {
  const BasicParticles<D>& p = c.particles;
  const NeighborList& near = c.sim.neighbors_at_star(c.sim.surface_kernel());
  std::vector<char>& surface = c.fields.surface;
  // Decided from the flags as the density test left them, so a wall made wet wets no other.
  wet_.assign(p.size(), 0);
  for (std::size_t i = 0; i < p.size(); ++i) {
    if (p.kind[i] != Kind::wall || !surface[i]) continue;
    const auto list = near.of(i);
    wet_[i] = std::any_of(list.begin(), list.end(), [&](int j) {
      const auto jj = static_cast<std::size_t>(j);
      return p.kind[jj] == Kind::fluid && !surface[jj];
    });
  }
  for (std::size_t i = 0; i < p.size(); ++i)
    if (wet_[i]) surface[i] = 0;
}

template <int D>
void BasicParticleCollision<D>::after_predictor(StepContext& c) {
  BasicParticles<D>& p = c.particles;
  const BasicStepFields<D>& f = c.fields;
  movable_.assign(p.size(), 0);
  for (std::size_t i = 0; i < p.size(); ++i) movable_[i] = !f.prescribed[i];
  collision_velocity_changes<D>(p, c.sim.domain(), c.sim.neighbors_now(), distance_ * c.sim.config().l0, restitution_,
                                movable_, change_);
  const auto pos = p.positions();
  const auto vel = p.velocities();
  for (std::size_t i = 0; i < p.size(); ++i)
    if (p.kind[i] == Kind::fluid && movable_[i]) {
      Vec<D> r;
      for (std::size_t a = 0; a < D; ++a) {
        (*vel[a])[i] += change_[a][i];
        r[a] = (*pos[a])[i] + f.dt * change_[a][i];  // the predictor having moved it by dt u*
      }
      c.sim.domain().wrap(r);
      for (std::size_t a = 0; a < D; ++a) (*pos[a])[i] = r[a];
    }
}

template <int D>
void BasicRemoveEscaped<D>::after_corrector(StepContext& c) {
  BasicParticles<D>& p = c.particles;
  const auto vel = p.velocities();
  for (std::size_t i = 0; i < p.size(); ++i)
    if (p.kind[i] == Kind::fluid && !inside_(p.position(i))) {
      p.kind[i] = Kind::ghost;
      for (std::size_t a = 0; a < D; ++a) (*vel[a])[i] = 0.0;
      p.p[i] = 0.0;
      ++removed_;
    }
}

template <int D>
BasicWallBackstop<D>::BasicWallBackstop(AxisBox tank, std::vector<AxisBox> obstacles, double slack)
    : tank_(tank), obstacles_(std::move(obstacles)), slack_(slack) {
  if (!(slack >= 0.0 && std::isfinite(slack)))
    throw std::invalid_argument("WallBackstop: the slack must be finite and at least 0 m, got " +
                                std::to_string(slack));
}

template <int D>
void BasicWallBackstop<D>::after_corrector(StepContext& c) {
  BasicParticles<D>& p = c.particles;
  const auto r = p.positions();
  const auto vel = p.velocities();
  constexpr std::size_t up = D - 1;
  for (std::size_t i = 0; i < p.size(); ++i) {
    if (p.kind[i] != Kind::fluid) continue;
    bool moved = false;
    // Onto face `a` of a solid lying on the side `sign` (-1 below, +1 above): no velocity into it remains.
    auto put_on = [&](std::size_t a, double face, double sign) {
      (*r[a])[i] = face;
      double& u = (*vel[a])[i];
      u = sign < 0 ? std::max(u, 0.0) : std::min(u, 0.0);
      moved = true;
    };
    if ((*r[up])[i] < tank_.hi[up])
      for (std::size_t a = 0; a < D; ++a) {
        if ((*r[a])[i] < tank_.lo[a] - slack_) put_on(a, tank_.lo[a], -1.0);
        if (a != up && (*r[a])[i] > tank_.hi[a] + slack_) put_on(a, tank_.hi[a], 1.0);
      }
    for (const AxisBox& b : obstacles_) {
      // Out through the nearest face; not through the bottom of an obstacle standing on the tank's floor (fluid put
      // on the floor below it would stay inside).
      const bool on_floor = b.lo[up] <= tank_.lo[up];
      double depth = std::numeric_limits<double>::infinity();
      std::size_t axis = 0;
      bool upper = false, inside = true;
      for (std::size_t a = 0; a < D && inside; ++a) {
        const double x = (*r[a])[i], below = x - b.lo[a], above = b.hi[a] - x;
        // On a face is outside, but on the floor under an obstacle standing on it is inside.
        inside = (below > slack_ || (below >= 0.0 && a == up && on_floor)) && above > slack_;
        if (below < depth && !(a == up && on_floor)) depth = below, axis = a, upper = false;
        if (above < depth) depth = above, axis = a, upper = true;
      }
      if (inside) put_on(axis, upper ? b.hi[axis] : b.lo[axis], upper ? -1.0 : 1.0);
    }
    returned_ += moved;
  }
}

template <int D>
void BasicHydrostaticSplit<D>::before_predictor(StepContext& c) {
  c.fields.balanced = force_;
}

// The unknown is P' = P - P_h. Walls stay zero-flux for P', i.e. dP/dn = rho f . n for P.
template <int D>
void BasicHydrostaticSplit<D>::before_assembly(StepContext& c) {
  const BasicParticles<D>& p = c.particles;
  const SimulationConfig& config = c.sim.config();
  BasicStepFields<D>& f = c.fields;
  f.pressure_offset.resize(p.size());
  f.held_value.resize(p.size());
  const double surface_pressure = 0.5 * config.l0 * config.rho * norm<D>(force_);
  for (std::size_t i = 0; i < p.size(); ++i) {
    f.pressure_offset[i] = config.rho * dot<D>(force_, p.position(i));
    f.held_value[i] = surface_pressure - f.pressure_offset[i];
  }
  // The minimum reference balances only where the kernel is full: at a cut-off surface kernel it pushed particles
  // up and into the wall at the contact lines (docs/numerics.md).
  f.surface_own_reference = true;
}

template <int D>
BasicInitialReferenceDensity<D>::BasicInitialReferenceDensity(const BasicParticles<D>& initial,
                                                              const BasicDomain<D>& domain, BasicCellGrid<D>& grid,
                                                              const Kernel& density) {
  grid.bin(initial);
  const NeighborList near = grid.neighbors(initial, density.re);
  const std::vector<double> n = mps::number_density<D>({initial, domain, near, density});
  double fluid_sum = 0.0;
  int max_id = 0;
  for (std::size_t i = 0; i < initial.size(); ++i) {
    if (initial.kind[i] == Kind::fluid) fluid_sum += n[i];
    max_id = std::max(max_id, initial.id[i]);
  }
  // Fluid particles travel, so they share one reference; ghosts that become fluid take it too.
  reference_.assign(static_cast<std::size_t>(max_id) + 1, fluid_sum / static_cast<double>(initial.count(Kind::fluid)));
  for (std::size_t i = 0; i < initial.size(); ++i)
    if (initial.kind[i] == Kind::wall || initial.kind[i] == Kind::dummy)
      reference_[static_cast<std::size_t>(initial.id[i])] = n[i];
}

// Scaled so that the source's (n - n0)/n0 reads (n* - n_ref)/n_ref.
template <int D>
void BasicInitialReferenceDensity<D>::before_source(StepContext& c) {
  const BasicParticles<D>& p = c.particles;
  BasicStepFields<D>& f = c.fields;
  const double n0 = c.sim.density_kernel().n0;
  f.n_source = f.n_star;
  for (std::size_t i = 0; i < p.size(); ++i) {
    const auto id = static_cast<std::size_t>(p.id[i]);
    if (id < reference_.size()) f.n_source[i] *= n0 / reference_[id];
  }
}

template <int D>
void BasicParticleShifting<D>::shift_positions(StepContext& c) {
  BasicParticles<D>& p = c.particles;
  const BasicStepFields<D>& f = c.fields;
  const Kernel& k = c.sim.gradient_kernel();
  const NeighborList& close = c.sim.neighbors_at_star(k);
  const auto n = static_cast<std::ptrdiff_t>(p.size());
  movable_.assign(p.size(), 0);
  near_surface_.assign(p.size(), 0);
#pragma omp parallel for schedule(static) if (detail::worth_threads(n))
  for (std::ptrdiff_t ii = 0; ii < n; ++ii) {
    const auto i = static_cast<std::size_t>(ii);
    if (p.kind[i] != Kind::fluid || f.prescribed[i]) continue;
    const auto near = close.of(i);
    near_surface_[i] = f.surface[i] || std::any_of(near.begin(), near.end(), [&](int j) {
                         return f.surface[static_cast<std::size_t>(j)] != 0;
                       });
    movable_[i] = along_surface_ || !near_surface_[i];
  }
  const double l0 = c.sim.config().l0;
  const double diffusion = coefficient_ * l0 * std::sqrt(c.sim.max_over_ranks(max_fluid_speed_squared(p))) * f.dt;
  const BasicStencil<D> stencil{p, c.sim.domain(), close, k};
  if (!along_surface_) {
    shift_particles<D>(stencil, diffusion, 0.2 * l0, movable_, p);
    return;
  }
  // The normal from the wider density kernel follows the surface; at the shift's own radius it would point along
  // the shift itself and leave nothing to move.
  const Kernel& wide = c.sim.density_kernel();
  surface_normals<D>({p, c.sim.domain(), c.sim.neighbors_at_star(wide), wide}, near_surface_, normal_);
  ConstComponents<D> normal;
  for (std::size_t a = 0; a < D; ++a) normal[a] = normal_[a];
  shift_particles<D>(stencil, diffusion, 0.2 * l0, movable_, p, normal);
}

template <int D>
bool BasicContinuousFreeSurface<D>::runs_after(const BasicStepComponent<D>& other) const {
  return dynamic_cast<const BasicHydrostaticSplit<D>*>(&other) != nullptr;
}

template <int D>
void BasicContinuousFreeSurface<D>::before_assembly(StepContext& c) {
  const BasicParticles<D>& p = c.particles;
  BasicStepFields<D>& f = c.fields;
  const Kernel& k = c.sim.pressure_kernel();
  const NeighborList& list = c.sim.neighbors_at_star(k);
  const BasicDomain<D>& domain = c.sim.domain();
  const double full = k.laplacian_weight_sum();
  const double rho = c.sim.config().rho;
  if (f.held.empty()) f.held = f.surface;
  const auto n = static_cast<std::ptrdiff_t>(p.size());
  for (std::size_t i = 0; i < p.size(); ++i)
    if (p.kind[i] == Kind::fluid && f.surface[i]) f.held[i] = 0;
  f.open_weight.assign(p.size(), 0.0);
  f.open_value.assign(p.size(), 0.0);
  // Its own pressure as the gradient's reference pinned a surface particle whose pressure is now solved: a zigzag grew
  // along the surface row (docs/pressure.md).
  f.surface_own_reference = false;
  if (cut_weight_.empty()) (void)surface_distance(k, 0.0, cut_weight_);  // filled before the threads read it
#pragma omp parallel for schedule(static) if (detail::worth_threads(n))
  for (std::ptrdiff_t ii = 0; ii < n; ++ii) {
    const auto i = static_cast<std::size_t>(ii);
    if (!(p.kind[i] == Kind::fluid || (p.kind[i] == Kind::wall && !f.held[i]))) continue;
    const Vec<D> ri = p.position(i);
    double present = 0.0;
    Vec<D> moment{};
    // The nearest free-surface particle (the particle itself if it is one): the surface lies half a spacing beyond it.
    std::size_t nearest = p.kind[i] == Kind::fluid && f.surface[i] ? i : p.size();
    double nearest_r2 = 0.0;
    for (int jj : list.of(i)) {
      const auto j = static_cast<std::size_t>(jj);
      if (p.kind[j] == Kind::ghost) continue;
      const Vec<D> r = domain.displacement(ri, p.position(j));
      const double r2 = norm2<D>(r);
      if (nearest != i && p.kind[j] == Kind::fluid && f.surface[j] &&
          (nearest == p.size() || r2 < nearest_r2 || (r2 == nearest_r2 && p.id[j] < p.id[nearest]))) {
        nearest = j;
        nearest_r2 = r2;
      }
      const double w = k.laplacian_weight(std::sqrt(r2));
      if (w <= 0.0) continue;
      present += w;
      for (std::size_t a = 0; a < D; ++a) moment[a] += w * r[a];
    }
    const double empty = full - present;
    if (empty <= 0.0) continue;
    // The lattice's first moment vanishes, so the empty part's centroid is minus the present part's over its weight.
    Vec<D> centroid;
    for (std::size_t a = 0; a < D; ++a) centroid[a] = -moment[a] / empty;
    // With no surface particle in reach, the surface lies where a flat cut of the lattice leaves as much empty.
    const bool near = nearest < p.size();
    const double ghost = norm<D>(centroid);
    const double s = near ? std::sqrt(nearest_r2) + 0.5 * k.l0
                          : std::max(surface_distance(k, empty, cut_weight_), 0.1 * k.l0);
    // P linear from the particle through the surface's value s away to the ghost |c| away: the pair's
    // w (P_i - P_ghost) is w (|c|/s) (P_i - P_surface) (Gibou et al. 2002).
    f.open_weight[i] = empty * std::max(1.0, ghost / s);
    if (near) {
      if (!f.held_value.empty()) f.open_value[i] = f.held_value[nearest];
    } else if (!f.pressure_offset.empty() && ghost > 0.0) {  // P = 0 less the offset at the surface point
      Vec<D> at_surface;
      for (std::size_t a = 0; a < D; ++a) at_surface[a] = centroid[a] * (s / ghost);
      f.open_value[i] = -(f.pressure_offset[i] + rho * dot<D>(f.balanced, at_surface));
    }
  }
}

template <int D>
double BasicContinuousFreeSurface<D>::surface_distance(const Kernel& k, double empty, std::vector<double>& table) {
  const int reach = static_cast<int>(std::ceil(k.re / k.l0));
  if (table.empty()) {  // table[m]: the weight of the lattice points at least m - reach + 1 rows above the particle
    table.assign(static_cast<std::size_t>(2 * reach + 1), 0.0);
    const int nz = D == 3 ? reach : 0;
    for (int c = -nz; c <= nz; ++c)
      for (int j = -reach; j <= reach; ++j)
        for (int i = -reach; i <= reach; ++i) {
          if (i == 0 && j == 0 && c == 0) continue;
          const double w = k.laplacian_weight(k.l0 * std::sqrt(double(i) * i + double(j) * j + double(c) * c));
          for (int m = 0; m <= 2 * reach; ++m)
            if (j >= m - reach + 1) table[static_cast<std::size_t>(m)] += w;
        }
  }
  // table[m] belongs to a cut at (m - reach + 1/2) l0 and falls with m; between cuts the distance is interpolated.
  if (empty >= table.front()) return (0.5 - reach) * k.l0;
  for (std::size_t m = 1; m < table.size(); ++m)
    if (empty >= table[m]) {
      const double t = (table[m - 1] - empty) / (table[m - 1] - table[m]);
      return (static_cast<double>(m) - 1.0 + t - reach + 0.5) * k.l0;
    }
  return (reach + 0.5) * k.l0;
}

template class BasicOpenOutlet<2>;
template class BasicOpenOutlet<3>;
template class BasicMirrorNoSlip<2>;
template class BasicMirrorNoSlip<3>;
template class BasicMirrorPlaneNoSlip<2>;
template class BasicMirrorPlaneNoSlip<3>;
template class BasicSurfaceRegion<2>;
template class BasicSurfaceRegion<3>;
template class BasicAsymmetrySurface<2>;
template class BasicAsymmetrySurface<3>;
template class BasicWetWalls<2>;
template class BasicWetWalls<3>;
template class BasicParticleCollision<2>;
template class BasicParticleCollision<3>;
template class BasicRemoveEscaped<2>;
template class BasicRemoveEscaped<3>;
template class BasicWallBackstop<2>;
template class BasicWallBackstop<3>;
template class BasicHydrostaticSplit<2>;
template class BasicHydrostaticSplit<3>;
template class BasicInitialReferenceDensity<2>;
template class BasicInitialReferenceDensity<3>;
template class BasicParticleShifting<2>;
template class BasicParticleShifting<3>;
template class BasicContinuousFreeSurface<2>;
template class BasicContinuousFreeSurface<3>;

}  // namespace mps
