#pragma once
/// \file
/// The semi-implicit MPS step (design §3), time-step control and the stability guard. A step runs named stages,
/// neighbours -> predictor -> n*, div u* -> free surface -> PPE source -> assemble -> solve -> pressure boundary
/// values -> corrector -> post-step, and a scene adds components (mps/step/components.hpp) that hook in between them.
/// docs/step.md describes the stages, the hooks and each component.
#include <array>
#include <functional>
#include <limits>
#include <memory>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "mps/core/errors.hpp"
#include "mps/core/kernel.hpp"
#include "mps/core/neighbors.hpp"
#include "mps/core/particles.hpp"
#include "mps/core/vec.hpp"
#include "mps/numerics/operators.hpp"
#include "mps/numerics/ppe.hpp"
#include "mps/solvers/solver.hpp"
#include "mps/step/config.hpp"
#include "mps/step/exchange.hpp"

namespace mps {

/// What the last step did.
struct StepInfo {
  int step = 0;                 ///< steps completed
  /// @{ simulated time at the end of the step, and the step's time step [s]
  double time = 0, dt = 0;  /// @}
  std::string dt_limit;         ///< which bound set dt: "dt_max", "cfl" or "viscous"
  SolveReport solve;            ///< the pressure solve
  int viscosity_iterations = 0;  ///< implicit viscosity: CG iterations of both components
  /// @{ the PPE's unknowns, free-surface particles and closed groups (each with its gauge)
  std::size_t unknowns = 0, free_surface = 0, floating_groups = 0;  /// @}
  double max_speed = 0;         ///< the fluid's largest speed at the end of the step [m/s]
  /// The list at r^n was the last step's at r* widened by its fringe, not a search (SimulationConfig::neighbor_skin).
  bool neighbors_carried = false;
};

/// Wall-clock seconds spent in each phase of the step, summed over every step so far.
struct PhaseTimes {
  /// @{ neighbour searches, predictor, n* to assembly, solver setup, solve, pressure boundary values to corrector
  double neighbors = 0, predict = 0, assemble = 0, solver_setup = 0, solve = 0, correct = 0;  /// @}
  /// The sum of the phases.
  [[nodiscard]] double total() const { return neighbors + predict + assemble + solver_setup + solve + correct; }
};

/// What one step's stages hand on to the next, per particle unless said. Kept by the simulation so that its memory
/// is reused from step to step. Components read and write it at their hooks.
template <int D>
struct BasicStepFields {
  double dt = 0;    ///< this step's time step [s]
  double time = 0;  ///< at the end of the step
  /// The part of the body force a known pressure balances (HydrostaticSplit): the predictor leaves it out.
  Vec<D> balanced{};
  std::vector<char> prescribed;  ///< fluid whose velocity a boundary sets: viscosity, pressure and shifting pass it by
  std::vector<double> n_star;    ///< number density at r* (density kernel), for `in_ppe` particles (0 for the others)
  std::vector<double> n_surface;  ///< at the surface kernel's radius, when it differs (`in_ppe` particles)
  /// The number density at the surface kernel's radius: n_surface, or n_star where the radii are the same.
  [[nodiscard]] const std::vector<double>& n_at_surface_radius() const { return n_surface.empty() ? n_star : n_surface; }
  std::vector<double> n_source;  ///< the density the source reads in place of n_star (empty: n_star)
  std::vector<double> div;       ///< div u* (with higher_order_source: -(d/n_rate) Dn/Dt at r*, u*); `in_ppe` only
  std::vector<double> n_start;   ///< scratch: number density at r^n (error_compensating_source)
  std::vector<double> ecs;       ///< the error-compensating source term, from r^n, u^n (empty: off)
  std::vector<char> surface;     ///< free-surface particles
  std::vector<double> source;    ///< right-hand side of lap P = source
  std::vector<char> held;        ///< particles held at a given pressure in the PPE (empty: the free surface)
  std::vector<double> held_value;       ///< the pressure they are held at (empty: 0)
  /// @{ The Laplacian weight of each unknown's empty support and the unknown's value there (ContinuousFreeSurface;
  /// empty: none)
  std::vector<double> open_weight, open_value;  /// @}
  std::vector<double> pressure_offset;  ///< the PPE solves for P - offset (empty: for P)
  bool surface_own_reference = false;   ///< free-surface particles take their own P as the gradient's reference
  std::vector<char> carriers;    ///< particles whose pressure the gradient sees
  /// @{ scratch: the velocity's Laplacian and the pressure's gradient by axis, made for the `advanced` particles only
  std::array<std::vector<double>, D> lap_u, grad_p;  /// @}
  std::array<std::vector<double>, D> stabilisation;  ///< scratch: the dynamic stabilisation's velocity changes
  std::vector<char> advanced;  ///< scratch: the fluid the step moves itself (not prescribed)
  std::vector<char> in_ppe;    ///< scratch: fluid and walls, the particles n*, div u* and the source are made for
  std::vector<double> residual;  ///< scratch: P - offset for the corrector
};
using StepFields = BasicStepFields<2>;  ///< a 2-D step's fields

/// max |u|^2 over the fluid particles.
template <int D>
double max_fluid_speed_squared(const BasicParticles<D>& particles);

template <int D>
class BasicSimulation;

/// What a hook sees: the simulation (configuration, domain, kernels, grid and neighbour lists), its particles and
/// this step's fields.
template <int D>
struct BasicStepContext {
  const BasicSimulation<D>& sim;  ///< the simulation, read-only
  BasicParticles<D>& particles;   ///< its particles, for the component to change
  BasicStepFields<D>& fields;     ///< this step's fields
};
using StepContext = BasicStepContext<2>;  ///< a 2-D hook's view

/// A scene-specific treatment hooked into the step. Each hook runs at a named point, components in the order they
/// were added; a component overrides the hooks it needs (docs/step.md lists which one each uses).
template <int D>
class BasicStepComponent {
 public:
  using StepContext = BasicStepContext<D>;  ///< what a hook sees
  virtual ~BasicStepComponent() = default;  ///< components are owned through this base (Simulation::add)
  virtual void before_predictor(StepContext&) {}   ///< neighbours of r^n found, grid binned at r^n
  virtual void after_predictor(StepContext&) {}    ///< particles at r*, fields.time the new time
  virtual void before_projection(StepContext&) {}  ///< before n* and div u*
  virtual void before_source(StepContext&) {}      ///< n*, div u* and the free surface known
  virtual void before_assembly(StepContext&) {}    ///< source known
  virtual void after_pressure(StepContext&) {}     ///< pressures scattered, dummies set, carriers known
  /// Velocities and positions at n+1, the neighbour lists of r* still in place (on ranks, the halo's copies too, at
  /// n+1): where particle shifting moves particles by their neighbours.
  virtual void shift_positions(StepContext&) {}
  virtual void after_corrector(StepContext&) {}    ///< velocities and positions at n+1, final (on ranks: own only)
  /// How far from a particle it sets the component reads other particles, where that is beyond the kernels' radii
  /// [m] (0: within them): a distributed step's halo must reach as far.
  [[nodiscard]] virtual double reach(const BasicSimulation<D>&) const { return 0.0; }
  /// Flags the particles beyond the fluid and the walls whose rows of the neighbour lists the component reads (a
  /// structure's dummies, say): the step searches the rows of those three only, and leaves a dummy's row empty.
  virtual void mark_rows_read(const BasicParticles<D>& particles, std::span<char> rows) const {
    (void)particles;
    (void)rows;
  }
  /// What a checkpoint must hold of this component for a restored run to continue bitwise: what changes from step to
  /// step (counters, a structure's deformation), not what it was made with (default: nothing). restore_state() takes
  /// it back into the component of a simulation built as this one was (Simulation::restore).
  [[nodiscard]] virtual nlohmann::json save_state() const { return nullptr; }
  virtual void restore_state(const nlohmann::json& state) { (void)state; }  ///< see save_state()
  /// The state of one process that takes over what the processes of `parts` held (a restart on another number of
  /// processes): by default the first part's; counts add up. No parts: a process that starts with none of it.
  [[nodiscard]] virtual nlohmann::json merge_states(const std::vector<const nlohmann::json*>& parts) const {
    return parts.empty() ? nlohmann::json() : *parts.front();
  }
  /// Whether this component reads what `other` writes at a hook they share, and so must run after it: the order
  /// Simulation::add checks (the configuration's own components come first).
  [[nodiscard]] virtual bool runs_after(const BasicStepComponent& other) const {
    (void)other;
    return false;
  }
};
using StepComponent = BasicStepComponent<2>;  ///< a 2-D component

/// The stages of a step, in order (docs/step.md). Simulation::step runs them all; Simulation::advance_to runs them
/// up to one, so that a caller can stop after the assembly. Each stage that begins with an exchange begins with it
/// (a no-op on one process), and processes agree after every stage whether one of them failed.
enum class Stage {
  exchange,           ///< the exchange's begin_step (on ranks: migration and halo)
  time_step,          ///< dt from dt_max, the CFL and viscous limits; this step's fields reset
  neighbors,          ///< grid binned and neighbours found at r^n; hook before_predictor
  predictor,          ///< viscosity and body force give u*, r*; hooks after_predictor, before_projection
  neighbors_at_star,  ///< copies take r*, u*; neighbours at r*
  projection,         ///< n*, div u* and the free surface
  free_surface,       ///< copies take the free-surface flags; hook before_source
  source,             ///< copies take the flags again; the mixed source; hook before_assembly
  assembly,           ///< the PPE
  solve,              ///< the pressure solve (its special cases decided over every process), pressures scattered
  pressure_boundary,  ///< free-surface particles' held pressures, dummies' pressures, the carriers
  corrector,          ///< copies take pressures and carriers; hook after_pressure; u^{n+1}, r^{n+1}
  shifting,           ///< copies take r^{n+1}, u^{n+1}; hook shift_positions
  end_corrector,      ///< copies dropped; hook after_corrector
  finish,             ///< the largest speed, time and step count advanced, the stability guard
};
/// The stage's name, as in the enum.
const char* to_string(Stage stage);

/// A run: particles in a D-dimensional domain, stepped by the semi-implicit MPS step with the components added to it,
/// on one process or, given a RankExchange (mps/parallel/rank_exchange.hpp), on the ranks of an MPI communicator.
template <int D>
class BasicSimulation {
 public:
  using Particles = BasicParticles<D>;        ///< its particles
  using Domain = BasicDomain<D>;              ///< its domain
  using StepComponent = BasicStepComponent<D>;  ///< its components' base
  using StepContext = BasicStepContext<D>;    ///< what a component's hook sees
  using StepFields = BasicStepFields<D>;      ///< what the stages hand on
  using CellGrid = BasicCellGrid<D>;          ///< its cell grid
  using Stencil = BasicStencil<D>;            ///< an operator's view of it
  using Exchange = BasicExchange<D>;          ///< its exchange policy's base

  /// Validates the configuration and the particles (throws std::invalid_argument naming what is wrong), makes the
  /// pressure solver from config.solver and adds the components the configuration asks for. One process.
  BasicSimulation(Particles particles, Domain domain, SimulationConfig config);
  /// Same, with a pressure solver of the caller's making (config.solver is then not read).
  BasicSimulation(Particles particles, Domain domain, SimulationConfig config, std::unique_ptr<LinearSolver> solver);
  /// Same, on the processes of `exchange` (e.g. a RankExchange): every process passes the same scene, each keeps the
  /// particles it owns, and the pressure solver is made from config.solver for the exchange's communicator.
  /// Throws std::invalid_argument for what the exchange cannot run. Collective.
  BasicSimulation(Particles particles, Domain domain, SimulationConfig config, std::unique_ptr<Exchange> exchange);

  /// Advances one step (the rest of one advance_to began) or throws SimulationError and keeps the previous state;
  /// on several processes every one throws, with the message of the first that failed.
  const StepInfo& step();
  /// Runs the stages of the step up to and including `last` (opening a step if none is open) and leaves the step
  /// open there: its fields, last_ppe() and the particles are as that stage left them; step() completes it. A
  /// failure rolls back as step() does. Throws std::logic_error for a stage this step has passed.
  void advance_to(Stage last);
  /// The run's state between steps for a checkpoint (write_checkpoint, docs/restart.md): the particles, the step
  /// count, time and last step's record, the phase times, each component's save_state(), the solver's and the
  /// exchange's. On ranks collective: rank 0 gets every rank's part ({"ranks": P, "parts": [...]}), the others null.
  /// Throws std::logic_error while a step is open.
  [[nodiscard]] nlohmann::json checkpoint() const;
  /// Continues from `state`, a checkpoint() of a simulation built as this one was (the same scene, components in the
  /// same order, the same configuration; every process passes the whole checkpoint). On as many processes as the
  /// checkpointed run the steps that follow repeat its steps bitwise when it was taken at a checkpoint_exact() step.
  /// On another number (one process from ranks, ranks from one process, 2 from 3, ...) the particles are distributed
  /// afresh, components merge their parts (merge_states) and the solver starts afresh: the run then agrees with the
  /// uninterrupted one within the solver's tolerance. Throws std::runtime_error naming what does not match
  /// (dimension, particle fields, components) and std::logic_error while a step is open. Collective on ranks.
  void restore(const nlohmann::json& state);
  /// Replaces the particles between steps with an edited copy of them (particles() changed and handed back; Python's
  /// `sim.particles = p`): the same particles in the same order (their ids), with any positions, velocities,
  /// pressures (the next solve's first guess), kinds and groups. The solver drops a kept AMG hierarchy (the unknowns
  /// may change). Throws std::invalid_argument, leaving the run as it was, for another count or order, a field of
  /// another length, a non-finite value, a particle outside the domain or no fluid left; std::logic_error while a step
  /// is open or on MPI ranks (each process holds only its own particles).
  void set_particles(Particles particles);
  /// Whether a checkpoint taken now continues bitwise: the solver keeps no setup made from an earlier matrix, or the
  /// next step renumbers the unknowns (reorder_every; on ranks the placements, migrate_every), which sets it up afresh
  /// anyway.
  [[nodiscard]] bool checkpoint_exact() const;
  /// The stage the open step runs next (Stage::exchange when no step is open).
  [[nodiscard]] Stage next_stage() const { return static_cast<Stage>(next_stage_); }

  /// Adds a component (mps/step/components.hpp, or a scene's own) after those already there; returns it. Throws
  /// std::invalid_argument when one already there must run after it (StepComponent::runs_after).
  template <class Component, class... Args>
  Component& add(Args&&... args) {
    auto component = std::make_unique<Component>(std::forward<Args>(args)...);
    check_order(*component);
    Component& added = *component;
    components_.push_back(std::move(component));
    return added;
  }
  /// @{ The first component of that type (for which `accept` holds), or nullptr.
  template <class Component>
  [[nodiscard]] const Component* find() const {
    return find<Component>([](const Component&) { return true; });
  }
  template <class Component, class Accept>
  [[nodiscard]] const Component* find(Accept&& accept) const {
    for (const auto& c : components_)
      if (const auto* found = dynamic_cast<const Component*>(c.get()); found != nullptr && accept(*found)) return found;
    return nullptr;
  }
  /// @}

  [[nodiscard]] const Particles& particles() const { return particles_; }  ///< the particles now
  /// Particles [0, owned) are this process's own; during a step on ranks the rest are halo copies of other processes'
  /// particles (serially: all).
  [[nodiscard]] std::size_t owned_particles() const { return exchange_->owned(particles_); }
  [[nodiscard]] const Domain& domain() const { return domain_; }           ///< the domain
  [[nodiscard]] const SimulationConfig& config() const { return config_; }  ///< the configuration
  [[nodiscard]] const LinearSolver& solver() const { return *solver_; }    ///< the pressure solver
  [[nodiscard]] const Exchange& exchange() const { return *exchange_; }    ///< the exchange policy
  [[nodiscard]] const StepInfo& last_step() const { return info_; }        ///< what the last step did
  [[nodiscard]] const PhaseTimes& times() const { return times_; }         ///< time per phase, all steps so far
  [[nodiscard]] double time() const { return info_.time; }                 ///< simulated time [s]
  /// @{ the kernels at the configured radii: number density (source), free surface, gradient, Laplacian
  [[nodiscard]] const Kernel& density_kernel() const { return k_density_; }
  [[nodiscard]] const Kernel& surface_kernel() const { return k_surface_; }
  [[nodiscard]] const Kernel& gradient_kernel() const { return k_gradient_; }
  [[nodiscard]] const Kernel& laplacian_kernel() const { return k_laplacian_; }
  /// @}
  /// The PPE's Laplacian: the Laplacian kernel, with the higher-order weight when config().higher_order_laplacian.
  [[nodiscard]] const Kernel& pressure_kernel() const { return k_pressure_; }
  /// n* of the last step: of the fluid and wall particles (0 for dummies and ghosts, which hold no PPE row)
  [[nodiscard]] const std::vector<double>& number_density() const { return fields_.n_star; }
  [[nodiscard]] const StepFields& fields() const { return fields_; }  ///< the fields of the last (or open) step
  /// The last step's PPE (matrix, rhs, maps); on ranks this process's part, as assembled locally.
  [[nodiscard]] const PpeSystem& last_ppe() const { return exchange_->ppe(); }
  [[nodiscard]] const CellGrid& grid() const { return grid_; }  ///< the cell grid, binned at the last search
  /// Neighbours at r* covering kernel k (valid from before_source on): one list at the largest radius, one at the
  /// largest of the smaller ones. Rows of the fluid and walls only, and of particles a component marks
  /// (BasicStepComponent::mark_rows_read); the other rows are empty.
  [[nodiscard]] const NeighborList& neighbors_at_star(const Kernel& k) const {
    return k.re <= small_radius_ ? close_star_ : near_star_;
  }
  /// Neighbours at r^n within the Laplacian's radius, and perhaps pairs a little beyond it, which every sum skips by
  /// its kernel (valid from before_predictor to before_projection: the list at r* is later found into the same memory).
  /// A component that measures these pairs at r* (ParticleCollision) sees the pairs beyond too: see neighbor_skin.
  [[nodiscard]] const NeighborList& neighbors_now() const { return near_star_; }  ///< rows as neighbors_at_star's
  /// The largest of `value` over the processes a step runs on (one process: `value`). Collective on ranks.
  [[nodiscard]] double max_over_ranks(double value) const { return exchange_->max(value); }

 private:
  // A null solver is made from config.solver for the exchange's context.
  BasicSimulation(Particles particles, Domain domain, SimulationConfig config, std::unique_ptr<LinearSolver> solver,
                  std::unique_ptr<Exchange> exchange);
  void check_order(const StepComponent& added) const;
  void run_stage(Stage stage);
  [[nodiscard]] std::string describe_failure(std::exception_ptr error) const;
  void roll_back();
  [[nodiscard]] double components_reach() const;
  [[nodiscard]] std::string dt_advice() const;
  [[nodiscard]] double choose_dt(std::string& limit) const;
  void run(void (StepComponent::*hook)(StepContext&));
  // The stages' work, in order.
  void begin_exchange();
  void choose_time_step();
  void mark_rows_read();
  void find_neighbors_now();
  [[nodiscard]] bool fringe_covers_moves() const;
  void error_compensation();
  void predict();
  void mark_in_ppe();
  void mark_advanced();
  void explicit_viscous_predictor();
  void implicit_viscous_predictor();
  void find_neighbors_at_star();
  void number_density_and_divergence();
  void detect_surface();
  void compute_source();
  void assemble();
  void solve();
  void set_pressure_boundary_values();
  void correct();
  void finish_step();
  void check_guard() const;

  Particles particles_;
  StepInfo info_;
  StepFields fields_;
  std::unique_ptr<Exchange> exchange_;
  std::unique_ptr<LinearSolver> solver_;
  Domain domain_;
  SimulationConfig config_;
  std::unique_ptr<LinearSolver> viscosity_solver_;  // only with implicit_viscosity
  Kernel k_density_, k_surface_, k_gradient_, k_laplacian_, k_pressure_;
  // The neighbour skin [m]; 0 on ranks, where the list at r^n is narrower than the largest radius, and where a
  // periodic axis is too short for the wider cells.
  double skin_ = 0;
  CellGrid grid_;
  std::vector<std::unique_ptr<StepComponent>> components_;
  PhaseTimes times_;
  // The lists at r^n and at the wider r* radius share one buffer: their uses do not overlap, and a list at 4.1 l0
  // costs about 200 bytes a particle.
  NeighborList near_star_, close_star_;
  double small_radius_ = 0;
  // The pairs within the skin beyond near_star_'s radius at the last search at r*, and where the particles were then:
  // while none has moved half the skin since, every pair now within that radius is in near_star_ + fringe_, and the
  // next step widens near_star_ by the fringe instead of searching (every sum skips pairs beyond its kernel).
  NeighborList fringe_;
  std::array<std::vector<double>, D> searched_at_;
  std::vector<char> searched_rows_;  // the rows the last search at r* made, to carry its list over
  std::vector<char> rows_read_;      // the rows some stage reads: fluid, walls, those components mark
  bool fringe_ready_ = false;
  int next_stage_ = 0;      // of the open step (0: none open)
  Particles before_step_;   // the state a failed step rolls back to
  StepInfo info_before_;
  struct ViscousSystem {
    std::vector<int> row;             // particle -> row of the fluid system, or -1
    std::vector<std::size_t> fluid;   // row -> particle
    CsrMatrix matrix;                 // I - dt nu L over the fluid
    std::array<std::vector<double>, D> b, u;  // right-hand sides and solutions by component
  } viscous_;  // implicit viscosity's system, kept between steps for its memory
};

using Simulation = BasicSimulation<2>;   ///< a 2-D run
using Simulation3 = BasicSimulation<3>;  ///< a 3-D run

extern template class BasicSimulation<2>;
extern template class BasicSimulation<3>;

}  // namespace mps
