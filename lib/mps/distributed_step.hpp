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
  std::size_t messages_sent = 0;    ///< point-to-point messages of the migrations, halos and refreshes
  std::size_t bytes_sent = 0;       ///< their payload bytes
  double migrate_seconds = 0;       ///< wall-clock time in the partition and migration
  double halo_seconds = 0;          ///< wall-clock time building halos
};

/// A Simulation whose particles are spread over the ranks of `comm` (MPI_Comm_c2f of the communicator). Each step
/// starts with a new RCB partition (partition_particles) and the migration to it, then a halo at the largest kernel
/// radius or component reach (StepComponent::reach: an OpenOutlet's upstream sampling) plus twice the guard's
/// max_displacement (both particles of a pair may move that far in the step); the stages then run over owned and halo
/// particles, the copies refreshed after the predictor (whole particles; particles the predictor's components turned
/// from ghosts to fluid, a pushing plate's column, are first copied to the ranks whose halo they fall in, appended
/// after the other copies: a component keeping per-particle state from before_predictor must allow for them), after
/// the free surface (flags), by the distributed PPE, and after the pressure boundary values (pressures, carriers).
/// The time step and the stability guard are taken over all ranks. Between steps particles() holds this rank's own
/// particles only, sorted by id after each migration; gather() collects them all on rank 0.
///
/// Refused (std::invalid_argument, naming the cause): periodic domains, implicit viscosity (its global solve), particle
/// shifting (it reads |u|max and neighbours after the copies are dropped) and the initial reference density (a t = 0
/// mean over the domain); also a pressure solver that does not run on the communicator (the serial backends on more
/// than one rank).
class DistributedSimulation : public Simulation {
 public:
  /// Every rank passes the same scene: every rank validates it as Simulation does, rank 0's particles are then
  /// distributed. config.reorder_every is set to 0 (the migration orders each rank's particles by id). Collective.
  DistributedSimulation(Particles scene, Domain domain, SimulationConfig config, int comm);

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

 protected:
  void begin_step() override;                       ///< new partition, migration, halo
  [[nodiscard]] double max_over_ranks(double value) const override;  ///< MPI_Allreduce(MAX)
  void share_predicted() override;                  ///< copies take their owners' r*, u*
  void share_surface() override;                    ///< copies take their owners' free-surface flags
  void assemble() override;                         ///< assemble_distributed_ppe
  void solve() override;                            ///< solve_distributed_ppe (which scatters the pressures)
  void scatter_pressure() override {}               ///< done by solve()
  void share_pressure_boundary() override;          ///< copies take their owners' pressures and carrier flags
  void end_corrector() override;                    ///< drops the copies
  void check_guard() const override;                ///< every rank stops if one rank's guard trips

 private:
  void count(const ExchangeStats& e);
  void refuse_unsupported() const;

  int comm_ = 0, rank_ = 0, ranks_ = 1;
  double kernel_reach_ = 0;  // the largest kernel radius [m]
  double halo_radius_ = 0;
  std::optional<Halo> halo_;
  DistributedPpe distributed_ppe_;
  DistributedStepStats stats_;
};

}  // namespace mps
