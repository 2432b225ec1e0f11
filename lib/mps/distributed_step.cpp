#include "mps/distributed_step.hpp"

#include <mpi.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <stdexcept>
#include <string>
#include <utility>

#include "mps/components.hpp"

namespace mps {
namespace {

using Clock = std::chrono::steady_clock;

double seconds_since(Clock::time_point start) { return std::chrono::duration<double>(Clock::now() - start).count(); }

SolverContext on(int comm) {
  SolverContext context;
  context.mpi_comm = comm;
  return context;
}

// The migration puts each rank's particles in id order; reordering by cell would shuffle owned and halo copies.
SimulationConfig without_reordering(SimulationConfig config) {
  config.reorder_every = 0;
  return config;
}

// A right-hand side of zeros over all ranks has the solution zero (Simulation::solve's special case): an iterative
// solver measuring its residual relative to |b| could not confirm it.
class ZeroSolution : public LinearSolver {
 public:
  SolveReport solve(const CsrMatrix&, std::span<const double>, std::span<double> x) override {
    std::fill(x.begin(), x.end(), 0.0);
    return {};
  }
  [[nodiscard]] std::string spec() const override { return "zero"; }
};

}  // namespace

template <int D>
BasicDistributedSimulation<D>::BasicDistributedSimulation(Particles scene, Domain domain, SimulationConfig config,
                                                          int comm, DistributedOptions options)
    : BasicSimulation<D>(std::move(scene), domain, without_reordering(config), make_solver(config.solver, on(comm))),
      comm_(comm), options_(options) {
  const MPI_Comm c = MPI_Comm_f2c(comm_);
  MPI_Comm_rank(c, &rank_);
  MPI_Comm_size(c, &ranks_);
  refuse_unsupported();
  if (std::isnan(options_.rebalance_threshold))
    throw std::invalid_argument("distributed simulation: rebalance_threshold is NaN; give the largest rank's particle "
                                "count over the mean to tolerate before new cuts (default 1.01)");
  const SimulationConfig& cfg = this->config();
  kernel_reach_ = cfg.l0 * std::max({cfg.radius_density, cfg.radius_surface, cfg.radius_gradient, cfg.radius_laplacian});
  halo_radius_ = kernel_reach_ + 2.0 * cfg.max_displacement * cfg.l0;
  // Every rank validated the whole scene; rank 0's copy is the one distributed.
  Particles& p = this->particles_;
  if (rank_ != 0) p = Particles{};
  const auto start = Clock::now();
  partition_.emplace(comm_);
  const RcbPartition::Placement placed = partition_->place(p, options_.rebalance_threshold);
  stats_.kept_imbalance = stats_.imbalance = stats_.max_imbalance = placed.imbalance;
  count(migrate_particles(p, placed.destination, comm_));
  stats_.migrate_seconds += seconds_since(start);
}

template <int D>
void BasicDistributedSimulation<D>::refuse_unsupported() const {
  const SimulationConfig& c = this->config();
  const Domain& d = this->domain();
  auto refuse = [](const std::string& what) {
    throw std::invalid_argument("distributed simulation: " + what + " does not run on several ranks yet; run it "
                                "serially (mps::Simulation)");
  };
  const auto periodic = d.periodic();
  if (std::any_of(periodic.begin(), periodic.end(), [](bool b) { return b; }))
    refuse("a periodic domain (a halo copy would need its periodic image's shift)");
  if (c.implicit_viscosity) refuse("implicit viscosity (its viscous system is solved over all particles at once)");
  if (c.initial_reference_density) refuse("initial_reference_density (a t = 0 mean over the whole domain)");
  if (this->template find<BasicInitialReferenceDensity<D>>()) refuse("InitialReferenceDensity (a t = 0 mean over the whole domain)");
}

template <int D>
void BasicDistributedSimulation<D>::count(const ExchangeStats& e) {
  stats_.messages_sent += static_cast<std::size_t>(e.messages_sent);
  stats_.bytes_sent += e.bytes_sent;
}

template <int D>
template <class Field>
void BasicDistributedSimulation<D>::refresh(Field&& field) {
  halo_->refresh(std::forward<Field>(field));
  ++stats_.refreshes;
  count(halo_->last_refresh());
}

// Components a scene added after construction are refused here, on every rank alike.
template <int D>
void BasicDistributedSimulation<D>::check_components() const { refuse_unsupported(); }

template <int D>
void BasicDistributedSimulation<D>::begin_step() {
  ++stats_.steps;
  migrate_to_partition();
  const auto start = Clock::now();
  // Components are added after construction: their reach is read each step.
  halo_radius_ = std::max(kernel_reach_, this->components_reach()) + 2.0 * this->config().max_displacement * this->config().l0;
  halo_.emplace(this->particles_, this->domain(), halo_radius_, comm_);
  stats_.halo_copies += halo_->copies();
  count(halo_->setup());
  stats_.halo_seconds += seconds_since(start);
}

// The kept cuts' boxes, or new cuts when the load has drifted past the threshold; one migration either way.
template <int D>
void BasicDistributedSimulation<D>::migrate_to_partition() {
  const auto start = Clock::now();
  const RcbPartition::Placement placed = partition_->place(this->particles_, options_.rebalance_threshold);
  const double placing = seconds_since(start);
  if (placed.repartitioned) {
    ++stats_.repartitions;
    stats_.repartition_seconds += placing;
  } else {
    stats_.assign_seconds += placing;
  }
  stats_.kept_imbalance = placed.kept_imbalance;
  stats_.imbalance = placed.imbalance;
  stats_.max_imbalance = std::max(stats_.max_imbalance, placed.imbalance);
  const ExchangeStats moved = migrate_particles(this->particles_, placed.destination, comm_);
  stats_.migrated += moved.particles_sent;
  count(moved);
  stats_.migrate_seconds += seconds_since(start);
}

template <int D>
double BasicDistributedSimulation<D>::max_over_ranks(double value) const {
  MPI_Allreduce(MPI_IN_PLACE, &value, 1, MPI_DOUBLE, MPI_MAX, MPI_Comm_f2c(comm_));
  return value;
}

template <int D>
std::size_t BasicDistributedSimulation<D>::owned_particles() const {
  return halo_ ? halo_->owned() : this->particles_.size();
}

// A ghost turned fluid after the predictor (a pushing plate's column) was in no halo: its copies join now, and the
// per-particle fields already sized take their owners' entries for them.
template <int D>
void BasicDistributedSimulation<D>::share_predicted() {
  const ExchangeStats added = halo_->add_activated(this->particles_);
  stats_.activated_copies += added.particles_received;
  count(added);
  const bool any_added = max_over_ranks(static_cast<double>(added.particles_received)) > 0.0;
  refresh(this->particles_);
  if (!any_added) return;
  this->fields_.prescribed.resize(this->particles_.size(), 0);
  refresh(std::span<char>(this->fields_.prescribed));
}

template <int D>
void BasicDistributedSimulation<D>::share_surface() { refresh(std::span<char>(this->fields_.surface)); }

template <int D>
void BasicDistributedSimulation<D>::assemble() {
  const BasicStepFields<D>& f = this->fields_;
  const double screening = this->config().sound_speed * f.dt;
  const Kernel& k = this->laplacian_kernel();
  assemble_distributed_ppe(*halo_, {this->particles_, this->domain(), this->neighbors_at_star(k), k}, f.held.empty() ? f.surface : f.held,
                           f.source, f.held_value, screening > 0.0 ? 1.0 / (screening * screening) : 0.0,
                           distributed_ppe_);
  this->info_.unknowns = static_cast<std::size_t>(distributed_ppe_.global_rows);
  long long surface = 0;
  for (std::size_t i = 0; i < halo_->owned(); ++i) surface += f.surface[i];
  MPI_Allreduce(MPI_IN_PLACE, &surface, 1, MPI_LONG_LONG, MPI_SUM, MPI_Comm_f2c(comm_));
  this->info_.free_surface = static_cast<std::size_t>(surface);
  this->info_.floating_groups = distributed_ppe_.closed.size();
}

template <int D>
void BasicDistributedSimulation<D>::solve() {
  Particles& p = this->particles_;
  const BasicStepFields<D>& f = this->fields_;
  const MPI_Comm c = MPI_Comm_f2c(comm_);
  const PpeSystem& local = distributed_ppe_.local;
  // Simulation::solve's two special cases, decided over all ranks: a zero right-hand side, and no previous pressure
  // (or no warm start), which starts from P - offset = 0 rather than from -offset.
  int zero_rhs = std::all_of(distributed_ppe_.rhs.begin(), distributed_ppe_.rhs.end(), [](double b) { return b == 0.0; });
  int no_previous = std::all_of(local.particle.begin(), local.particle.begin() + static_cast<std::ptrdiff_t>(distributed_ppe_.rows()),
                                [&](int i) { return p.p[static_cast<std::size_t>(i)] == 0.0; });
  MPI_Allreduce(MPI_IN_PLACE, &zero_rhs, 1, MPI_INT, MPI_LAND, c);
  MPI_Allreduce(MPI_IN_PLACE, &no_previous, 1, MPI_INT, MPI_LAND, c);
  if (no_previous || !this->config().warm_start)
    for (std::size_t r = 0; r < distributed_ppe_.rows(); ++r) {
      const auto i = static_cast<std::size_t>(local.particle[r]);
      p.p[i] = f.pressure_offset.empty() ? 0.0 : f.pressure_offset[i];
    }
  ZeroSolution zero;
  LinearSolver& solver = zero_rhs ? static_cast<LinearSolver&>(zero) : *this->solver_;
  this->info_.solve = solve_distributed_ppe(*halo_, distributed_ppe_, solver, p, this->config().clamp_negative_pressure,
                                      f.pressure_offset);
}

template <int D>
void BasicDistributedSimulation<D>::share_pressure_boundary() {
  refresh(std::span<double>(this->particles_.p));
  refresh(std::span<char>(this->fields_.carriers));
}

// Shifting moves a particle by its neighbours' positions and velocities at n+1.
template <int D>
void BasicDistributedSimulation<D>::share_corrected() { refresh(this->particles_); }

template <int D>
void BasicDistributedSimulation<D>::end_corrector() {
  halo_->remove(this->particles_);
  halo_.reset();
}

template <int D>
void BasicDistributedSimulation<D>::check_guard() const {
  std::string reason;
  try {
    BasicSimulation<D>::check_guard();
  } catch (const SimulationError& e) {
    reason = e.what();
  }
  const MPI_Comm c = MPI_Comm_f2c(comm_);
  int first = reason.empty() ? ranks_ : rank_;
  MPI_Allreduce(MPI_IN_PLACE, &first, 1, MPI_INT, MPI_MIN, c);
  if (first == ranks_) return;
  int length = static_cast<int>(reason.size());
  MPI_Bcast(&length, 1, MPI_INT, first, c);
  reason.resize(static_cast<std::size_t>(length));
  MPI_Bcast(reason.data(), length, MPI_CHAR, first, c);
  throw SimulationError("rank " + std::to_string(first) + " of " + std::to_string(ranks_) +
                        " (particle numbers are that rank's): " + reason);
}

template <int D>
typename BasicDistributedSimulation<D>::Particles BasicDistributedSimulation<D>::gather() const {
  Particles all = this->particles();
  const std::vector<int> to_root(all.size(), 0);
  migrate_particles(all, to_root, comm_);
  return all;
}

template class BasicDistributedSimulation<2>;
template class BasicDistributedSimulation<3>;

}  // namespace mps
