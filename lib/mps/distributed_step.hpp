#pragma once
/// \file
/// The MPS step on the ranks of an MPI communicator (issue 27, second slice): each rank owns the particles of one
/// RCB box and runs the serial stages over its own particles and halo copies of its neighbours', exchanging at the
/// points docs/scaling.md lists. The same scene gives the same answer on any rank count, to within the pressure
/// solver's tolerance (tests/mpi/test_distributed_step.cpp).
#include <cstddef>
#include <memory>
#include <optional>

#include "mps/distributed.hpp"
#include "mps/step.hpp"

namespace mps {

/// What the distributed step exchanged, summed over the steps so far (this rank's view).
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
};

/// How the distributed step spreads its particles.
struct DistributedOptions {
  /// New RCB cuts when the kept ones would give the largest rank more than this many times the mean particle count.
  /// 1 or below: new cuts every step; +infinity: never after the constructor's. Chosen from the classic dam break on
  /// 2 ranks (docs/scaling.md, "Keeping the cuts"): new cuts cost about 1 % of a step, 1 % of imbalance costs up to
  /// 1 % of a step, every step; of the thresholds tried (1 to 1.10) this one cost least, about half what new cuts
  /// every step did.
  double rebalance_threshold = 1.01;
};

/// A Simulation whose particles are spread over the ranks of `comm` (MPI_Comm_c2f of the communicator). Each step
/// starts by placing the particles in the kept RCB boxes (RcbPartition::place: new cuts when the load imbalance
/// exceeds options.rebalance_threshold) and the migration of those that crossed a cut, then a halo at the largest
/// kernel radius or component reach (StepComponent::reach: an OpenOutlet's upstream sampling) plus twice the guard's
/// max_displacement (both particles of a pair may move that far in the step); the stages then run over owned and halo
/// particles, the copies refreshed after the predictor (whole particles; particles the predictor's components turned
/// from ghosts to fluid, a pushing plate's column, are first copied to the ranks whose halo they fall in, appended
/// after the other copies: a component keeping per-particle state from before_predictor must allow for them), after
/// the free surface (flags), by the distributed PPE, after the pressure boundary values (pressures, carriers) and
/// after the corrector (whole particles, for particle shifting).
/// The time step and the stability guard are taken over all ranks. Between steps particles() holds this rank's own
/// particles only, sorted by id after each migration; gather() collects them all on rank 0.
///
/// Refused (std::invalid_argument, naming the cause): periodic domains, implicit viscosity (its global solve) and the
/// initial reference density (a t = 0 mean over the domain); also a pressure solver that does not run on the
/// communicator (the serial backends on more than one rank).
template <int D>
class BasicDistributedSimulation : public BasicSimulation<D> {
 public:
  using typename BasicSimulation<D>::Particles;
  using typename BasicSimulation<D>::Domain;
  /// Every rank passes the same scene: every rank validates it as Simulation does, rank 0's particles are then
  /// distributed. config.reorder_every is set to 0 (the migration orders each rank's particles by id). Collective.
  BasicDistributedSimulation(Particles scene, Domain domain, SimulationConfig config, int comm,
                             DistributedOptions options = {});

  /// Every rank's particles, on rank 0 sorted by id (empty on the other ranks). Collective; call between steps.
  [[nodiscard]] Particles gather() const;
  [[nodiscard]] int comm() const { return comm_; }  ///< the communicator's Fortran handle
  [[nodiscard]] int rank() const { return rank_; }  ///< this rank in the communicator
  [[nodiscard]] int ranks() const { return ranks_; }  ///< ranks in the communicator
  /// The halo's radius of the latest step: the largest kernel radius or component reach, plus twice
  /// config().max_displacement l0 [m].
  [[nodiscard]] double halo_radius() const { return halo_radius_; }
  /// Between begin_step and end_corrector this rank's own particles, before the halo copies; else all it holds.
  [[nodiscard]] std::size_t owned_particles() const override;
  [[nodiscard]] const DistributedStepStats& stats() const { return stats_; }  ///< exchanges so far
  [[nodiscard]] const DistributedOptions& options() const { return options_; }  ///< as constructed
  [[nodiscard]] double max_over_ranks(double value) const override;  ///< MPI_Allreduce(MAX)

 protected:
  void check_components() const override;           ///< refuses what does not run on ranks (added since)
  void begin_step() override;                       ///< placement in the kept boxes (or new cuts), migration, halo
  void share_predicted() override;                  ///< copies take their owners' r*, u*
  void share_surface() override;                    ///< copies take their owners' free-surface flags
  void assemble() override;                         ///< assemble_distributed_ppe
  void solve() override;                            ///< solve_distributed_ppe (which scatters the pressures)
  void scatter_pressure() override {}               ///< done by solve()
  void share_pressure_boundary() override;          ///< copies take their owners' pressures and carrier flags
  void share_corrected() override;                  ///< copies take their owners' r^{n+1}, u^{n+1}
  void end_corrector() override;                    ///< drops the copies
  void check_guard() const override;                ///< every rank stops if one rank's guard trips

 private:
  void count(const ExchangeStats& e);
  template <class Field>
  void refresh(Field&& field);  // the halo's refresh of a field or of whole particles, counted
  void refuse_unsupported() const;
  void migrate_to_partition();

  int comm_ = 0, rank_ = 0, ranks_ = 1;
  double kernel_reach_ = 0;  // the largest kernel radius [m]
  double halo_radius_ = 0;
  std::optional<BasicHalo<D>> halo_;
  DistributedPpe distributed_ppe_;
  DistributedStepStats stats_;
  DistributedOptions options_;
  std::optional<RcbPartition> partition_;  // the kept cuts
};
using DistributedSimulation = BasicDistributedSimulation<2>;   ///< a 2-D run on ranks
using DistributedSimulation3 = BasicDistributedSimulation<3>;  ///< a 3-D run on ranks

extern template class BasicDistributedSimulation<2>;
extern template class BasicDistributedSimulation<3>;

}  // namespace mps
