#pragma once
/// \file
/// One interface for every sparse linear solver, picked at run time by a spec string
/// "name[:key=value,...]" (e.g. "eigen-cg:precond=ic,tol=1e-10"), parsed and validated in one place.
#include <map>
#include <memory>
#include <optional>
#include <span>
#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

#include <nlohmann/json.hpp>

#include "mps/core/csr.hpp"

namespace mps {

/// What one solve did, returned by LinearSolver::solve (and carried by SolverError when it failed).
struct SolveReport {
  std::string backend;  ///< the solver's name, e.g. "eigen-cg" (for auto: the backend that solved)
  int iterations = 0;   ///< iterations taken (1 for cholmod)
  double relative_residual = 0;  ///< ||b - A x|| / ||b||, measured on the returned x
  double setup_seconds = 0;      ///< preconditioner / factorisation
  double solve_seconds = 0;      ///< the iterations or the triangular solves
  bool setup_reused = false;     ///< hypre: AMG hierarchy kept (reuse=N); cholmod: symbolic analysis kept
  /// Relative residuals, first entry at the initial guess: every iteration for hypre-pcg and hypre-amg; the
  /// initial and the final one for the Eigen solvers (Eigen keeps no history); the final one for cholmod.
  std::vector<double> residual_history;
};

/// A solve that failed: no convergence, a matrix the method cannot handle, or NaN in or out. The report
/// says how far it got.
class SolverError : public std::runtime_error {
 public:
  /// The message names what failed; the report, how far the solve got.
  SolverError(const std::string& message, SolveReport report)
      : std::runtime_error(message), report_(std::move(report)) {}
  [[nodiscard]] const SolveReport& report() const { return report_; }  ///< how far the solve got

 private:
  SolveReport report_;
};

/// A sparse linear solver; make_solver builds one from a spec string.
class LinearSolver {
 public:
  virtual ~LinearSolver() = default;  ///< solvers are owned through this base (make_solver)
  /// Solves A x = b for a symmetric positive definite A (the PPE after its sign flip); x is the initial
  /// guess on entry (warm start; a guess with NaN or Inf is replaced by zeros) and the solution on return.
  /// Throws SolverError when the iterations reach max_iter above tol, when A or b hold NaN or Inf, when x
  /// comes out with NaN or Inf, or when the method cannot handle A (cholmod: not positive definite or not
  /// symmetric). One solver object keeps state between solves (a factorisation, an AMG hierarchy): use one
  /// per thread. The hypre backends on one rank read a's own arrays, each row's diagonal swapped to its front
  /// during the call and swapped back before it returns (no copy of A): no other thread may read a meanwhile.
  virtual SolveReport solve(const CsrMatrix& a, std::span<const double> b, std::span<double> x) = 0;
  /// The spec that rebuilds this solver, every key spelled out with its value.
  [[nodiscard]] virtual std::string spec() const = 0;
  /// The unknowns are in another order from the next solve on (the step's reordering by cell, a migration between
  /// ranks): state tied to their order (a reused AMG hierarchy) is set up afresh then. On ranks, called on every rank.
  virtual void renumbered() {}
  /// What a checkpoint must hold for the solves after a restart to repeat this solver's bitwise: its modes and
  /// counters (auto), never a setup (default: nothing). restore_state() takes it back on a solver of the same spec.
  [[nodiscard]] virtual nlohmann::json save_state() const { return nullptr; }
  virtual void restore_state(const nlohmann::json& state) { (void)state; }  ///< see save_state()
  /// Whether the next solve would reuse a setup made from an earlier matrix (a kept AMG hierarchy or PETSc
  /// preconditioner). No checkpoint holds one: a run restored from here sets it up afresh, and its solves then agree
  /// with the uninterrupted run's within the tolerance, not bitwise (docs/restart.md).
  [[nodiscard]] virtual bool keeps_setup() const { return false; }
  /// Whether the next solves would gain from a row numbering that holds from one matrix to the next: every fluid and
  /// wall particle a row, those not solved for alone in theirs (PpeRows::every_particle), so that a free surface
  /// changes a kept AMG hierarchy's matrices but not its unknowns (hypre's refresh=galerkin, auto on AMG).
  [[nodiscard]] virtual bool wants_fixed_rows() const { return false; }
};

/// A spec string taken apart: "name:key=value,..." -> name and options.
struct SolverSpec {
  std::string name;                            ///< e.g. "eigen-cg"
  std::map<std::string, std::string> options;  ///< key -> value, as written
};
/// Syntax only; names and keys are checked by make_solver.
SolverSpec parse_solver_spec(std::string_view spec);

/// What a host program may hand a solver besides its spec: the hypre backends (and auto) solve on its communicator,
/// the serial backends refuse one of more than one rank (make_solver throws std::invalid_argument).
struct SolverContext {
  /// The MPI communicator the hypre backends run on, as its Fortran handle so that this header needs no
  /// `<mpi.h>`: set it with MPI_Comm_c2f(comm) after MPI_Init, and keep the communicator alive as long as the
  /// solver. Unset means MPI_COMM_SELF (a serial solve; MPI is then initialised on first use if the host
  /// has not done it). On a communicator of P ranks every rank calls solve together, passing its own
  /// contiguous block of rows (blocks in rank order) with global column indices, a.cols being the global
  /// size, and its block of b and x.
  std::optional<int> mpi_comm;
};

/// A solver from its spec, e.g. "hypre-pcg:reuse=20,tol=1e-3". Throws std::invalid_argument naming what is valid for
/// unknown names, unknown keys and bad values.
std::unique_ptr<LinearSolver> make_solver(std::string_view spec);
/// Same, with what the host program hands the solver besides its spec (an MPI communicator).
std::unique_ptr<LinearSolver> make_solver(std::string_view spec, const SolverContext& context);
/// Every registered solver with its keys, defaults and a line on when to use it (for --list-solvers).
std::string describe_solvers();
std::vector<std::string> solver_names();  ///< the registered names, as make_solver accepts them

}  // namespace mps
