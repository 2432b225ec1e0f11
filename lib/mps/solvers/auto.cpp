// "auto": Jacobi-CG while it converges in few iterations or the unknowns keep changing (a free surface, an inlet:
// an AMG hierarchy would be rebuilt nearly every step), AMG-preconditioned CG with its hierarchy reused once they
// have stayed the same for a few solves and Jacobi needed many iterations. Once Jacobi is slow it asks the step for a
// row per particle, which a free surface leaves the same, and its hierarchy is refreshed rather than rebuilt (hypre's
// refresh=galerkin). The rule reads only the systems' sizes and iteration counts, so a run repeats bitwise;
// docs/solvers.md has the measurements behind it.
#include <mpi.h>

#include <algorithm>
#include <memory>
#include <string>
#include <vector>

#include "mps/core/state.hpp"
#include "mps/solvers/backend_util.hpp"
#include "mps/solvers/registry.hpp"

namespace mps {
namespace {

class AutoSolver final : public LinearSolver {
 public:
  AutoSolver(const SolverOptions& o, const SolverContext& context)
      : switch_iterations_(o.integer("switch_iterations", 0, 100000000)),
        rebuild_iterations_(o.integer("rebuild_iterations", 0, 100000000)),
        steady_solves_(o.integer("steady_solves", 1, 1000000)),
        fixed_rows_iterations_(o.integer("fixed_rows_iterations", 0, 100000000)),
        surface_agg_levels_(o.integer("surface_agg_levels", 0, 25)),
        spec_(o.spec()) {
    const std::string tol = "tol=" + o.values().at("tol");
    // A Jacobi solve stops at rebuild_iterations: past it AMG-PCG is the faster method and finishes the solve.
    jacobi_max_iter_ = std::clamp(rebuild_iterations_, 1, 100000);
    const std::string jacobi_max_iter = ",max_iter=" + std::to_string(jacobi_max_iter_);
    // Validated here, passed on as written.
    static_cast<void>(o.number("tol", 1e-16, 1e-1));
    static_cast<void>(o.integer("reuse", 0, 1000000));
    static_cast<void>(o.number("filter", 0.0, 1.0));
    refresh_ = o.choice("refresh", {"none", "galerkin"}) == "galerkin";
    distributed_ = context.mpi_comm.has_value();
    if (distributed_) comm_ = MPI_Comm_f2c(*context.mpi_comm);
    // Eigen solves one rank's rows only: on ranks, Jacobi-CG is hypre's PCG with the diagonal.
    jacobi_ = distributed_ ? make_solver("hypre-pcg:precond=jacobi," + tol + jacobi_max_iter, context)
                           : make_solver("eigen-cg:precond=jacobi," + tol + jacobi_max_iter);
    amg_spec_ = "hypre-pcg:reuse=" + o.values().at("reuse") + ",filter=" + o.values().at("filter") +
                ",refresh=" + o.values().at("refresh") + "," + tol;
    rescue_spec_ =
        (distributed_ ? "hypre-pcg:precond=jacobi," : "eigen-cg:precond=jacobi,") + tol + ",max_iter=100000";
    context_ = context;
  }

  SolveReport solve(const CsrMatrix& a, std::span<const double> b, std::span<double> x) override {
    // On ranks: steady only while no rank's count changed (what lets hypre reuse a hierarchy), the same on every rank.
    const bool same = !any_rank(a.rows != last_rows_);
    steady_ = same ? steady_ + 1 : 1;
    last_rows_ = a.rows;
    // Jacobi this slow costs more than a fresh filtered AMG setup and solve (about 150 and 50 SpMVs at 1e5
    // unknowns, docs/solvers.md): AMG from then on, its hierarchy rebuilt whenever the unknowns change.
    always_amg_ = always_amg_ || last_jacobi_iterations_ > rebuild_iterations_;
    // Every input of the rule is the same on every rank (the iterations are global), so the ranks choose alike.
    const bool steady_and_slow =
        steady_ >= steady_solves_ && (on_amg_ || last_jacobi_iterations_ > switch_iterations_);
    if (always_amg_ || steady_and_slow) {
      on_amg_ = true;
      return amg_solve(a, b, x);
    }
    on_amg_ = false;
    try {
      SolveReport report = jacobi_->solve(a, b, x);
      last_jacobi_iterations_ = report.iterations;
      return report;
    } catch (const SolverError& e) {
      // Not converged in rebuild_iterations (a first solve of 1e6 unknowns from rest would take thousands): AMG-PCG
      // goes on from where Jacobi got to, and solves for good. Decided alike on every rank (the residual is global).
      // Bad input stops Jacobi before its last iteration and is the caller's to hear.
      if (e.report().iterations < jacobi_max_iter_) throw;
      always_amg_ = on_amg_ = true;
      return amg_solve(a, b, x);
    }
  }
  // AMG-PCG; should it break down, the same solve by Jacobi-CG from the same guess, uncapped. A filtered hierarchy
  // broke down on a free surface torn by a moving paddle (examples/scenes/wave_paddle.toml, docs/solvers.md) where
  // IC-CG and unfiltered AMG converged. The hierarchy is set up afresh at the next solve.
  SolveReport amg_solve(const CsrMatrix& a, std::span<const double> b, std::span<double> x) {
    // A row that stands alone (held at its Dirichlet value, or coupled to known values only) means a free surface,
    // whose hierarchy is refreshed nearly every step: aggressive coarsening there halves the refresh for a few more
    // iterations (docs/solvers.md). Decided once, alike on every rank; the hierarchy is then set up afresh.
    if (!surface_ && surface_agg_levels_ > 0 && any_rank(has_row_standing_alone(a))) {
      surface_ = true;
      amg_.reset();
    }
    // Made at its first solve: a run that never leaves Jacobi-CG (a free surface) then never starts MPI and hypre.
    if (!amg_)
      amg_ = make_solver(amg_spec_ + (surface_ ? ",agg_levels=" + std::to_string(surface_agg_levels_) : ""), context_);
    guess_.assign(x.begin(), x.end());
    try {
      return amg_->solve(a, b, x);
    } catch (const SolverError& amg_failure) {
      std::copy(guess_.begin(), guess_.end(), x.begin());
      amg_->renumbered();
      if (!rescue_) rescue_ = make_solver(rescue_spec_, context_);
      try {
        SolveReport report = rescue_->solve(a, b, x);
        report.backend += " (hypre-pcg broke down)";
        return report;
      } catch (const SolverError& e) {
        throw SolverError(std::string(amg_failure.what()) + "; Jacobi-CG from the same guess: " + e.what(), e.report());
      }
    }
  }
  [[nodiscard]] std::string spec() const override { return spec_; }
  void renumbered() override {
    if (amg_) amg_->renumbered();
  }
  // The rule's inputs; the hierarchy is set up afresh after a restart (keeps_setup says when that differs).
  [[nodiscard]] nlohmann::json save_state() const override {
    return {{"on_amg", on_amg_},     {"always_amg", always_amg_},
            {"last_rows", last_rows_}, {"last_jacobi_iterations", last_jacobi_iterations_},
            {"steady", steady_}};
  }
  void restore_state(const nlohmann::json& state) override {
    on_amg_ = unpack_value<bool>(state, "on_amg");
    always_amg_ = unpack_value<bool>(state, "always_amg");
    last_rows_ = unpack_value<int>(state, "last_rows");
    last_jacobi_iterations_ = unpack_value<int>(state, "last_jacobi_iterations");
    steady_ = unpack_value<int>(state, "steady");
  }
  [[nodiscard]] bool keeps_setup() const override { return amg_ && amg_->keeps_setup(); }
  // AMG-PCG waits for the unknowns to hold still: with a row for every particle they do, even under a free surface,
  // and its refreshed hierarchy serves from step to step. A refresh costs more than a few PCG iterations, so it is
  // asked for only where Jacobi is slower than that and AMG together (docs/solvers.md).
  [[nodiscard]] bool wants_fixed_rows() const override {
    return refresh_ && (always_amg_ || last_jacobi_iterations_ > fixed_rows_iterations_);
  }

 private:
  std::unique_ptr<LinearSolver> jacobi_, amg_, rescue_;
  std::vector<double> guess_;  // the guess of an AMG-PCG solve, for Jacobi-CG to start from should AMG break down
  // One process may not have started MPI (a run that never leaves Jacobi-CG never does).
  [[nodiscard]] bool any_rank(bool local) const {
    return distributed_ ? solver_detail::any_rank(local, comm_) : local;
  }
  static bool has_row_standing_alone(const CsrMatrix& a) {
    for (std::size_t r = 0; r + 1 < a.row_ptr.size(); ++r)
      if (a.row_ptr[r + 1] - a.row_ptr[r] == 1) return true;
    return false;
  }

  int switch_iterations_, rebuild_iterations_, steady_solves_, fixed_rows_iterations_, surface_agg_levels_,
      jacobi_max_iter_ = 1;
  std::string spec_, amg_spec_, rescue_spec_;
  SolverContext context_;
  bool distributed_ = false, on_amg_ = false, always_amg_ = false, refresh_ = true, surface_ = false;
  MPI_Comm comm_ = MPI_COMM_SELF;
  int last_rows_ = -1, last_jacobi_iterations_ = 0;
  int steady_ = 0;  // solves in a row, this one included, with the same unknown count
};

}  // namespace

SolverEntry auto_entry() {
  return {"auto",
          "The default: Jacobi-CG (eigen-cg:precond=jacobi; on MPI ranks hypre-pcg:precond=jacobi) while it needs few "
          "iterations or the unknowns change from step to step; hypre-pcg with its AMG hierarchy reused once the "
          "unknowns (on ranks, every rank's) stay the same and Jacobi needed more than switch_iterations, or for good once a "
          "Jacobi solve reached rebuild_iterations without converging (AMG-PCG then finishes that solve from "
          "Jacobi's iterate). Should AMG-PCG break down, Jacobi-CG solves again from the same guess, uncapped. Each "
          "solve's report names the backend that finished it.",
          {{"tol", "1e-8", "relative residual ||b-Ax||/||b|| to reach, for either backend"},
           {"switch_iterations", "50", "Jacobi iterations above which an unchanged system moves to AMG-PCG"},
           {"rebuild_iterations", "150",
            "Jacobi iterations after which AMG-PCG finishes the solve and takes over for good, set up afresh whenever "
            "the unknowns change"},
           {"steady_solves", "3", "solves in a row with the same unknown count before AMG-PCG is set up"},
           {"reuse", "20", "hypre-pcg: solves one AMG hierarchy serves while the unknowns stay the same"},
           {"refresh", "galerkin",
            "hypre-pcg: galerkin keeps the hierarchy across a moving free surface (a row for every particle once "
            "Jacobi needs more than fixed_rows_iterations, coarse operators made again when rows join or leave the "
            "solve); none: rebuilt whenever the unknowns change"},
           {"fixed_rows_iterations", "80",
            "with refresh=galerkin: Jacobi iterations above which the step keeps a row for every particle"},
           {"surface_agg_levels", "1",
            "hypre-pcg's agg_levels once a row of the system stands alone (a free surface, whose hierarchy is "
            "refreshed nearly every step: aggressive coarsening halves the refresh); 0: as a confined flow's"},
           {"filter", "0.2",
            "hypre-pcg: AMG built on the PPE with couplings below this fraction of the strongest lumped onto the "
            "diagonal (half the solve's cost on the 4.1 l0 stencil)"}},
          [](const SolverOptions& o, const SolverContext& c) { return std::make_unique<AutoSolver>(o, c); },
          /*distributed: hypre-pcg alone on a communicator*/ true};
}

}  // namespace mps
