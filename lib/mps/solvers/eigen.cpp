// Eigen's iterative solvers over the library's CSR matrix, mapped without copying.
#include <Eigen/IterativeLinearSolvers>
#include <Eigen/SparseCore>
#include <chrono>
#include <cmath>
#include <limits>
#include <sstream>

#include "mps/solvers/registry.hpp"

namespace mps {
namespace {

using RowMatrix = Eigen::SparseMatrix<double, Eigen::RowMajor, int>;
using Clock = std::chrono::steady_clock;

double seconds_since(Clock::time_point t0) { return std::chrono::duration<double>(Clock::now() - t0).count(); }

Eigen::Map<const RowMatrix> as_eigen(const CsrMatrix& a) {
  return {a.rows, a.cols, static_cast<Eigen::Index>(a.nnz()), a.row_ptr.data(), a.col.data(), a.val.data()};
}

bool all_finite(std::span<const double> x) {
  for (double v : x)
    if (!std::isfinite(v)) return false;
  return true;
}

class EigenCg final : public LinearSolver {
 public:
  explicit EigenCg(const SolverOptions& o)
      : precond_(o.choice("precond", {"ic", "jacobi"})),
        ordering_(o.choice("ordering", {"natural", "amd"})),
        tol_(o.number("tol", 1e-16, 1e-1)),
        max_iter_(o.integer("max_iter", 1, 100000000)),
        spec_(o.spec()) {}

  SolveReport solve(const CsrMatrix& a, std::span<const double> b, std::span<double> x) override {
    if (precond_ == "jacobi") return run<Eigen::DiagonalPreconditioner<double>>(a, b, x);
    if (ordering_ == "amd") return run<Eigen::IncompleteCholesky<double, Eigen::Lower, Eigen::AMDOrdering<int>>>(a, b, x);
    return run<Eigen::IncompleteCholesky<double, Eigen::Lower, Eigen::NaturalOrdering<int>>>(a, b, x);
  }
  [[nodiscard]] std::string spec() const override { return spec_; }

 private:
  template <class Preconditioner>
  SolveReport run(const CsrMatrix& a, std::span<const double> b, std::span<double> x) {
    SolveReport report;
    report.backend = "eigen-cg";
    if (a.rows != a.cols || b.size() != static_cast<std::size_t>(a.rows) || x.size() != b.size())
      throw SolverError("eigen-cg: matrix and vector sizes do not match", report);
    if (!all_finite(b) || !all_finite(a.val)) throw SolverError("eigen-cg: NaN or Inf in the matrix or right-hand side", report);
    if (!all_finite(x)) std::fill(x.begin(), x.end(), 0.0);  // a broken guess must not poison the solve

    const auto t0 = Clock::now();
    Eigen::ConjugateGradient<RowMatrix, Eigen::Lower | Eigen::Upper, Preconditioner> cg;
    cg.setTolerance(tol_);
    cg.setMaxIterations(max_iter_);
    cg.compute(as_eigen(a));
    report.setup_seconds = seconds_since(t0);
    if (cg.preconditioner().info() != Eigen::Success)
      throw SolverError("eigen-cg: the preconditioner could not be built (matrix not symmetric positive definite?)",
                        report);

    const auto t1 = Clock::now();
    Eigen::Map<const Eigen::VectorXd> rhs(b.data(), static_cast<Eigen::Index>(b.size()));
    Eigen::Map<Eigen::VectorXd> sol(x.data(), static_cast<Eigen::Index>(x.size()));
    const Eigen::VectorXd guess = sol;
    sol = cg.solveWithGuess(rhs, guess);
    report.solve_seconds = seconds_since(t1);
    report.iterations = static_cast<int>(cg.iterations());
    report.relative_residual = relative_residual(a, x, b);
    if (!all_finite(x)) throw SolverError("eigen-cg: the solution contains NaN or Inf", report);
    if (cg.info() != Eigen::Success || !(report.relative_residual <= 10.0 * tol_)) {
      std::ostringstream msg;
      msg << "eigen-cg (precond=" << precond_ << "): no convergence after " << report.iterations
          << " iterations, relative residual " << report.relative_residual << " > tol " << tol_
          << "; raise max_iter, loosen tol, or pick a stronger solver (hypre-pcg, cholmod)";
      throw SolverError(msg.str(), report);
    }
    return report;
  }

  std::string precond_, ordering_;
  double tol_;
  int max_iter_;
  std::string spec_;
};

}  // namespace

SolverEntry eigen_cg_entry() {
  return {"eigen-cg",
          "Eigen conjugate gradients; the classic MPS baseline with precond=ic. Threads only its SpMV.",
          {{"precond", "ic", "ic (incomplete Cholesky) | jacobi"},
           {"ordering", "natural", "IC fill ordering: natural (cell-sorted particles) | amd"},
           {"tol", "1e-8", "relative residual ||b-Ax||/||b|| to reach"},
           {"max_iter", "10000", "iterations before the solve is reported as failed"}},
          [](const SolverOptions& o) { return std::make_unique<EigenCg>(o); }};
}

}  // namespace mps
