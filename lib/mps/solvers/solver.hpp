#pragma once
// One interface for every sparse linear solver, picked at run time by a spec string
// "name[:key=value,...]" (e.g. "eigen-cg:precond=ic,tol=1e-10"), parsed and validated in one place.
#include <map>
#include <memory>
#include <span>
#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

#include "mps/csr.hpp"

namespace mps {

struct SolveReport {
  std::string backend;
  int iterations = 0;
  double relative_residual = 0;  // ||b - A x|| / ||b||, measured on the returned x
  double setup_seconds = 0;      // preconditioner / factorisation
  double solve_seconds = 0;
  bool setup_reused = false;
  std::vector<double> residual_history;  // relative residual per iteration, where the backend provides it
};

// A solve that failed: no convergence, a matrix the method cannot handle, or NaN in or out. The report
// says how far it got.
class SolverError : public std::runtime_error {
 public:
  SolverError(const std::string& message, SolveReport report)
      : std::runtime_error(message), report_(std::move(report)) {}
  [[nodiscard]] const SolveReport& report() const { return report_; }

 private:
  SolveReport report_;
};

class LinearSolver {
 public:
  virtual ~LinearSolver() = default;
  // Solves A x = b for a symmetric positive definite A (the PPE after its sign flip); x is the initial
  // guess on entry (warm start) and the solution on return. Throws SolverError on failure.
  virtual SolveReport solve(const CsrMatrix& a, std::span<const double> b, std::span<double> x) = 0;
  // The spec that rebuilds this solver, every key spelled out with its value.
  [[nodiscard]] virtual std::string spec() const = 0;
};

struct SolverSpec {
  std::string name;
  std::map<std::string, std::string> options;
};
// Syntax only; names and keys are checked by make_solver.
SolverSpec parse_solver_spec(std::string_view spec);

// Throws std::invalid_argument naming what is valid for unknown names, unknown keys and bad values.
std::unique_ptr<LinearSolver> make_solver(std::string_view spec);
// Every registered solver with its keys, defaults and a line on when to use it (for --list-solvers).
std::string describe_solvers();
std::vector<std::string> solver_names();

}  // namespace mps
