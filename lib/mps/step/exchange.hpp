#pragma once
/// \file
/// Where a step meets the other processes it runs on: the exchange policy a Simulation is given. The step's stages
/// (mps/step/step.hpp) are the same on one process and on many; the policy says what crosses between processes at the
/// points between them, where the PPE lives, and how a failure on one process reaches the others. SerialExchange,
/// the default, exchanges nothing; RankExchange (mps/parallel/rank_exchange.hpp) spreads a run over MPI ranks. docs/step.md.
#include <cstddef>
#include <span>
#include <string>
#include <vector>

#include "mps/core/neighbors.hpp"
#include "mps/core/particles.hpp"
#include "mps/numerics/ppe.hpp"
#include "mps/solvers/solver.hpp"
#include "mps/step/config.hpp"

namespace mps {

template <int D>
class BasicSimulation;

/// The PPE's global size, as the step reports it (StepInfo::unknowns, floating_groups).
struct PpeCounts {
  std::size_t unknowns = 0;         ///< unknowns over every process
  std::size_t floating_groups = 0;  ///< closed groups (each gauged) over every process
};

/// This process's own rows of the PPE: what the solve's special cases are decided on.
struct OwnPpeRows {
  std::span<const double> rhs;   ///< their right-hand side
  std::span<const int> particle;  ///< the particle of each
};

/// The exchange policy: one call for each point of the step where processes meet, in the order the step calls them.
/// Every call is collective over the processes of a run.
template <int D>
class BasicExchange {
 public:
  using Particles = BasicParticles<D>;  ///< the particles it exchanges
  virtual ~BasicExchange() = default;   ///< a Simulation owns its policy through this base

  /// @{ Set-up, by the Simulation's constructor
  /// What the pressure solver is made with (on ranks: the communicator).
  [[nodiscard]] virtual SolverContext solver_context() const = 0;
  /// Throws std::invalid_argument naming what of `sim` this policy cannot run; again before each step, since
  /// components are added after construction.
  virtual void check(const BasicSimulation<D>& sim) const = 0;
  /// Every process passes the same validated scene; keeps the particles this process owns.
  virtual void distribute(Particles& particles) = 0;
  /// Whether the step may reorder particles by cell (on ranks begin_step does it for a rank's own).
  [[nodiscard]] virtual bool reorders() const = 0;
  /// Whether a particle keeps its index from one step's search at r* to the next step's start (serially; on ranks
  /// the halo is made anew), so that the step may carry a neighbour list over (SimulationConfig::neighbor_skin).
  [[nodiscard]] virtual bool keeps_indices() const = 0;
  /// @}

  /// @{ Within a step, in this order
  /// Before the step: particles move to the process that owns them now, those staying keeping their order and those
  /// arriving after them; with `cell_size` > 0 [m] a process's own are then put in the cell order of a neighbour
  /// grid of that size. Copies of those within `reach` [m] of this process's own (the halo) join after them.
  virtual void begin_step(Particles& particles, const BasicDomain<D>& domain, double reach, double cell_size) = 0;
  /// After the predictor: copies take their owners' r*, u* (and `prescribed` flags for copies new in this step).
  virtual void share_predicted(Particles& particles, std::vector<char>& prescribed) = 0;
  /// Copies take their owners' entries of a per-particle flag.
  virtual void share_flags(std::span<char> flags) = 0;
  /// Assembles the PPE (assemble_ppe's arguments) over the particles this process holds.
  /// `rows`: on ranks the rows are always the unknowns (a particle crossing a cut renumbers them anyway).
  virtual PpeCounts assemble(const BasicStencil<D>& laplacian, std::span<const char> held,
                             std::span<const double> source, std::span<const double> held_value, double shift,
                             OpenSupport open, PpeRows rows) = 0;
  /// This process's part of the last PPE (on ranks: its owned and halo unknowns, as assembled locally).
  [[nodiscard]] virtual const PpeSystem& ppe() const = 0;
  /// The unknowns this process owns.
  [[nodiscard]] virtual OwnPpeRows own_rows() const = 0;
  /// Solves the PPE with `solver`, starting from P - offset = 0 (`from_zero`) or from the particles' pressures, and
  /// writes the pressures into the particles as PpeSystem::scatter does (copies too).
  virtual SolveReport solve(LinearSolver& solver, Particles& particles, bool from_zero, bool clamp_negative,
                            std::span<const double> offset) = 0;
  /// After the pressure boundary values: copies take their owners' pressures and carrier flags.
  virtual void share_pressure(std::span<double> pressure, std::span<char> carriers) = 0;
  /// After the corrector: copies take their owners' r^{n+1}, u^{n+1} (for particle shifting).
  virtual void share_particles(Particles& particles) = 0;
  /// After shift_positions: the copies are dropped.
  virtual void end_step(Particles& particles) = 0;
  /// A failed step is rolled back: whatever begin_step set up is undone (the particles are restored by the step).
  virtual void abandon_step() = 0;
  /// @}

  /// @{ Over every process
  /// Particles [0, owned) are this process's own, the rest copies.
  [[nodiscard]] virtual std::size_t owned(const Particles& particles) const = 0;
  [[nodiscard]] virtual double max(double value) const = 0;  ///< the largest value
  [[nodiscard]] virtual bool all(bool value) const = 0;      ///< true where every process has true
  [[nodiscard]] virtual long long sum(long long value) const = 0;  ///< the sum
  /// Each process's failure of the stage just run ("" for none): every process gets the failure of the first process
  /// that failed, saying which it was, or "" when none did. How an error on one process stops them all.
  [[nodiscard]] virtual std::string first_failure(const std::string& failure) const = 0;
  /// @}

  /// @{ Checkpoints (Simulation::checkpoint, docs/restart.md). The processes' states: on one process `own` itself;
  /// on ranks {"ranks": P, "parts": [each rank's own]} on rank 0 and null on the others (collective).
  [[nodiscard]] virtual nlohmann::json gather_states(nlohmann::json own) const = 0;
  /// This process's part of a checkpoint of as many processes as this run has: `parts[rank]`.
  [[nodiscard]] virtual const nlohmann::json& own_part(const std::vector<const nlohmann::json*>& parts) const = 0;
  [[nodiscard]] virtual int processes() const = 0;  ///< how many processes the run has
  [[nodiscard]] virtual bool first_process() const = 0;  ///< rank 0 (one process: true)
  /// What the exchange carries from step to step (on ranks: the kept cuts' input and the step count), and back on a
  /// simulation of the same process count; `state` null (another count): the step count only, after distribute().
  [[nodiscard]] virtual nlohmann::json save_state() const = 0;
  virtual void restore_state(const nlohmann::json& state, int steps) = 0;  ///< see save_state()
  /// Whether the step after `steps` completed ones renumbers the unknowns, and so sets a kept solver setup up afresh.
  [[nodiscard]] virtual bool renumbers_after(int steps, const SimulationConfig& config) const = 0;
  /// @}
};

/// One process: nothing to exchange, the PPE assembled and solved here (assemble_ppe, PpeSystem::scatter).
template <int D>
class BasicSerialExchange final : public BasicExchange<D> {
 public:
  using typename BasicExchange<D>::Particles;
  [[nodiscard]] SolverContext solver_context() const override { return {}; }  ///< no communicator
  void check(const BasicSimulation<D>&) const override {}    ///< runs everything
  void distribute(Particles&) override {}                    ///< keeps every particle
  [[nodiscard]] bool reorders() const override { return true; }  ///< reordering by cell allowed
  [[nodiscard]] bool keeps_indices() const override { return true; }  ///< no halo: the particles stay as they are
  void begin_step(Particles&, const BasicDomain<D>&, double, double) override {}    ///< nothing to move
  void share_predicted(Particles&, std::vector<char>&) override {}  ///< no copies
  void share_flags(std::span<char>) override {}              ///< no copies
  /// assemble_ppe into the kept system.
  PpeCounts assemble(const BasicStencil<D>& laplacian, std::span<const char> held, std::span<const double> source,
                     std::span<const double> held_value, double shift, OpenSupport open, PpeRows rows) override;
  [[nodiscard]] const PpeSystem& ppe() const override { return ppe_; }  ///< the whole PPE
  [[nodiscard]] OwnPpeRows own_rows() const override { return {ppe_.rhs, ppe_.particle}; }  ///< every row
  /// Warm start by PpeSystem::gather, the solve, PpeSystem::scatter.
  SolveReport solve(LinearSolver& solver, Particles& particles, bool from_zero, bool clamp_negative,
                    std::span<const double> offset) override;
  void share_pressure(std::span<double>, std::span<char>) override {}  ///< no copies
  void share_particles(Particles&) override {}              ///< no copies
  void end_step(Particles&) override {}                      ///< no copies
  void abandon_step() override {}                            ///< nothing set up
  [[nodiscard]] std::size_t owned(const Particles& particles) const override { return particles.size(); }  ///< all
  [[nodiscard]] double max(double value) const override { return value; }      ///< the value
  [[nodiscard]] bool all(bool value) const override { return value; }          ///< the value
  [[nodiscard]] long long sum(long long value) const override { return value; }  ///< the value
  [[nodiscard]] std::string first_failure(const std::string& failure) const override { return failure; }  ///< it
  [[nodiscard]] nlohmann::json gather_states(nlohmann::json own) const override { return own; }  ///< `own`
  /// the only part
  [[nodiscard]] const nlohmann::json& own_part(const std::vector<const nlohmann::json*>& parts) const override {
    return *parts.front();
  }
  [[nodiscard]] int processes() const override { return 1; }  ///< one
  [[nodiscard]] bool first_process() const override { return true; }  ///< it is
  [[nodiscard]] nlohmann::json save_state() const override { return nullptr; }  ///< nothing
  void restore_state(const nlohmann::json&, int) override {}  ///< nothing
  /// the steps that reorder by cell (reorder_every)
  [[nodiscard]] bool renumbers_after(int steps, const SimulationConfig& config) const override {
    return config.reorders_after(steps);
  }

 private:
  PpeSystem ppe_;                 // kept between steps for its memory
  std::vector<double> pressure_;  // the solve's unknowns
};
using SerialExchange = BasicSerialExchange<2>;   ///< one process, 2-D
using SerialExchange3 = BasicSerialExchange<3>;  ///< one process, 3-D

extern template class BasicSerialExchange<2>;
extern template class BasicSerialExchange<3>;

}  // namespace mps
