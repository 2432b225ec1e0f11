#include "mps/step.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <sstream>

namespace mps {
namespace {

using Clock = std::chrono::steady_clock;
using Index = std::ptrdiff_t;

double lap(Clock::time_point& t) {
  const auto now = Clock::now();
  const double s = std::chrono::duration<double>(now - t).count();
  t = now;
  return s;
}

void require(bool ok, const std::string& message) {
  if (!ok) throw std::invalid_argument("simulation config: " + message);
}

std::string fmt(double v) {
  std::ostringstream s;
  s << v;
  return s.str();
}

}  // namespace

void SimulationConfig::validate() const {
  auto positive = [](double v) { return v > 0.0 && std::isfinite(v); };
  require(positive(l0), "particle spacing l0 must be positive, got " + fmt(l0));
  require(positive(radius_density) && radius_density > 1.0, "radius_density must exceed 1 (in l0), got " + fmt(radius_density));
  require(positive(radius_surface) && radius_surface > 1.0, "radius_surface must exceed 1 (in l0), got " + fmt(radius_surface));
  require(positive(radius_gradient) && radius_gradient > 1.0, "radius_gradient must exceed 1 (in l0), got " + fmt(radius_gradient));
  require(positive(radius_laplacian) && radius_laplacian > 1.0, "radius_laplacian must exceed 1 (in l0), got " + fmt(radius_laplacian));
  require(positive(rho), "density rho must be positive, got " + fmt(rho));
  require(nu >= 0.0 && std::isfinite(nu), "viscosity nu must be >= 0, got " + fmt(nu));
  require(std::isfinite(fx) && std::isfinite(fy), "body force must be finite");
  require(gamma >= 0.0 && gamma <= 1.0, "gamma must be in [0, 1], got " + fmt(gamma));
  require(beta > 0.0 && beta < 1.0, "beta must be in (0, 1), got " + fmt(beta));
  require(theta >= 0.0 && theta <= 1.0, "theta must be in [0, 1], got " + fmt(theta));
  require(positive(dt_max), "time step dt_max must be positive, got " + fmt(dt_max));
  require(positive(cfl), "cfl must be positive, got " + fmt(cfl));
  require(positive(viscous_number), "viscous_number must be positive, got " + fmt(viscous_number));
  require(shifting >= 0.0 && std::isfinite(shifting), "shifting must be >= 0 (0: off), got " + fmt(shifting));
  require(reorder_every >= 0, "reorder_every must be >= 0");
  require(positive(max_displacement), "max_displacement must be positive (in l0)");
  require(max_speed > 0.0, "max_speed must be positive");
  require(sound_speed >= 0.0 && std::isfinite(sound_speed),
          "sound_speed must be >= 0 (0: incompressible), got " + fmt(sound_speed));
}

Simulation::Simulation(Particles particles, Domain domain, SimulationConfig config)
    : Simulation(std::move(particles), domain, config, make_solver(config.solver)) {}

Simulation::Simulation(Particles particles, Domain domain, SimulationConfig config,
                       std::unique_ptr<LinearSolver> solver)
    : particles_(std::move(particles)),
      domain_(domain),
      config_(std::move(config)),
      solver_(std::move(solver)),
      k_density_(make_kernel(config_.radius_density, config_.l0, config_.weight)),
      k_surface_(make_kernel(config_.radius_surface, config_.l0, config_.weight)),
      k_gradient_(make_kernel(config_.radius_gradient, config_.l0, config_.weight)),
      k_laplacian_(make_kernel(config_.radius_laplacian, config_.l0, config_.weight)),
      grid_(domain_, config_.l0 * std::max({config_.radius_density, config_.radius_surface, config_.radius_gradient,
                                            config_.radius_laplacian})) {
  config_.validate();
  if (!solver_) throw std::invalid_argument("simulation: no linear solver given");
  if (config_.implicit_viscosity) viscosity_solver_ = make_solver(config_.viscosity_solver);
  if (particles_.count(Kind::fluid) == 0) throw std::invalid_argument("simulation: the domain holds no fluid particles");
  for (std::size_t i = 0; i < particles_.size(); ++i)
    if (particles_.kind[i] != Kind::ghost && !domain_.contains(particles_.x[i], particles_.y[i]))
      throw std::invalid_argument("simulation: particle " + std::to_string(i) + " at (" + fmt(particles_.x[i]) + ", " +
                                  fmt(particles_.y[i]) + ") starts outside the domain");
  if (config_.initial_reference_density) {
    grid_.bin(particles_);
    const NeighborList near = grid_.neighbors(particles_, k_density_.re);
    const std::vector<double> n = mps::number_density({particles_, domain_, near, k_density_});
    double fluid_sum = 0.0;
    int max_id = 0;
    for (std::size_t i = 0; i < particles_.size(); ++i) {
      if (particles_.kind[i] == Kind::fluid) fluid_sum += n[i];
      max_id = std::max(max_id, particles_.id[i]);
    }
    // Fluid particles travel, so they share one reference; ghosts that become fluid take it too.
    n_reference_.assign(static_cast<std::size_t>(max_id) + 1,
                        fluid_sum / static_cast<double>(particles_.count(Kind::fluid)));
    for (std::size_t i = 0; i < particles_.size(); ++i)
      if (particles_.kind[i] == Kind::wall || particles_.kind[i] == Kind::dummy)
        n_reference_[static_cast<std::size_t>(particles_.id[i])] = n[i];
  }
}

void Simulation::add_mirror_wall(const MirrorWall& wall) {
  wall.validate();
  mirror_walls_.push_back(wall);
}

void Simulation::set_outflow_buffer(const OutflowBuffer& buffer) {
  buffer.validate();
  outflow_ = buffer;
}

// The boundary velocities are lagged by a step. For the mode a wall's mirror values feed back on (u beside
// the wall, its mirror -u) that gives the factor (1 - a)/(1 + a), a > 0: stable for any dt.
void Simulation::implicit_viscous_predictor(const Stencil& s, double dt, double fx, double fy) {
  Particles& p = particles_;
  const CsrMatrix lap = laplacian_matrix(s);
  std::vector<int> row(p.size(), -1);
  std::vector<std::size_t> fluid;
  for (std::size_t i = 0; i < p.size(); ++i)
    if (p.kind[i] == Kind::fluid && !in_buffer_[i]) {
      row[i] = static_cast<int>(fluid.size());
      fluid.push_back(i);
    }
  const double a = dt * config_.nu;
  CsrMatrix m;
  m.rows = m.cols = static_cast<int>(fluid.size());
  m.row_ptr.assign(fluid.size() + 1, 0);
  m.col.reserve(lap.nnz());
  m.val.reserve(lap.nnz());
  std::vector<double> bu(fluid.size()), bv(fluid.size()), u(fluid.size()), v(fluid.size());
  for (std::size_t r = 0; r < fluid.size(); ++r) {
    const std::size_t i = fluid[r];
    bu[r] = p.u[i] + dt * fx;
    bv[r] = p.v[i] + dt * fy;
    u[r] = p.u[i];
    v[r] = p.v[i];
    for (auto k = static_cast<std::size_t>(lap.row_ptr[i]); k < static_cast<std::size_t>(lap.row_ptr[i + 1]); ++k) {
      const auto j = static_cast<std::size_t>(lap.col[k]);
      if (row[j] >= 0) {
        m.col.push_back(row[j]);
        m.val.push_back((j == i ? 1.0 : 0.0) - a * lap.val[k]);
      } else {
        bu[r] += a * lap.val[k] * p.u[j];
        bv[r] += a * lap.val[k] * p.v[j];
      }
    }
    m.row_ptr[r + 1] = static_cast<int>(m.col.size());
  }
  try {
    info_.viscosity_iterations = viscosity_solver_->solve(m, bu, u).iterations;
    info_.viscosity_iterations += viscosity_solver_->solve(m, bv, v).iterations;
  } catch (const SolverError& e) {
    throw SimulationError("step " + std::to_string(info_.step + 1) + " (t = " + fmt(info_.time) +
                          " s): implicit viscosity solve failed: " + e.what());
  }
  for (std::size_t r = 0; r < fluid.size(); ++r) {
    const std::size_t i = fluid[r];
    p.u[i] = u[r];
    p.v[i] = v[r];
    p.x[i] += dt * u[r];
    p.y[i] += dt * v[r];
    domain_.wrap(p.x[i], p.y[i]);
  }
  for (std::size_t i = 0; i < p.size(); ++i)
    if (p.kind[i] == Kind::fluid && in_buffer_[i]) {
      p.x[i] += dt * p.u[i];
      p.y[i] += dt * p.v[i];
      domain_.wrap(p.x[i], p.y[i]);
    }
}

void Simulation::apply_mirror_walls() {
  for (const MirrorWall& wall : mirror_walls_)
    apply_mirror_velocity(wall, grid_, k_gradient_.re, particles_);
}

double Simulation::choose_dt(std::string& limit) const {
  double umax2 = 0.0;
  for (std::size_t i = 0; i < particles_.size(); ++i)
    if (particles_.kind[i] == Kind::fluid)
      umax2 = std::max(umax2, particles_.u[i] * particles_.u[i] + particles_.v[i] * particles_.v[i]);
  double dt = config_.dt_max;
  limit = "dt_max";
  const double umax = std::sqrt(umax2);
  if (umax > 0.0 && config_.cfl * config_.l0 / umax < dt) {
    dt = config_.cfl * config_.l0 / umax;
    limit = "cfl";
  }
  if (!config_.implicit_viscosity && config_.nu > 0.0 &&
      config_.viscous_number * config_.l0 * config_.l0 / config_.nu < dt) {
    dt = config_.viscous_number * config_.l0 * config_.l0 / config_.nu;
    limit = "viscous";
  }
  return dt;
}

const StepInfo& Simulation::step() {
  before_step_ = particles_;
  const StepInfo info_before = info_;
  try {
    advance();
    check_guard();
  } catch (const SolverError& e) {
    particles_ = before_step_;
    info_ = info_before;
    throw SimulationError("step " + std::to_string(info_before.step + 1) + " (t = " + fmt(info_before.time) +
                          " s): pressure solve failed: " + e.what());
  } catch (const SimulationError&) {
    particles_ = before_step_;
    info_ = info_before;
    throw;
  }
  return info_;
}

void Simulation::advance() {
  Particles& p = particles_;
  const auto n = static_cast<Index>(p.size());
  // The body force's hydrostatic part (its components along non-periodic axes; see hydrostatic_split):
  // balanced by P_h = rho f_h . r exactly, it is left out of the predictor and of the pressure solved for.
  const bool split = config_.hydrostatic_split && config_.min_reference_tilt;
  const double fhx = split && !domain_.periodic_x ? config_.fx : 0.0;
  const double fhy = split && !domain_.periodic_y ? config_.fy : 0.0;
  auto t = Clock::now();
  const double dt = choose_dt(info_.dt_limit);
  info_.dt = dt;

  if (config_.reorder_every > 0 && info_.step % config_.reorder_every == 0) {
    grid_.bin(p);
    p.permute(grid_.cell_order());
  }
  grid_.bin(p);
  grid_.neighbors(p, k_laplacian_.re, near_now_);  // viscosity only
  in_buffer_.assign(p.size(), 0);
  if (outflow_) {
    for (std::size_t i = 0; i < p.size(); ++i)
      in_buffer_[i] = p.kind[i] != Kind::ghost && outflow_->contains(p.x[i], p.y[i]);
    apply_outflow_velocity(*outflow_, grid_, k_gradient_.re, in_buffer_, p);
  }
  apply_mirror_walls();
  const NeighborList& near_now = near_now_;
  times_.neighbors += lap(t);

  // Predictor: viscosity and body force; walls and dummies carry their (prescribed or mirrored) velocity
  // into the viscous sum, which is the no-slip condition.
  if (config_.implicit_viscosity) {
    implicit_viscous_predictor({p, domain_, near_now, k_laplacian_}, dt, config_.fx - fhx, config_.fy - fhy);
  } else {
    const Stencil s{p, domain_, near_now, k_laplacian_};
    std::vector<double> lu(p.size()), lv(p.size());
    laplacian(s, p.u, p.v, lu, lv);
#pragma omp parallel for schedule(static)
    for (Index ii = 0; ii < n; ++ii) {
      const auto i = static_cast<std::size_t>(ii);
      if (p.kind[i] != Kind::fluid) continue;
      if (!in_buffer_[i]) {
        p.u[i] += dt * (config_.nu * lu[i] + config_.fx - fhx);
        p.v[i] += dt * (config_.nu * lv[i] + config_.fy - fhy);
      }
      p.x[i] += dt * p.u[i];
      p.y[i] += dt * p.v[i];
      domain_.wrap(p.x[i], p.y[i]);
    }
  }
  if (motion_) {
    motion_(p, info_.time + dt);
    // The motion may recycle particles: a pushing plate turns buffer fluid that crossed the outlet into a ghost
    // and, in the same call, into a fresh inlet particle. Left flagged, that particle was held at P = 0 beside the
    // plate for its first step and sucked its neighbours in (the Re = 4 inlet channel's guard stops).
    if (outflow_)
      for (std::size_t i = 0; i < p.size(); ++i)
        if (in_buffer_[i] && (p.kind[i] == Kind::ghost || !outflow_->contains(p.x[i], p.y[i]))) in_buffer_[i] = 0;
  }
  times_.predict += lap(t);

  // Two lists serve every kernel: one at the largest radius, one at the largest of the small ones.
  grid_.bin(p);
  // The projection sees a mirror wall at its own velocity: mirrored values there would put the fluid's
  // streamwise changes into div u* wherever the flow develops or the wall changes speed, and an inlet channel
  // was driven into a growing period-2 pressure oscillation from its outlet and conveyor ends.
  for (const MirrorWall& wall : mirror_walls_)
    for (std::size_t i = 0; i < p.size(); ++i)
      if ((p.kind[i] == Kind::wall || p.kind[i] == Kind::dummy) && p.group[i] == wall.group) {
        const auto U = wall.velocity_at(p.x[i], p.y[i]);
        p.u[i] = U[0];
        p.v[i] = U[1];
      }
  const Kernel* kernels[] = {&k_density_, &k_surface_, &k_gradient_, &k_laplacian_};
  double small_radius = 0.0;
  for (const Kernel* k : kernels)
    if (k->re < grid_.cell_size() * (1.0 - 1e-12)) small_radius = std::max(small_radius, k->re);
  if (small_radius > 0.0) grid_.neighbors(p, grid_.cell_size(), near_star_, small_radius, close_star_);
  else grid_.neighbors(p, grid_.cell_size(), near_star_);
  const NeighborList& near_star = near_star_;
  const NeighborList& close_star = close_star_;
  const auto list_for = [&](const Kernel& k) -> const NeighborList& {
    return k.re <= small_radius ? close_star : near_star;
  };
  times_.neighbors += lap(t);

  const Stencil grad{p, domain_, list_for(k_gradient_), k_gradient_};
  const Stencil lapl{p, domain_, list_for(k_laplacian_), k_laplacian_};
  n_star_ = mps::number_density({p, domain_, list_for(k_density_), k_density_});
  const std::vector<double> n_surface = k_surface_.re == k_density_.re
                                            ? n_star_
                                            : mps::number_density({p, domain_, list_for(k_surface_), k_surface_});
  std::vector<double> div(p.size());
  divergence(grad, p.u, p.v, div);
  std::vector<char> surface = detect_free_surface(p, n_surface, k_surface_.n0, config_.beta, &list_for(k_surface_),
                                                  k_surface_.lattice_neighbors, config_.theta);
  if (surface_region_)
    for (std::size_t i = 0; i < surface.size(); ++i)
      if (surface[i] && !surface_region_(p.x[i], p.y[i])) surface[i] = 0;
  std::vector<double> n_against_reference;  // only with initial_reference_density
  if (!n_reference_.empty()) {
    n_against_reference = n_star_;  // scaled so that mixed_source's (n - n0)/n0 reads (n* - n_ref)/n_ref
    for (std::size_t i = 0; i < p.size(); ++i) {
      const auto id = static_cast<std::size_t>(p.id[i]);
      if (id < n_reference_.size()) n_against_reference[i] *= k_density_.n0 / n_reference_[id];
    }
  }
  std::vector<double> source = mixed_source(n_reference_.empty() ? n_star_ : n_against_reference, k_density_.n0, div,
                                            config_.rho, dt, config_.gamma);
  if (std::find(surface.begin(), surface.end(), 1) != surface.end()) {
    // Where the source kernel reaches a free-surface particle its number density deficit is geometry, not
    // expansion: read as such it asks for suction that grows as 1/dt^2. There the divergence term alone
    // (gamma = 0) drives the PPE. (Without a surface the scan over every pair is skipped.)
    const NeighborList& reach = list_for(k_density_);
#pragma omp parallel for schedule(static)
    for (Index ii = 0; ii < n; ++ii) {
      const auto i = static_cast<std::size_t>(ii);
      for (int j : reach.of(i)) {
        const auto jj = static_cast<std::size_t>(j);
        if (!surface[jj]) continue;
        const auto d = domain_.displacement(p.x[i], p.y[i], p.x[jj], p.y[jj]);
        if (d[0] * d[0] + d[1] * d[1] < k_density_.re * k_density_.re) {
          source[i] = config_.rho / dt * div[i];
          break;
        }
      }
    }
  }
  // With the hydrostatic part split off, the unknown is P' = P - P_h. A free-surface particle holds P' = -P_h
  // + rho |f_h| l0/2: the surface itself (P = 0) lies half a spacing above the surface particle's centre, the
  // top of the volume it stands for, and a liquid at rest has its surface normal to f_h. Walls stay zero-flux
  // for P', which is the wall condition dP/dn = rho f_h . n for P.
  std::vector<double> hydro, dirichlet;
  if (fhx != 0.0 || fhy != 0.0) {
    hydro.resize(p.size());
    dirichlet.resize(p.size());
    const double surface_pressure = 0.5 * config_.l0 * config_.rho * std::hypot(fhx, fhy);
    for (std::size_t i = 0; i < p.size(); ++i) {
      hydro[i] = config_.rho * (fhx * p.x[i] + fhy * p.y[i]);
      dirichlet[i] = surface_pressure - hydro[i];
    }
  }
  // The outflow buffer is held at P = 0 like a free surface, but it is no surface: the fluid beside it has full
  // kernels, and its number density stays in the source (above).
  std::vector<char> held;
  if (outflow_) {
    held = surface;
    for (std::size_t i = 0; i < p.size(); ++i)
      if (in_buffer_[i]) {
        held[i] = 1;
        if (!dirichlet.empty()) dirichlet[i] = -hydro[i];
      }
  }
  const double screening = config_.sound_speed * dt;  // the compressibility's reach
  assemble_ppe(lapl, outflow_ ? held : surface, source, ppe_, dirichlet,
               screening > 0.0 ? 1.0 / (screening * screening) : 0.0);
  info_.unknowns = ppe_.size();
  info_.free_surface = static_cast<std::size_t>(std::count(surface.begin(), surface.end(), 1));
  info_.floating_groups = ppe_.floating.size();
  times_.assemble += lap(t);

  // Warm start from the previous step, or the zero guess of a cold start.
  std::vector<double> pressure = config_.warm_start ? ppe_.gather(p, hydro) : std::vector<double>(ppe_.size(), 0.0);
  // A zero right-hand side (a liquid at rest on the lattice once the hydrostatic part is split off) has the
  // solution 0, which iterative solvers measuring a residual relative to |b| cannot confirm.
  const bool zero_rhs = std::all_of(ppe_.rhs.begin(), ppe_.rhs.end(), [](double b) { return b == 0.0; });
  // Before any pressure has been set (all P = 0) there is nothing to warm-start from, and with the split P = 0
  // would read as P' = -P_h: from that guess a liquid at rest, whose |b| is at round-off, cannot reach a
  // tolerance relative to |b|.
  const bool no_previous = std::all_of(ppe_.particle.begin(), ppe_.particle.end(),
                                       [&](int i) { return p.p[static_cast<std::size_t>(i)] == 0.0; });
  if (no_previous) std::fill(pressure.begin(), pressure.end(), 0.0);
  if (ppe_.size() > 0 && zero_rhs) {
    std::fill(pressure.begin(), pressure.end(), 0.0);
    info_.solve = SolveReport{};
  } else if (ppe_.size() > 0) {
    info_.solve = solver_->solve(ppe_.matrix, ppe_.rhs, pressure);
  }
  times_.solver_setup += info_.solve.setup_seconds;
  times_.solve += lap(t) - info_.solve.setup_seconds;

  ppe_.scatter(pressure, p, config_.clamp_negative_pressure, hydro);
  if (!dirichlet.empty())
    for (std::size_t i = 0; i < p.size(); ++i)
      if (p.kind[i] == Kind::fluid && surface[i]) p.p[i] = dirichlet[i] + hydro[i];  // its P, as held in the PPE
  std::vector<char> carriers = set_dummy_pressure(lapl, p, surface, config_.rho, config_.fx, config_.fy);
  for (std::size_t i = 0; i < p.size(); ++i)
    if (in_buffer_[i]) {
      p.p[i] = 0.0;
      carriers[i] = 1;
    }
  std::vector<double> gx(p.size()), gy(p.size());
  const double tilt = config_.min_reference_tilt ? config_.rho : 0.0;
  if (split) {
    // The corrector takes the gradient of P' (its minimum reference is the tilted one, of P - rho f_h . r): the
    // hydrostatic part's gradient rho f_h cancels f_h exactly, which the predictor therefore left out. Taken
    // through the particle sum instead, it would be M rho f_h, M = (d/n0) sum w r r^T/r^2, and wherever M != I
    // (a lattice distorted near a wall corner, a truncated kernel) gravity would push sideways: the closed tank's
    // mode growing ~15 /s (README, "Numerics and stability").
    std::vector<double> residual(p.p);
    for (std::size_t i = 0; i < p.size(); ++i) residual[i] -= config_.rho * (fhx * p.x[i] + fhy * p.y[i]);
    // A free-surface particle takes its own, imposed P' as the reference, not the minimum over its neighbours.
    // The minimum reference is a repulsion against clustering, (P'_j - P'_min) summed over the kernel, that balances
    // only where the kernel is full. A surface particle's kernel is cut off above by the surface and, at a contact
    // line, also on the wall side, the dry wall there carrying no pressure. Any dip of P' below the imposed surface
    // value within its reach (the PPE's answer to a small motion) then becomes a net push towards the missing
    // side: up and into the wall, which moves the particle further and deepens the dip. In the tank this mode grew
    // from solver round-off at ~12 /s (gamma 0.99) and ~10 /s (0.01) at both contact lines and broke the tank up
    // after 1.2-1.5 s. With its own value as reference the particle feels the pressure gradient itself: P' below it
    // under the surface value pulls it down, neighbours on the surface at the same value exert nothing.
    // Only where a hydrostatic part is split off: the channel apps' outlets are free surfaces too, and their
    // measured tables predate this; whether it helps there (the Re 400 outlet corners) is still to be measured.
    const bool hydrostatic = fhx != 0.0 || fhy != 0.0;
    gradient(grad, residual, gx, gy, config_.pressure_gradient, carriers,
             {tilt * (config_.fx - fhx), tilt * (config_.fy - fhy)}, hydrostatic ? std::span<const char>(surface)
                                                                                 : std::span<const char>());
  } else {
    gradient(grad, p.p, gx, gy, config_.pressure_gradient, carriers, {tilt * config_.fx, tilt * config_.fy});
  }
  for (std::size_t i = 0; i < p.size(); ++i) {
    if (p.kind[i] != Kind::fluid || in_buffer_[i]) continue;
    const double du = -dt / config_.rho * gx[i], dv = -dt / config_.rho * gy[i];
    p.u[i] += du;
    p.v[i] += dv;
    p.x[i] += dt * du;  // x^{n+1} = x^n + dt u^{n+1}, the predictor having moved it by dt u*
    p.y[i] += dt * dv;
    domain_.wrap(p.x[i], p.y[i]);
  }
  double umax2 = 0.0;
  for (std::size_t i = 0; i < p.size(); ++i)
    if (p.kind[i] == Kind::fluid) umax2 = std::max(umax2, p.u[i] * p.u[i] + p.v[i] * p.v[i]);
  if (config_.shifting > 0.0) {
    // A particle at or beside a free surface would be pushed out through it, towards the missing neighbours.
    const NeighborList& close = list_for(k_gradient_);
    std::vector<char> movable(p.size(), 0);
#pragma omp parallel for schedule(static)
    for (Index ii = 0; ii < n; ++ii) {
      const auto i = static_cast<std::size_t>(ii);
      if (p.kind[i] != Kind::fluid || in_buffer_[i] || surface[i]) continue;
      const auto near = close.of(i);
      movable[i] = std::none_of(near.begin(), near.end(), [&](int j) { return surface[static_cast<std::size_t>(j)] != 0; });
    }
    const double diffusion = config_.shifting * config_.l0 * std::sqrt(umax2) * dt;
    shift_particles(grad, diffusion, 0.2 * config_.l0, movable, p);
    umax2 = 0.0;
    for (std::size_t i = 0; i < p.size(); ++i)
      if (p.kind[i] == Kind::fluid) umax2 = std::max(umax2, p.u[i] * p.u[i] + p.v[i] * p.v[i]);
  }
  info_.max_speed = std::sqrt(umax2);
  info_.time += dt;
  ++info_.step;
  times_.correct += lap(t);
}

void Simulation::check_guard() const {
  const Particles& p = particles_;
  // The advice names the knob of the limit that set dt: lowering dt_max does nothing while cfl binds.
  const std::string advice = info_.dt_limit == "viscous" ? " (reduce viscous_number, the viscous limit set dt)"
                             : info_.dt_limit == "cfl"   ? " (reduce cfl, the CFL limit set dt)"
                                                         : " (reduce dt_max)";
  auto fail = [&](const std::string& what) {
    throw SimulationError("step " + std::to_string(info_.step) + " (t = " + fmt(info_.time) + " s, dt = " +
                          fmt(info_.dt) + " s, dt limit " + info_.dt_limit + "): " + what + advice);
  };
  // A fluid particle moves by exactly dt |u^{n+1}| in a step, so the displacement bound is a speed bound.
  const double max_move = config_.max_displacement * config_.l0;
  for (std::size_t i = 0; i < p.size(); ++i) {
    if (p.kind[i] == Kind::ghost) continue;
    const double speed = std::hypot(p.u[i], p.v[i]);
    if (!std::isfinite(p.x[i]) || !std::isfinite(p.y[i]) || !std::isfinite(speed) || !std::isfinite(p.p[i]))
      fail("particle " + std::to_string(i) + " has a non-finite position, velocity or pressure; the run blew up");
    if (!domain_.contains(p.x[i], p.y[i]))
      fail(std::string(to_string(p.kind[i])) + " particle " + std::to_string(i) + " left the domain at (" +
           fmt(p.x[i]) + ", " + fmt(p.y[i]) + "); the flow is unstable");
    if (speed > config_.max_speed)
      fail("particle " + std::to_string(i) + " moves at " + fmt(speed) + " m/s, above max_speed " +
           fmt(config_.max_speed) + " m/s");
    if (p.kind[i] == Kind::fluid && info_.dt * speed > max_move)
      fail("particle " + std::to_string(i) + " moved " + fmt(info_.dt * speed / config_.l0) +
           " l0 in one step, above the limit of " + fmt(config_.max_displacement) +
           " l0: velocity blow-up");
  }
}

}  // namespace mps
