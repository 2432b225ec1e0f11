#pragma once
/// \file
/// The exchange policy of a step on the ranks of an MPI communicator: each rank owns the particles of one RCB box
/// and runs the step's stages over its own particles and halo copies of its neighbours', exchanging at the points
/// mps/step/exchange.hpp lists (docs/scaling.md). The same scene gives the same answer on any rank count, to within the
/// pressure solver's tolerance (tests/mpi/test_distributed_step.cpp).
#include <cstddef>
#include <optional>
#include <string>
#include <vector>

#include "mps/parallel/distributed.hpp"
#include "mps/step/exchange.hpp"

namespace mps {

/// What the rank exchange moved, summed over the steps so far (this rank's view).
struct DistributedStepStats {
  std::size_t steps = 0;            ///< steps begun
  std::size_t migrated = 0;         ///< particles this rank sent to another at the start of a step
  std::size_t halo_copies = 0;      ///< halo copies this rank received when building each step's halo
  std::size_t activated_copies = 0; ///< copies it received of particles turned from ghosts to fluid within a step
  std::size_t refreshes = 0;        ///< the step's own halo refreshes (the PPE's and hypre's not counted)
  std::size_t messages_sent = 0;    ///< point-to-point messages of the migrations, halos, new fluid's copies and refreshes
  std::size_t bytes_sent = 0;       ///< their payload bytes
  double migrate_seconds = 0;       ///< wall-clock time in the partition (assignment or repartition) and migration
  double halo_seconds = 0;          ///< wall-clock time building halos
  std::size_t repartitions = 0;     ///< new RCB cuts made at the start of a step (the constructor's not counted)
  double assign_seconds = 0;        ///< of migrate_seconds: placing particles in the kept boxes, imbalance measured
  double repartition_seconds = 0;   ///< of migrate_seconds: the new cuts (Zoltan's RCB) and their imbalance
  double kept_imbalance = 1;        ///< this step's load imbalance had the cuts been kept (before any repartition)
  double imbalance = 1;             ///< this step's load imbalance (largest rank's particles / mean), all ranks alike
  double max_imbalance = 1;         ///< the largest `imbalance` over the steps so far
  std::size_t placements = 0;       ///< steps that placed and migrated the particles (every migrate_every-th)
  std::size_t ghosts_moved = 0;     ///< ghosts this rank sent to the rank of their box between placements
};

/// How the rank exchange spreads its particles.
struct DistributedOptions {
  /// New RCB cuts when the kept ones would give the largest rank more than this many times the mean load.
  /// 1 or below: new cuts every step; +infinity: never after the first. Chosen from the classic dam break on 2 ranks
  /// (docs/scaling.md, "Keeping the cuts"): new cuts cost about 1 % of a step, 1 % of imbalance costs up to 1 % of a
  /// step, every step; of the thresholds tried (1 to 1.10) this one cost least, about half what new cuts every step
  /// did.
  double rebalance_threshold = 1.01;
  /// The load of a particle of each kind (fluid, wall, dummy, ghost) that the cuts balance (RcbPartition). Every kind
  /// alike balances the particle count, right where fluid dominates (the 2-D scenes); the 3-D dam break's walls and
  /// dummies outnumber its fluid and it weighs them by their estimated cost (docs/scaling.md).
  RcbPartition::KindWeights kind_weights = {1.0, 1.0, 1.0, 1.0};
  /// Steps between placements and migrations (1: every step). In between, a particle that crossed a cut stays with
  /// its rank (the halo follows where each rank's particles are, not the cuts), so no rank's unknowns change by
  /// migration and `auto` keeps its AMG hierarchy; only ghosts go to their box's rank every step. 20: the default of
  /// SimulationConfig::reorder_every, so that the PPE's rows are renumbered on the same steps (docs/scaling.md).
  int migrate_every = 20;
};

/// A step's exchange over the ranks of `comm` (MPI_Comm_c2f of the communicator), given to a Simulation:
///
///     auto ranks = std::make_unique<mps::RankExchange>(comm);
///     mps::RankExchange& exchange = *ranks;
///     mps::Simulation sim(scene, domain, config, std::move(ranks));  // every rank passes the same scene
///
/// Rank 0's copy of the scene is distributed by RCB. Every options.migrate_every-th step starts by placing the
/// particles in the kept RCB boxes (RcbPartition::place: new cuts when the load imbalance exceeds
/// options.rebalance_threshold) and the migration of those that crossed a cut; every step then builds a halo out to the
/// step's reach (the largest kernel radius or StepComponent::reach, plus twice the guard's max_displacement). The
/// copies are refreshed after the predictor (whole particles; particles the predictor's components turned from ghosts
/// to fluid, a pushing plate's column, are first copied to the ranks whose halo they fall in, appended after the other
/// copies: a component keeping per-particle state from before_predictor must allow for them), after the free surface
/// (flags), by the distributed PPE, after the pressure boundary values (pressures, carriers) and after the corrector
/// (whole particles, for particle shifting). Between steps the simulation's particles() are this rank's own: those that
/// stayed in their order, those that arrived after them by id, and every config.reorder_every steps all in the
/// neighbour grid's cell order; gather() collects them all on rank 0, sorted by id. The step's special cases and
/// failures are decided over all ranks: one rank's failure ends the step on every rank with that rank's message.
///
/// Refused (std::invalid_argument, naming the cause): options.migrate_every below 1, a NaN rebalance threshold,
/// periodic domains, implicit viscosity (its global solve) and the initial reference density (a t = 0 mean over the
/// domain); also a pressure solver that does not run on the communicator (the serial backends on more than one rank).
template <int D>
class BasicRankExchange final : public BasicExchange<D> {
 public:
  using typename BasicExchange<D>::Particles;
  /// Collective over `comm`.
  explicit BasicRankExchange(int comm, DistributedOptions options = {});

  /// Every rank's particles (`own`: this rank's, as the simulation holds them between steps), on rank 0 sorted by id
  /// (empty on the other ranks). Collective; call between steps.
  [[nodiscard]] Particles gather(const Particles& own) const;
  [[nodiscard]] int comm() const { return comm_; }  ///< the communicator's Fortran handle
  [[nodiscard]] int rank() const { return rank_; }  ///< this rank in the communicator
  [[nodiscard]] int ranks() const { return ranks_; }  ///< ranks in the communicator
  /// The halo's radius of the latest step: the step's reach [m].
  [[nodiscard]] double halo_radius() const { return halo_radius_; }
  [[nodiscard]] const DistributedStepStats& stats() const { return stats_; }  ///< exchanges so far
  [[nodiscard]] const DistributedOptions& options() const { return options_; }  ///< as constructed

  /// @{ The policy (mps/step/exchange.hpp)
  [[nodiscard]] SolverContext solver_context() const override;
  void check(const BasicSimulation<D>& sim) const override;
  void distribute(Particles& particles) override;
  [[nodiscard]] bool reorders() const override { return false; }
  [[nodiscard]] bool keeps_indices() const override { return false; }  ///< the halo is made anew each step
  void begin_step(Particles& particles, const BasicDomain<D>& domain, double reach, double cell_size) override;
  void share_predicted(Particles& particles, std::vector<char>& prescribed) override;
  void share_flags(std::span<char> flags) override;
  PpeCounts assemble(const BasicStencil<D>& laplacian, std::span<const char> held, std::span<const double> source,
                     std::span<const double> held_value, double shift, OpenSupport open, PpeRows rows) override;
  [[nodiscard]] const PpeSystem& ppe() const override { return ppe_.local; }
  [[nodiscard]] OwnPpeRows own_rows() const override;
  SolveReport solve(LinearSolver& solver, Particles& particles, bool from_zero, bool clamp_negative,
                    std::span<const double> offset) override;
  void share_pressure(std::span<double> pressure, std::span<char> carriers) override;
  void share_particles(Particles& particles) override;
  void end_step(Particles& particles) override;
  void abandon_step() override;
  [[nodiscard]] std::size_t owned(const Particles& particles) const override;
  [[nodiscard]] double max(double value) const override;
  [[nodiscard]] bool all(bool value) const override;
  [[nodiscard]] long long sum(long long value) const override;
  /// The first failing rank's message, prefixed "rank r of P (particle numbers are that rank's): ".
  [[nodiscard]] std::string first_failure(const std::string& failure) const override;
  [[nodiscard]] nlohmann::json gather_states(nlohmann::json own) const override;
  [[nodiscard]] const nlohmann::json& own_part(const std::vector<const nlohmann::json*>& parts) const override;
  [[nodiscard]] int processes() const override { return ranks_; }  ///< the ranks
  [[nodiscard]] bool first_process() const override { return rank_ == 0; }  ///< rank 0
  /// The kept cuts' input (each rank's particles' positions, ids and kinds when the cuts were made), the step count
  /// and whether the last migration renumbered; restore_state() makes the same cuts again (collective).
  [[nodiscard]] nlohmann::json save_state() const override;
  void restore_state(const nlohmann::json& state, int steps) override;
  /// the steps that place and migrate (migrate_every): the solver is told they renumber
  [[nodiscard]] bool renumbers_after(int steps, const SimulationConfig& config) const override;
  /// @}

 private:
  void count(const ExchangeStats& e);
  template <class Field>
  void refresh(Field&& field);  // the halo's refresh of a field or of whole particles, counted
  void migrate_to_partition(Particles& particles);
  void send_ghosts_home(Particles& particles);
  ExchangeStats migrate_keeping_order(Particles& particles, const std::vector<int>& destination);

  int comm_ = 0, rank_ = 0, ranks_ = 1;
  double halo_radius_ = 0;
  bool renumbered_ = false;  // a migration moved particles since the last solve
  std::optional<BasicHalo<D>> halo_;
  DistributedPpe ppe_;
  DistributedStepStats stats_;
  DistributedOptions options_;
  std::optional<RcbPartition> partition_;  // the kept cuts
  // What the kept cuts were made from (positions, ids and kinds of this rank's particles then): a checkpoint holds it so
  // that a restart makes the same cuts. About 21 bytes a particle in 2-D.
  Particles cut_input_;
  void keep_cut_input(const Particles& particles);
};
using RankExchange = BasicRankExchange<2>;   ///< the exchange of a 2-D run on ranks
using RankExchange3 = BasicRankExchange<3>;  ///< the exchange of a 3-D run on ranks

extern template class BasicRankExchange<2>;
extern template class BasicRankExchange<3>;

}  // namespace mps
