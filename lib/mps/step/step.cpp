#include "mps/step/step.hpp"
#include "mps/core/state.hpp"
#include "mps/core/threads.hpp"
#include "mps/core/vec.hpp"

#include "mps/step/components.hpp"

#include <algorithm>
#include <exception>
#include <chrono>
#include <cstdlib>
#include <cxxabi.h>
#include <typeinfo>
#include <cmath>
#include <map>
#include <string_view>
#include <type_traits>
#include <sstream>
#include <utility>

namespace mps {
namespace {

using Clock = std::chrono::steady_clock;
using Index = std::ptrdiff_t;

double seconds_since(Clock::time_point start) { return std::chrono::duration<double>(Clock::now() - start).count(); }

std::string fmt(double v) {
  std::ostringstream s;
  s << v;
  return s.str();
}

// What the first step would turn into NaN without a word: a non-finite velocity or pressure, and two particles at one
// point (r_ij / |r_ij|^2 in the gradient and divergence). Ghosts are inactive and may hold anything.
template <int D>
std::string fmt(const Vec<D>& r) {
  std::string text = "(" + fmt(r[0]);
  for (std::size_t a = 1; a < D; ++a) text += ", " + fmt(r[a]);
  return text + ")";
}

template <int D>
void check_initial_state(const BasicParticles<D>& p, BasicCellGrid<D>& grid, double l0) {
  static constexpr const char* velocity_names[3] = {"velocity u", "velocity v", "velocity w"};
  const auto vel = p.velocities();
  for (std::size_t i = 0; i < p.size(); ++i) {
    if (p.kind[i] == Kind::ghost) continue;
    for (std::size_t a = 0; a <= D; ++a) {
      const double value = a < D ? (*vel[a])[i] : p.p[i];
      if (!std::isfinite(value))
        throw std::invalid_argument("simulation: particle " + std::to_string(i) + " has " +
                                    (a < D ? velocity_names[a] : "pressure p") + " = " + fmt(value) +
                                    "; every particle but ghosts needs a finite velocity and pressure");
    }
  }
  // "One point" up to round-off: a periodic image one period away lands within a few ulps, not exactly.
  const double same = 1e-6 * l0;
  grid.bin(p);
  for (std::size_t i = 0; i < p.size(); ++i) {
    if (p.kind[i] == Kind::ghost) continue;
    int twin = -1;
    grid.for_each_near(p.position(i), same, [&](int j, const Vec<D>&) {
      if (static_cast<std::size_t>(j) > i && (twin < 0 || j < twin)) twin = j;
    });
    if (twin >= 0)
      throw std::invalid_argument("simulation: particles " + std::to_string(i) + " and " + std::to_string(twin) +
                                  " sit at one position " + fmt<D>(p.position(i)) + ", closer than " +
                                  fmt(same / l0) + " l0; remove or move one of them");
  }
}

// The radius of the list at r^n: the viscosity's; the error-compensating source reads the density kernel's too. The
// search adds a rounding margin (its sums skip what lies beyond): across a periodic boundary the grid's distance may
// differ from the sums' by an ulp, and the list carried over instead holds every pair the sums count.
double radius_now(const SimulationConfig& config) {
  return config.l0 * (config.error_compensating_source ? std::max(config.radius_laplacian, config.radius_density)
                                                        : config.radius_laplacian);
}

// The neighbour skin in metres, where the step can carry a list over: one process, a list at r^n at the largest
// radius (a wider carried list would cost its sums more than the search it saves), and periodic axes long enough for
// cells that wide (a grid needs three cells along a periodic axis).
template <int D>
double carried_skin(const SimulationConfig& config, const BasicDomain<D>& domain, const BasicExchange<D>& exchange) {
  const double largest = config.largest_radius() * config.l0;
  const double skin = config.neighbor_skin * config.l0, cell = largest + skin;
  if (!(skin > 0.0) || !exchange.keeps_indices() || radius_now(config) < largest * (1.0 - 1e-12)) return 0.0;
  for (std::size_t a = 0; a < D; ++a)
    if (domain.periodic()[a] && domain.extent(static_cast<int>(a)) < 3.0 * cell) return 0.0;
  return skin;
}

std::unique_ptr<LinearSolver> given(std::unique_ptr<LinearSolver> solver) {
  if (!solver) throw std::invalid_argument("simulation: no linear solver given");
  return solver;
}

SimulationConfig validated(SimulationConfig config) {
  config.validate();
  return config;
}

// A right-hand side of zeros (a liquid at rest on the lattice, hydrostatic part split off) has the solution 0, which
// iterative solvers measuring a residual relative to |b| cannot confirm.
class ZeroSolution final : public LinearSolver {
 public:
  SolveReport solve(const CsrMatrix&, std::span<const double>, std::span<double> x) override {
    std::fill(x.begin(), x.end(), 0.0);
    return {};
  }
  [[nodiscard]] std::string spec() const override { return "zero"; }
};

}  // namespace

const char* to_string(Stage stage) {
  switch (stage) {
    case Stage::exchange: return "exchange";
    case Stage::time_step: return "time_step";
    case Stage::neighbors: return "neighbors";
    case Stage::predictor: return "predictor";
    case Stage::neighbors_at_star: return "neighbors_at_star";
    case Stage::projection: return "projection";
    case Stage::free_surface: return "free_surface";
    case Stage::source: return "source";
    case Stage::assembly: return "assembly";
    case Stage::solve: return "solve";
    case Stage::pressure_boundary: return "pressure_boundary";
    case Stage::corrector: return "corrector";
    case Stage::shifting: return "shifting";
    case Stage::end_corrector: return "end_corrector";
    case Stage::finish: return "finish";
  }
  return "unknown stage";
}

namespace {
Kernel pressure_kernel_of(Kernel laplacian, bool higher_order) {
  laplacian.higher_order_laplacian = higher_order;
  return laplacian;
}

}  // namespace

template <int D>
BasicSimulation<D>::BasicSimulation(Particles particles, Domain domain, SimulationConfig config)
    : BasicSimulation(std::move(particles), domain, config, make_solver(config.solver)) {}

template <int D>
BasicSimulation<D>::BasicSimulation(Particles particles, Domain domain, SimulationConfig config,
                                    std::unique_ptr<LinearSolver> solver)
    : BasicSimulation(std::move(particles), domain, std::move(config), given(std::move(solver)),
                      std::make_unique<BasicSerialExchange<D>>()) {}

template <int D>
BasicSimulation<D>::BasicSimulation(Particles particles, Domain domain, SimulationConfig config,
                                    std::unique_ptr<Exchange> exchange)
    : BasicSimulation(std::move(particles), domain, std::move(config), nullptr, std::move(exchange)) {}

template <int D>
BasicSimulation<D>::BasicSimulation(Particles particles, Domain domain, SimulationConfig config,
                                    std::unique_ptr<LinearSolver> solver, std::unique_ptr<Exchange> exchange)
    : particles_(std::move(particles)),
      exchange_(exchange ? std::move(exchange)
                         : throw std::invalid_argument("simulation: no exchange policy given")),
      solver_(solver ? std::move(solver) : make_solver(config.solver, exchange_->solver_context())),
      domain_(domain),
      config_(validated(std::move(config))),  // before the kernels, so that a bad radius is named as the field
      k_density_(make_kernel(config_.radius_density, config_.l0, config_.weight, D)),
      k_surface_(make_kernel(config_.radius_surface, config_.l0, config_.weight, D)),
      k_gradient_(make_kernel(config_.radius_gradient, config_.l0, config_.weight, D)),
      k_laplacian_(make_kernel(config_.radius_laplacian, config_.l0, config_.weight, D)),
      k_pressure_(pressure_kernel_of(k_laplacian_, config_.higher_order_laplacian)),
      skin_(carried_skin(config_, domain_, *exchange_)),
      grid_(domain_, config_.l0 * config_.largest_radius(), skin_) {
  if (D == 2 && config_.fz != 0.0)
    throw std::invalid_argument("simulation config: fz = " + fmt(config_.fz) + " is a 3-D body force; a 2-D "
                                "simulation takes fx and fy");
  if (config_.implicit_viscosity) viscosity_solver_ = make_solver(config_.viscosity_solver);
  if (particles_.count(Kind::fluid) == 0) throw std::invalid_argument("simulation: the domain holds no fluid particles");
  for (std::size_t i = 0; i < particles_.size(); ++i)
    if (particles_.kind[i] != Kind::ghost && !domain_.contains(particles_.position(i)))
      throw std::invalid_argument("simulation: particle " + std::to_string(i) + " at " + fmt<D>(particles_.position(i)) +
                                  " starts outside the domain");
  check_initial_state(particles_, grid_, config_.l0);
  // The configuration's own components, ahead of any a scene adds (the outlet reads the hydrostatic offset).
  const bool split = config_.hydrostatic_split && config_.min_reference_tilt;
  const Vec<D> f = config_.body_force<D>();
  const auto periodic = domain_.periodic();
  Vec<D> balanced{};
  bool any = false;
  for (std::size_t a = 0; a < D; ++a) {
    balanced[a] = split && !periodic[a] ? f[a] : 0.0;
    any = any || balanced[a] != 0.0;
  }
  if (any) add<BasicHydrostaticSplit<D>>(balanced);
  if (config_.initial_reference_density)
    add<BasicInitialReferenceDensity<D>>(particles_, domain_, grid_, k_density_);
  if (config_.shifting > 0.0) add<BasicParticleShifting<D>>(config_.shifting, config_.shift_along_free_surface);
  if (config_.continuous_free_surface) add<BasicContinuousFreeSurface<D>>();
  exchange_->check(*this);
  exchange_->distribute(particles_);  // every process validated the whole scene
}

template <int D>
void BasicSimulation<D>::run(void (StepComponent::*hook)(StepContext&)) {
  StepContext context{*this, particles_, fields_};
  for (const auto& component : components_) ((*component).*hook)(context);
}

namespace {
// A component's name for a message: its type, demangled.
std::string component_name(const auto& component) {
  const char* mangled = typeid(component).name();
  int status = 0;
  char* plain = abi::__cxa_demangle(mangled, nullptr, nullptr, &status);
  std::string name = status == 0 && plain ? plain : mangled;
  std::free(plain);
  return name;
}
}  // namespace

template <int D>
void BasicSimulation<D>::check_order(const StepComponent& added) const {
  for (const auto& there : components_)
    if (there->runs_after(added))
      throw std::invalid_argument("simulation: " + component_name(added) + " must be added before " +
                                  component_name(*there) + ", which reads what it writes; add it first");
}

template <int D>
double BasicSimulation<D>::components_reach() const {
  double reach = 0.0;
  for (const auto& component : components_) reach = std::max(reach, component->reach(*this));
  return reach;
}

template <int D>
double max_fluid_speed_squared(const BasicParticles<D>& p) {
  double umax2 = 0.0;
  const auto n = static_cast<Index>(p.size());
  const auto vel = p.velocities();
#pragma omp parallel for schedule(static) reduction(max : umax2) if (detail::worth_threads(n))
  for (Index ii = 0; ii < n; ++ii) {
    const auto i = static_cast<std::size_t>(ii);
    if (p.kind[i] != Kind::fluid) continue;
    double speed2 = (*vel[0])[i] * (*vel[0])[i];
    for (std::size_t a = 1; a < D; ++a) speed2 += (*vel[a])[i] * (*vel[a])[i];
    umax2 = std::max(umax2, speed2);
  }
  return umax2;
}

template <int D>
double BasicSimulation<D>::choose_dt(std::string& limit) const {
  const double umax2 = max_over_ranks(max_fluid_speed_squared(particles_));
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

template <int D>
const StepInfo& BasicSimulation<D>::step() {
  advance_to(Stage::finish);
  return info_;
}

template <int D>
void BasicSimulation<D>::advance_to(Stage last) {
  const int stop = static_cast<int>(last);
  if (stop < next_stage_)
    throw std::logic_error(std::string("simulation: advance_to(") + to_string(last) + ") but the open step has " +
                           "passed it (next stage: " + to_string(next_stage()) + "); complete it with step() first");
  if (next_stage_ == 0) {
    exchange_->check(*this);  // components added since; outside the rollback, on every process alike
    before_step_ = particles_;
    info_before_ = info_;
  }
  for (; next_stage_ <= stop; ++next_stage_) {
    std::string failure;
    try {
      run_stage(static_cast<Stage>(next_stage_));
    } catch (...) {
      failure = describe_failure(std::current_exception());
    }
    failure = exchange_->first_failure(failure);  // a failure on one process stops them all
    if (!failure.empty()) {
      roll_back();
      throw SimulationError(failure);
    }
  }
  if (next_stage_ > static_cast<int>(Stage::finish)) next_stage_ = 0;
}

// The step, stage by stage, as docs/step.md lists it; each stage's time goes to its phase.
template <int D>
void BasicSimulation<D>::run_stage(Stage stage) {
  const auto start = Clock::now();
  double* phase = &times_.correct;
  switch (stage) {
    case Stage::exchange:
      begin_exchange();
      return;  // the exchange's own time is the exchange's to report (RankExchange::stats)
    case Stage::time_step:
      choose_time_step();
      phase = &times_.neighbors;
      break;
    case Stage::neighbors:
      find_neighbors_now();
      error_compensation();
      run(&StepComponent::before_predictor);
      phase = &times_.neighbors;
      break;
    case Stage::predictor:
      predict();
      run(&StepComponent::after_predictor);
      run(&StepComponent::before_projection);
      phase = &times_.predict;
      break;
    case Stage::neighbors_at_star:
      exchange_->share_predicted(particles_, fields_.prescribed);
      find_neighbors_at_star();
      phase = &times_.neighbors;
      break;
    case Stage::projection:
      number_density_and_divergence();
      detect_surface();
      phase = &times_.assemble;
      break;
    case Stage::free_surface:
      exchange_->share_flags(fields_.surface);
      run(&StepComponent::before_source);
      phase = &times_.assemble;
      break;
    case Stage::source:
      exchange_->share_flags(fields_.surface);
      compute_source();
      run(&StepComponent::before_assembly);
      phase = &times_.assemble;
      break;
    case Stage::assembly:
      assemble();
      phase = &times_.assemble;
      break;
    case Stage::solve:
      solve();
      times_.solver_setup += info_.solve.setup_seconds;
      times_.solve += seconds_since(start) - info_.solve.setup_seconds;
      return;
    case Stage::pressure_boundary:
      set_pressure_boundary_values();
      break;
    case Stage::corrector:
      exchange_->share_pressure(particles_.p, fields_.carriers);
      run(&StepComponent::after_pressure);
      correct();
      break;
    case Stage::shifting:
      exchange_->share_particles(particles_);
      run(&StepComponent::shift_positions);
      break;
    case Stage::end_corrector:
      exchange_->end_step(particles_);
      run(&StepComponent::after_corrector);
      break;
    case Stage::finish:
      finish_step();
      *phase += seconds_since(start);
      check_guard();
      return;
  }
  *phase += seconds_since(start);
}

// A failed step's message names the step, what failed and, for a failure the time step may cure, the knob.
template <int D>
std::string BasicSimulation<D>::describe_failure(std::exception_ptr error) const {
  const std::string at = "step " + std::to_string(info_before_.step + 1) + " (t = " + fmt(info_before_.time) + " s";
  try {
    std::rethrow_exception(error);
  } catch (const SimulationError& e) {
    return e.what();
  } catch (const SolverError& e) {
    return at + "): pressure solve failed: " + e.what();
  } catch (const std::bad_alloc&) {
    return at + "): out of memory (" + std::to_string(particles_.size()) + " particles)";
  } catch (const std::exception& e) {
    // Anything else a stage throws (a non-finite position met by the neighbour search, ...) is a failed step too.
    return at + ", dt = " + fmt(fields_.dt) + " s, dt limit " + info_.dt_limit + "): " + e.what() + dt_advice();
  } catch (...) {
    return at + "): a stage threw an exception that is not a std::exception";
  }
}

template <int D>
void BasicSimulation<D>::roll_back() {
  exchange_->abandon_step();
  particles_ = before_step_;
  fringe_ready_ = false;  // near_star_ may be this step's
  info_ = info_before_;
  next_stage_ = 0;
}

template <int D>
void BasicSimulation<D>::begin_exchange() {
  // Components are added after construction: their reach is read each step. Both particles of a pair may move
  // max_displacement in the step.
  const double kernels = config_.l0 * config_.largest_radius();
  const double reach = std::max(kernels, components_reach()) + 2.0 * config_.max_displacement * config_.l0;
  const bool reorder = config_.reorders_after(info_.step);
  exchange_->begin_step(particles_, domain_, reach, reorder ? grid_.cell_size() : 0.0);
  if (reorder) solver_->renumbered();  // the particles, and with them the PPE's rows, are put in cell order
}

template <int D>
void BasicSimulation<D>::choose_time_step() {
  StepFields& f = fields_;
  f.dt = choose_dt(info_.dt_limit);
  f.time = info_.time + f.dt;
  info_.dt = f.dt;
  f.balanced = {};
  f.n_source.clear();
  f.ecs.clear();
  f.held.clear();
  f.held_value.clear();
  f.open_weight.clear();
  f.open_value.clear();
  f.pressure_offset.clear();
  f.surface_own_reference = false;
}

template <int D>
void BasicSimulation<D>::find_neighbors_now() {
  Particles& p = particles_;
  const bool reorder = exchange_->reorders() && config_.reorders_after(info_.step);
  if (reorder) {
    grid_.bin(p);
    p.permute(grid_.cell_order());
  }
  grid_.bin(p);  // the mirror walls and outlets read the grid at r^n
  mark_rows_read();
  info_.neighbors_carried = !reorder && fringe_covers_moves();
  if (info_.neighbors_carried) add_fringe(near_star_, fringe_);
  else grid_.neighbors(p, radius_now(config_) * (1.0 + 1e-12), near_star_, rows_read_);  // radius_now: why the margin
  fringe_ready_ = false;
  fields_.prescribed.assign(p.size(), 0);
}

// No stage reads a dummy's neighbours (set_dummy_pressure reads the walls'), and a tank's dummies are most of its
// particles: the searches make the rows of the fluid, the walls and what components mark only.
template <int D>
void BasicSimulation<D>::mark_rows_read() {
  const Particles& p = particles_;
  rows_read_.resize(p.size());
  for (std::size_t i = 0; i < p.size(); ++i)
    rows_read_[i] = p.kind[i] == Kind::fluid || p.kind[i] == Kind::wall ? 1 : 0;
  for (const auto& c : components_) c->mark_rows_read(p, rows_read_);
}

// Whether every pair now within the largest radius was within it plus the skin at the last search at r*: the same
// rows searched (no particle added, removed or changed kind), none moved half the skin (less a margin for
// rounding).
template <int D>
bool BasicSimulation<D>::fringe_covers_moves() const {
  const Particles& p = particles_;
  if (!fringe_ready_ || rows_read_ != searched_rows_) return false;
  const double limit = 0.5 * skin_ * (1.0 - 1e-9), limit2 = limit * limit;
  const auto n = static_cast<Index>(p.size());
  bool covered = true;
#pragma omp parallel for schedule(static) reduction(&& : covered) if (detail::worth_threads(n))
  for (Index ii = 0; ii < n; ++ii) {
    const auto i = static_cast<std::size_t>(ii);
    if (p.kind[i] == Kind::ghost) continue;
    Vec<D> then;
    for (std::size_t a = 0; a < D; ++a) then[a] = searched_at_[a][i];
    if (!(norm2<D>(domain_.displacement(then, p.position(i))) < limit2)) covered = false;
  }
  return covered;
}

// The error-compensating source (Khayyer & Gotoh 2011) from the state at the step's start: e = (n - n0)/n0 and
// delta = dt (Dn/Dt)/n0, the fractional change of n this step would make. -(rho/dt^2)(|e| delta + |delta| e) is
// large only where n is both off and moving further off (or back fast), so a liquid at rest gets none of it.
template <int D>
void BasicSimulation<D>::error_compensation() {
  if (!config_.error_compensating_source) return;
  const Particles& p = particles_;
  StepFields& f = fields_;
  f.ecs.assign(p.size(), 0.0);
  ConstComponents<D> u;
  const auto vel = p.velocities();
  for (std::size_t a = 0; a < D; ++a) u[a] = *vel[a];
  mark_in_ppe();
  number_density_and_rate<D>({p, domain_, near_star_, k_density_}, u, f.n_start, f.ecs, f.in_ppe);
  const double n0 = k_density_.n0, scale = config_.rho / (f.dt * f.dt);
  for (std::size_t i = 0; i < p.size(); ++i) {
    const double e = (f.n_start[i] - n0) / n0, delta = f.dt * f.ecs[i] / n0;
    f.ecs[i] = -scale * (std::abs(e) * delta + std::abs(delta) * e);
  }
}

// Walls and dummies carry their (prescribed or mirrored) velocity into the viscous sum: the no-slip condition.
template <int D>
void BasicSimulation<D>::predict() {
  if (config_.implicit_viscosity) implicit_viscous_predictor();
  else explicit_viscous_predictor();
}

// Only fluid and walls can hold a PPE row: the source, the surface test and the assembly read n*, div u* and the
// error-compensating source of no other particle (the dummies are most of a tank's boundary).
template <int D>
void BasicSimulation<D>::mark_in_ppe() {
  const Particles& p = particles_;
  StepFields& f = fields_;
  f.in_ppe.resize(p.size());
  for (std::size_t i = 0; i < p.size(); ++i) f.in_ppe[i] = p.kind[i] == Kind::fluid || p.kind[i] == Kind::wall ? 1 : 0;
}

// Walls, dummies, ghosts and prescribed fluid take no viscous or pressure term: their sums are not made (in the 3-D
// dam break at 5 cm four fifths of the particles).
template <int D>
void BasicSimulation<D>::mark_advanced() {
  const Particles& p = particles_;
  StepFields& f = fields_;
  f.advanced.resize(p.size());
  for (std::size_t i = 0; i < p.size(); ++i) f.advanced[i] = p.kind[i] == Kind::fluid && !f.prescribed[i] ? 1 : 0;
}

template <int D>
void BasicSimulation<D>::explicit_viscous_predictor() {
  Particles& p = particles_;
  StepFields& f = fields_;
  const auto n = static_cast<Index>(p.size());
  const double dt = f.dt;
  const auto pos = p.positions();
  const auto vel = p.velocities();
  ConstComponents<D> u;
  Components<D> lap;
  for (std::size_t a = 0; a < D; ++a) {
    f.lap_u[a].assign(p.size(), 0.0);
    u[a] = *vel[a];
    lap[a] = f.lap_u[a];
  }
  mark_advanced();
  laplacian<D>({p, domain_, neighbors_now(), k_laplacian_}, u, lap, f.advanced);
  const Vec<D> force = config_.body_force<D>();
#pragma omp parallel for schedule(static) if (detail::worth_threads(n))
  for (Index ii = 0; ii < n; ++ii) {
    const auto i = static_cast<std::size_t>(ii);
    if (p.kind[i] != Kind::fluid) continue;
    if (!f.prescribed[i])
      for (std::size_t a = 0; a < D; ++a) (*vel[a])[i] += dt * (config_.nu * f.lap_u[a][i] + force[a] - f.balanced[a]);
    Vec<D> r;
    for (std::size_t a = 0; a < D; ++a) r[a] = (*pos[a])[i] + dt * (*vel[a])[i];
    domain_.wrap(r);
    for (std::size_t a = 0; a < D; ++a) (*pos[a])[i] = r[a];
  }
}

// The boundary velocities are lagged by a step. For the mode a wall's mirror values feed back on (u beside
// the wall, its mirror -u) that gives the factor (1 - a)/(1 + a), a > 0: stable for any dt.
template <int D>
void BasicSimulation<D>::implicit_viscous_predictor() {
  Particles& p = particles_;
  const StepFields& f = fields_;
  const double dt = f.dt;
  Vec<D> force = config_.body_force<D>();
  for (std::size_t a = 0; a < D; ++a) force[a] -= f.balanced[a];
  const auto pos = p.positions();
  const auto vel = p.velocities();
  const CsrMatrix lap = laplacian_matrix<D>({p, domain_, neighbors_now(), k_laplacian_});
  // Kept between steps for their memory: the system over the fluid, its right-hand sides and solutions.
  auto& [row, fluid, m, b, u] = viscous_;
  row.assign(p.size(), -1);
  fluid.clear();
  for (std::size_t i = 0; i < p.size(); ++i)
    if (p.kind[i] == Kind::fluid && !f.prescribed[i]) {
      row[i] = static_cast<int>(fluid.size());
      fluid.push_back(i);
    }
  const double a = dt * config_.nu;
  m.rows = m.cols = static_cast<int>(fluid.size());
  m.row_ptr.assign(fluid.size() + 1, 0);
  m.col.clear();
  m.val.clear();
  m.col.reserve(lap.nnz());
  m.val.reserve(lap.nnz());
  for (std::size_t c = 0; c < D; ++c) {
    b[c].resize(fluid.size());
    u[c].resize(fluid.size());
  }
  for (std::size_t r = 0; r < fluid.size(); ++r) {
    const std::size_t i = fluid[r];
    for (std::size_t c = 0; c < D; ++c) {
      b[c][r] = (*vel[c])[i] + dt * force[c];
      u[c][r] = (*vel[c])[i];
    }
    for (auto k = static_cast<std::size_t>(lap.row_ptr[i]); k < static_cast<std::size_t>(lap.row_ptr[i + 1]); ++k) {
      const auto j = static_cast<std::size_t>(lap.col[k]);
      if (row[j] >= 0) {
        m.col.push_back(row[j]);
        m.val.push_back((j == i ? 1.0 : 0.0) - a * lap.val[k]);
      } else {
        for (std::size_t c = 0; c < D; ++c) b[c][r] += a * lap.val[k] * (*vel[c])[j];
      }
    }
    m.row_ptr[r + 1] = static_cast<int>(m.col.size());
  }
  try {
    info_.viscosity_iterations = 0;
    for (std::size_t c = 0; c < D; ++c) info_.viscosity_iterations += viscosity_solver_->solve(m, b[c], u[c]).iterations;
  } catch (const SolverError& e) {
    throw SimulationError("step " + std::to_string(info_.step + 1) + " (t = " + fmt(info_.time) +
                          " s): implicit viscosity solve failed: " + e.what());
  }
  auto move = [&](std::size_t i) {
    Vec<D> r;
    for (std::size_t c = 0; c < D; ++c) r[c] = (*pos[c])[i] + dt * (*vel[c])[i];
    domain_.wrap(r);
    for (std::size_t c = 0; c < D; ++c) (*pos[c])[i] = r[c];
  };
  for (std::size_t r = 0; r < fluid.size(); ++r) {
    const std::size_t i = fluid[r];
    for (std::size_t c = 0; c < D; ++c) (*vel[c])[i] = u[c][r];
    move(i);
  }
  for (std::size_t i = 0; i < p.size(); ++i)
    if (p.kind[i] == Kind::fluid && f.prescribed[i]) move(i);
}

// One binning and two lists serve every kernel: one at the largest radius, one at the largest of the small ones.
template <int D>
void BasicSimulation<D>::find_neighbors_at_star() {
  const Particles& p = particles_;
  grid_.bin(p);
  mark_rows_read();
  const double largest = config_.l0 * config_.largest_radius();
  small_radius_ = 0.0;
  for (const Kernel* k : {&k_density_, &k_surface_, &k_gradient_, &k_laplacian_})
    if (k->re < largest * (1.0 - 1e-12)) small_radius_ = std::max(small_radius_, k->re);
  if (skin_ > 0.0) {
    grid_.neighbors(p, largest, near_star_, small_radius_, small_radius_ > 0.0 ? &close_star_ : nullptr,
                    largest + skin_, fringe_, rows_read_);
    const auto pos = p.positions();
    for (std::size_t a = 0; a < D; ++a) searched_at_[a].assign(pos[a]->begin(), pos[a]->end());
    searched_rows_ = rows_read_;
    fringe_ready_ = true;
  } else if (small_radius_ > 0.0) {
    grid_.neighbors(p, largest, near_star_, small_radius_, close_star_, rows_read_);
  } else {
    grid_.neighbors(p, largest, near_star_, rows_read_);
  }
}

template <int D>
void BasicSimulation<D>::number_density_and_divergence() {
  const Particles& p = particles_;
  const BasicStencil<D> density{p, domain_, neighbors_at_star(k_density_), k_density_};
  fields_.div.assign(p.size(), 0.0);
  ConstComponents<D> u;
  const auto vel = p.velocities();
  for (std::size_t a = 0; a < D; ++a) u[a] = *vel[a];
  mark_in_ppe();
  if (!config_.higher_order_source) {
    mps::number_density<D>(density, fields_.n_star, fields_.in_ppe);
    divergence<D>({p, domain_, neighbors_at_star(k_gradient_), k_gradient_}, u, fields_.div, fields_.in_ppe);
    return;
  }
  // One pass over the pairs for both.
  number_density_and_rate<D>(density, u, fields_.n_star, fields_.div, fields_.in_ppe);
  const double scale = -static_cast<double>(D) / k_density_.n_rate;
  for (double& d : fields_.div) d *= scale;
}

template <int D>
void BasicSimulation<D>::detect_surface() {
  const Particles& p = particles_;
  const NeighborList& list = neighbors_at_star(k_surface_);
  const bool own_radius = k_surface_.re != k_density_.re;
  if (own_radius) mps::number_density<D>({p, domain_, list, k_surface_}, fields_.n_surface, fields_.in_ppe);
  detect_free_surface(p, fields_.n_at_surface_radius(), k_surface_.n0, config_.beta, &list,
                      k_surface_.lattice_neighbors, config_.theta, fields_.surface);
}

template <int D>
void BasicSimulation<D>::compute_source() {
  const Particles& p = particles_;
  StepFields& f = fields_;
  const auto n = static_cast<Index>(p.size());
  mixed_source(f.n_source.empty() ? f.n_star : f.n_source, k_density_.n0, f.div, config_.rho, f.dt, config_.gamma,
               f.source);
  for (std::size_t i = 0; i < f.ecs.size(); ++i) f.source[i] += f.ecs[i];
  if (std::find(f.surface.begin(), f.surface.end(), 1) == f.surface.end()) return;
  // Where the source kernel reaches a free-surface particle its number density deficit is geometry, not
  // expansion, and would ask for suction growing as 1/dt^2: there the divergence term alone drives the PPE (the
  // error-compensating term, which reads the same deficit, is dropped too).
  const NeighborList& reach = neighbors_at_star(k_density_);
#pragma omp parallel for schedule(static) if (detail::worth_threads(n))
  for (Index ii = 0; ii < n; ++ii) {
    const auto i = static_cast<std::size_t>(ii);
    for (int j : reach.of(i)) {
      const auto jj = static_cast<std::size_t>(j);
      if (!f.surface[jj]) continue;
      if (norm2<D>(domain_.displacement(p.position(i), p.position(jj))) < k_density_.re * k_density_.re) {
        f.source[i] = config_.rho / f.dt * f.div[i];
        break;
      }
    }
  }
}

template <int D>
void BasicSimulation<D>::assemble() {
  const StepFields& f = fields_;
  const double screening = config_.sound_speed * f.dt;  // the compressibility's reach
  const PpeCounts counts =
      exchange_->assemble({particles_, domain_, neighbors_at_star(k_pressure_), k_pressure_},
                          f.held.empty() ? f.surface : f.held, f.source, f.held_value,
                          screening > 0.0 ? 1.0 / (screening * screening) : 0.0, {f.open_weight, f.open_value},
                          solver_->wants_fixed_rows() ? PpeRows::every_particle : PpeRows::unknowns);
  info_.unknowns = counts.unknowns;
  const std::size_t own = owned_particles();
  info_.free_surface = static_cast<std::size_t>(
      exchange_->sum(std::count(f.surface.begin(), f.surface.begin() + static_cast<Index>(own), 1)));
  info_.floating_groups = counts.floating_groups;
}

// Warm start from the previous step, or the zero guess of a cold start. Before any pressure has been set there is
// nothing to warm-start from (and with an offset P = 0 would read as P - offset = -offset, from which a liquid at rest
// cannot reach a tolerance relative to its round-off |b|). Both cases are decided over every process.
template <int D>
void BasicSimulation<D>::solve() {
  const OwnPpeRows own = exchange_->own_rows();
  const bool zero_rhs = exchange_->all(std::all_of(own.rhs.begin(), own.rhs.end(), [](double b) { return b == 0.0; }));
  const bool no_previous = exchange_->all(std::all_of(own.particle.begin(), own.particle.end(), [&](int i) {
    return particles_.p[static_cast<std::size_t>(i)] == 0.0;
  }));
  ZeroSolution zero;
  LinearSolver& solver = zero_rhs ? static_cast<LinearSolver&>(zero) : *solver_;
  info_.solve = exchange_->solve(solver, particles_, no_previous || !config_.warm_start,
                                 config_.clamp_negative_pressure, fields_.pressure_offset);
}

template <int D>
void BasicSimulation<D>::set_pressure_boundary_values() {
  Particles& p = particles_;
  StepFields& f = fields_;
  if (!f.held_value.empty()) {  // a held particle shows the pressure it was held at
    const std::vector<char>& held = f.held.empty() ? f.surface : f.held;
    for (std::size_t i = 0; i < p.size(); ++i)
      if (p.kind[i] == Kind::fluid && held[i])
        p.p[i] = f.held_value[i] + (f.pressure_offset.empty() ? 0.0 : f.pressure_offset[i]);
  }
  set_dummy_pressure<D>({p, domain_, neighbors_at_star(k_laplacian_), k_laplacian_}, p, f.surface, config_.rho,
                        config_.body_force<D>(), f.carriers);
}

// u^{n+1} = u* - (dt/rho) grad P, x^{n+1} = x^n + dt u^{n+1}. With a pressure offset the gradient is of P - offset,
// whose own gradient balances the force the predictor left out.
template <int D>
void BasicSimulation<D>::correct() {
  Particles& p = particles_;
  StepFields& f = fields_;
  std::span<const double> pressure = p.p;
  if (!f.pressure_offset.empty()) {
    f.residual = p.p;
    for (std::size_t i = 0; i < p.size(); ++i) f.residual[i] -= f.pressure_offset[i];
    pressure = f.residual;
  }
  const double tilt = config_.min_reference_tilt ? config_.rho : 0.0;
  const Vec<D> force = config_.body_force<D>();
  Vec<D> min_tilt;
  Components<D> grad;
  for (std::size_t a = 0; a < D; ++a) {
    f.grad_p[a].assign(p.size(), 0.0);
    grad[a] = f.grad_p[a];
    min_tilt[a] = tilt * (force[a] - f.balanced[a]);
  }
  mark_advanced();
  gradient<D>({p, domain_, neighbors_at_star(k_gradient_), k_gradient_}, pressure, grad, config_.pressure_gradient,
              f.carriers, min_tilt,
              f.surface_own_reference ? std::span<const char>(f.surface) : std::span<const char>(), f.advanced);
  const double dt = f.dt;
  const bool stabilise = config_.stabilisation_distance > 0.0;
  if (stabilise)
    stabilisation_velocity_changes<D>(p, domain_, neighbors_at_star(k_gradient_),
                                      config_.stabilisation_distance * config_.l0, dt, f.advanced, f.stabilisation);
  const auto n = static_cast<Index>(p.size());
  const auto pos = p.positions();
  const auto vel = p.velocities();
#pragma omp parallel for schedule(static) if (detail::worth_threads(n))
  for (Index ii = 0; ii < n; ++ii) {
    const auto i = static_cast<std::size_t>(ii);
    if (p.kind[i] != Kind::fluid || f.prescribed[i]) continue;
    Vec<D> r;
    for (std::size_t a = 0; a < D; ++a) {
      double du = -dt / config_.rho * f.grad_p[a][i];
      if (stabilise) du += f.stabilisation[a][i];
      (*vel[a])[i] += du;
      r[a] = (*pos[a])[i] + dt * du;  // the predictor having moved it by dt u*
    }
    domain_.wrap(r);
    for (std::size_t a = 0; a < D; ++a) (*pos[a])[i] = r[a];
  }
}

template <int D>
void BasicSimulation<D>::finish_step() {
  info_.max_speed = std::sqrt(max_over_ranks(max_fluid_speed_squared(particles_)));
  info_.time += fields_.dt;
  ++info_.step;
}

// Names the knob of the limit that set dt (lowering dt_max does nothing while cfl binds), or the host program's own
// option for the time step when it set one.
template <int D>
std::string BasicSimulation<D>::dt_advice() const {
  const std::string limit = info_.dt_limit == "viscous" ? "viscous" : info_.dt_limit == "cfl" ? "CFL" : "dt_max";
  if (!config_.dt_option.empty()) return " (reduce " + config_.dt_option + "; the " + limit + " limit set dt)";
  return info_.dt_limit == "viscous" ? " (reduce viscous_number, the viscous limit set dt)"
         : info_.dt_limit == "cfl"   ? " (reduce cfl, the CFL limit set dt)"
                                     : " (reduce dt_max)";
}

template <int D>
void BasicSimulation<D>::check_guard() const {
  const Particles& p = particles_;
  const std::string advice = dt_advice();
  // The projection's settings are named too: which one a blow-up happened under is the first thing to know.
  auto fail = [&](const std::string& what) {
    throw SimulationError("step " + std::to_string(info_.step) + " (t = " + fmt(info_.time) + " s, dt = " +
                          fmt(info_.dt) + " s, dt limit " + info_.dt_limit + ", pressure treatment " +
                          pressure_treatment(config_) + ", gradient " + std::string(to_string(config_.pressure_gradient)) +
                          "): " + what + advice);
  };
  // A fluid particle moves by exactly dt |u^{n+1}| in a step, so the displacement bound is a speed bound.
  const double max_move = config_.max_displacement * config_.l0;
  const auto pos = p.positions();
  auto finite_position = [&](std::size_t i) {
    bool finite = true;
    for (std::size_t a = 0; a < D; ++a) finite = finite && std::isfinite((*pos[a])[i]);
    return finite;
  };
  auto bad = [&](std::size_t i) {
    if (p.kind[i] == Kind::ghost) return false;
    const double speed = norm<D>(p.velocity(i));
    return !finite_position(i) || !std::isfinite(speed) || !std::isfinite(p.p[i]) ||
           !domain_.contains(p.position(i)) || speed > config_.max_speed ||
           (p.kind[i] == Kind::fluid && info_.dt * speed > max_move);
  };
  // Threads only look for the first offending particle; its message is then made in order.
  const auto n = static_cast<Index>(p.size());
  Index first = n;
#pragma omp parallel for schedule(static) reduction(min : first) if (detail::worth_threads(n))
  for (Index i = 0; i < n; ++i)
    if (bad(static_cast<std::size_t>(i))) first = std::min(first, i);
  if (first == n) return;
  const auto i = static_cast<std::size_t>(first);
  const double speed = norm<D>(p.velocity(i));
  if (!finite_position(i) || !std::isfinite(speed) || !std::isfinite(p.p[i]))
    fail("particle " + std::to_string(i) + " has a non-finite position, velocity or pressure; the run blew up");
  if (!domain_.contains(p.position(i)))
    fail(std::string(to_string(p.kind[i])) + " particle " + std::to_string(i) + " left the domain at " +
         fmt<D>(p.position(i)) + "; the flow is unstable");
  if (speed > config_.max_speed)
    fail("particle " + std::to_string(i) + " moves at " + fmt(speed) + " m/s, above max_speed " +
         fmt(config_.max_speed) + " m/s");
  fail("particle " + std::to_string(i) + " moved " + fmt(info_.dt * speed / config_.l0) +
       " l0 in one step, above the limit of " + fmt(config_.max_displacement) + " l0: velocity blow-up");
}

template <int D>
bool BasicSimulation<D>::checkpoint_exact() const {
  return !solver_->keeps_setup() || exchange_->renumbers_after(info_.step, config_);
}

template <int D>
nlohmann::json BasicSimulation<D>::checkpoint() const {
  if (next_stage_ != 0)
    throw std::logic_error("simulation: checkpoint() between steps only; step " + std::to_string(info_.step + 1) +
                           " is open at stage " + to_string(next_stage()));
  nlohmann::json particles = nlohmann::json::object();
  particles_.for_each_field([&](const char* name, const auto& values) { particles[name] = pack_array(values); });
  nlohmann::json components = nlohmann::json::array();
  for (const auto& component : components_)
    components.push_back({{"type", component_name(*component)}, {"state", component->save_state()}});
  const SolveReport& r = info_.solve;
  nlohmann::json own = {
      {"dim", D},
      {"step", info_.step},
      {"time", info_.time},
      {"dt", info_.dt},
      {"dt_limit", info_.dt_limit},
      {"viscosity_iterations", info_.viscosity_iterations},
      {"unknowns", info_.unknowns},
      {"free_surface", info_.free_surface},
      {"floating_groups", info_.floating_groups},
      {"max_speed", info_.max_speed},
      {"solve", {{"backend", r.backend}, {"iterations", r.iterations}, {"relative_residual", r.relative_residual},
                 {"setup_seconds", r.setup_seconds}, {"solve_seconds", r.solve_seconds},
                 {"setup_reused", r.setup_reused}}},
      {"phase_seconds", {times_.neighbors, times_.predict, times_.assemble, times_.solver_setup, times_.solve,
                         times_.correct}},
      {"exact", checkpoint_exact()},
      {"particles", std::move(particles)},
      {"components", std::move(components)},
      {"solver", {{"spec", solver_->spec()}, {"state", solver_->save_state()}}},
      {"exchange", exchange_->save_state()}};
  return exchange_->gather_states(std::move(own));
}

namespace {
// A checkpoint's parts: one per process of the run that wrote it ({"ranks": P, "parts": [...]}), or itself.
std::vector<const nlohmann::json*> parts_of(const nlohmann::json& state) {
  std::vector<const nlohmann::json*> parts;
  if (!state.contains("parts")) return {&state};
  const nlohmann::json& all = state_part(state, "parts");
  if (!all.is_array() || all.empty()) throw std::runtime_error("checkpoint: 'parts' is no list of processes");
  for (const auto& part : all) parts.push_back(&part);
  return parts;
}

// A part's components by type, in order: the k-th component of a type matches the k-th of that type in the part
// (an app may add a component on one rank only, such as rank 0's solve log).
const nlohmann::json* matching_component(const nlohmann::json& part, const std::string& type, int occurrence) {
  const nlohmann::json& list = state_part(part, "components");
  if (!list.is_array()) throw std::runtime_error("checkpoint: 'components' is not a list (a damaged file?)");
  for (const auto& entry : list)
    if (unpack_value<std::string>(entry, "type") == type && occurrence-- == 0) return &state_part(entry, "state");
  return nullptr;
}

template <int D>
BasicParticles<D> unpack_particles(const nlohmann::json& part) {
  BasicParticles<D> restored;
  restored.for_each_field([&](const char* name, auto& values) { unpack_array(state_part(part, "particles"), name, values); });
  bool same_length = true;
  restored.for_each_field([&](const char*, const auto& values) { same_length &= values.size() == restored.size(); });
  if (!same_length) throw std::runtime_error("checkpoint: its particle fields differ in length (a damaged file?)");
  return restored;
}
}  // namespace

template <int D>
void BasicSimulation<D>::restore(const nlohmann::json& state) {
  if (next_stage_ != 0)
    throw std::logic_error("simulation: restore() between steps only; step " + std::to_string(info_.step + 1) +
                           " is open at stage " + to_string(next_stage()));
  const std::vector<const nlohmann::json*> parts = parts_of(state);
  const bool same_processes = static_cast<int>(parts.size()) == exchange_->processes();
  const nlohmann::json& mine = same_processes ? exchange_->own_part(parts) : *parts.front();
  const int dim = unpack_value<int>(mine, "dim");
  if (dim != D)
    throw std::runtime_error("checkpoint: of a " + std::to_string(dim) + "-D run; this simulation is " +
                             std::to_string(D) + "-D");
  // Everything is read and checked before anything is changed: a checkpoint that does not fit leaves the run as it was.
  std::vector<std::vector<const nlohmann::json*>> component_parts(components_.size());
  {
    std::map<std::string, int> seen;
    std::string missing;
    for (std::size_t c = 0; c < components_.size(); ++c) {
      const std::string type = component_name(*components_[c]);
      const int occurrence = seen[type]++;
      for (const nlohmann::json* part : same_processes ? std::vector<const nlohmann::json*>{&mine} : parts)
        if (const nlohmann::json* found = matching_component(*part, type, occurrence))
          component_parts[c].push_back(found);
      if (component_parts[c].empty() && (same_processes || exchange_->first_process()))
        missing += (missing.empty() ? "" : ", ") + type;
    }
    if (!missing.empty()) {
      std::string theirs;
      for (const auto& entry : state_part(mine, "components"))
        theirs += (theirs.empty() ? "" : ", ") + unpack_value<std::string>(entry, "type");
      throw std::runtime_error("checkpoint: its run had the components [" + theirs + "], not [" + missing +
                               "] of this simulation; build the scene as the checkpointed run did");
    }
  }
  Particles restored;
  if (same_processes) {
    restored = unpack_particles<D>(mine);
  } else {
    for (const nlohmann::json* part : parts) {  // all of them, in the processes' order; the exchange distributes them
      const Particles more = unpack_particles<D>(*part);
      restored.for_each_field([&](const char* name, auto& values) {
        more.for_each_field([&](const char* other, const auto& theirs) {
          if constexpr (std::is_same_v<std::decay_t<decltype(values)>, std::decay_t<decltype(theirs)>>)
            if (std::string_view(name) == other) values.insert(values.end(), theirs.begin(), theirs.end());
        });
      });
    }
  }
  const nlohmann::json& solver = state_part(mine, "solver");
  const bool same_solver = same_processes && unpack_value<std::string>(solver, "spec") == solver_->spec();

  StepInfo info;
  info.step = unpack_value<int>(mine, "step");
  info.time = unpack_value<double>(mine, "time");
  info.dt = unpack_value<double>(mine, "dt");
  info.dt_limit = unpack_value<std::string>(mine, "dt_limit");
  info.viscosity_iterations = unpack_value<int>(mine, "viscosity_iterations");
  info.unknowns = unpack_value<std::size_t>(mine, "unknowns");
  info.free_surface = unpack_value<std::size_t>(mine, "free_surface");
  info.floating_groups = unpack_value<std::size_t>(mine, "floating_groups");
  info.max_speed = unpack_value<double>(mine, "max_speed");
  const nlohmann::json& r = state_part(mine, "solve");
  info.solve.backend = unpack_value<std::string>(r, "backend");
  info.solve.iterations = unpack_value<int>(r, "iterations");
  info.solve.relative_residual = unpack_value<double>(r, "relative_residual");
  info.solve.setup_seconds = unpack_value<double>(r, "setup_seconds");
  info.solve.solve_seconds = unpack_value<double>(r, "solve_seconds");
  info.solve.setup_reused = unpack_value<bool>(r, "setup_reused");
  const auto phases = unpack_value<std::vector<double>>(mine, "phase_seconds");
  if (phases.size() != 6) throw std::runtime_error("checkpoint: 'phase_seconds' holds no six phases (a damaged file?)");

  particles_ = std::move(restored);
  info_ = std::move(info);
  times_ = {phases[0], phases[1], phases[2], phases[3], phases[4], phases[5]};
  for (std::size_t c = 0; c < components_.size(); ++c) {
    if (same_processes)
      components_[c]->restore_state(*component_parts[c].front());
    else  // rank 0 takes over what every process held; the others start with none of it
      components_[c]->restore_state(
          components_[c]->merge_states(exchange_->first_process() ? component_parts[c] : std::vector<const nlohmann::json*>{}));
  }
  // Another solver than the checkpointed run's (a restart that changes it), or another process count: afresh.
  if (same_solver) solver_->restore_state(state_part(solver, "state"));
  if (same_processes) {
    exchange_->restore_state(mine.contains("exchange") ? mine.at("exchange") : nlohmann::json(), info_.step);
  } else {
    exchange_->distribute(particles_);
    exchange_->restore_state(nullptr, info_.step);
    solver_->renumbered();
  }
}

template <int D>
void BasicSimulation<D>::set_particles(Particles particles) {
  if (next_stage_ != 0)
    throw std::logic_error("simulation: set_particles() between steps only; step " + std::to_string(info_.step + 1) +
                           " is open at stage " + to_string(next_stage()));
  if (exchange_->processes() > 1)
    throw std::logic_error("simulation: set_particles() on one process only: on MPI ranks each holds its own");
  const std::size_t n = particles_.size();
  std::string wrong;
  particles.for_each_field([&](const char* name, const auto& values) {
    if (values.size() != n && wrong.empty())
      wrong = "field " + std::string(name) + " holds " + std::to_string(values.size()) + " values";
  });
  if (!wrong.empty() || particles.id != particles_.id)
    throw std::invalid_argument("simulation: set_particles() takes this simulation's " + std::to_string(n) +
                                " particles in their order (the ids of particles()), edited" +
                                (wrong.empty() ? std::string(": the ids differ") : "; " + wrong));
  for (std::size_t i = 0; i < n; ++i) {
    const Vec<D> r = particles.position(i), u = particles.velocity(i);
    bool finite = std::isfinite(particles.p[i]);
    for (std::size_t a = 0; a < D; ++a) finite = finite && std::isfinite(r[a]) && std::isfinite(u[a]);
    if (!finite)
      throw std::invalid_argument("simulation: set_particles(): particle " + std::to_string(i) +
                                  " has a non-finite position, velocity or pressure");
    if (static_cast<int>(particles.kind[i]) > static_cast<int>(Kind::ghost))
      throw std::invalid_argument("simulation: set_particles(): particle " + std::to_string(i) + " has no kind");
    if (particles.kind[i] != Kind::ghost && !domain_.contains(r))
      throw std::invalid_argument("simulation: set_particles(): particle " + std::to_string(i) + " at " + fmt<D>(r) +
                                  " is outside the domain");
  }
  if (particles.count(Kind::fluid) == 0) throw std::invalid_argument("simulation: set_particles(): no fluid left");
  particles_ = std::move(particles);
  solver_->renumbered();
}

template double max_fluid_speed_squared(const BasicParticles<2>&);
template double max_fluid_speed_squared(const BasicParticles<3>&);
template class BasicSimulation<2>;
template class BasicSimulation<3>;

}  // namespace mps
