// Eigen's iterative solvers over the library's CSR matrix, mapped without copying: eigen-cg (Jacobi or
// incomplete Cholesky) and eigen-bicgstab (Jacobi or ILUT). Both start from x (warm start), both take
// their tolerance and iteration cap explicitly, and both check the true residual of what they return.
#include <Eigen/IterativeLinearSolvers>
#include <Eigen/SparseCore>
#include <limits>
#include <sstream>

#include "mps/core/threads.hpp"
#include "mps/solvers/backend_util.hpp"
#include "mps/solvers/registry.hpp"

namespace mps {
namespace {

using solver_detail::all_finite;
using solver_detail::Clock;
using solver_detail::seconds_since;
using RowMatrix = Eigen::SparseMatrix<double, Eigen::RowMajor, int>;

Eigen::Map<const RowMatrix> as_eigen(const CsrMatrix& a) {
  return {a.rows, a.cols, static_cast<Eigen::Index>(a.nnz()), a.row_ptr.data(), a.col.data(), a.val.data()};
}

// Runs one Eigen iterative solver: `configure` sets its preconditioner parameters before compute().
// Eigen keeps no per-iteration residuals, so the history holds the initial and the final true relative
// residual.
template <class Solver, class Configure>
SolveReport run_eigen(const std::string& backend, const std::string& label, double tol, int max_iter, bool spd,
                      const CsrMatrix& a, std::span<const double> b, std::span<double> x, Configure configure) {
  SolveReport report;
  report.backend = backend;
  solver_detail::check_serial_input(backend, a, b, x, report, spd);
  if (b.empty()) return report;  // nothing to solve (Eigen divides by the size)
  report.residual_history.push_back(relative_residual(a, x, b));

  const auto t0 = Clock::now();
  Solver solver;
  solver.setTolerance(tol);
  solver.setMaxIterations(max_iter);
  configure(solver);
  solver.compute(as_eigen(a));
  report.setup_seconds = seconds_since(t0);
  if (solver.preconditioner().info() != Eigen::Success)
    throw SolverError(backend + " (" + label + "): the preconditioner could not be built" +
                          (backend == "eigen-cg" ? " (matrix not symmetric positive definite?)" : ""),
                      report);

  const auto t1 = Clock::now();
  Eigen::Map<const Eigen::VectorXd> rhs(b.data(), static_cast<Eigen::Index>(b.size()));
  Eigen::Map<Eigen::VectorXd> sol(x.data(), static_cast<Eigen::Index>(x.size()));
  const Eigen::VectorXd guess = sol;
  // Eigen threads its products from 20,000 entries on; below the library's own threshold one thread does it all.
  Eigen::setNbThreads(detail::worth_threads(a.rows) ? 0 : 1);  // 0: OpenMP's thread count
  sol = solver.solveWithGuess(rhs, guess);
  Eigen::setNbThreads(0);
  report.solve_seconds = seconds_since(t1);
  report.iterations = static_cast<int>(solver.iterations());
  if (!all_finite(x)) {
    report.relative_residual = std::numeric_limits<double>::quiet_NaN();
    report.residual_history.push_back(report.relative_residual);
    throw SolverError(backend + " (" + label + "): the solution contains NaN or Inf after " +
                          std::to_string(report.iterations) + " iterations",
                      report);
  }
  report.relative_residual = relative_residual(a, x, b);
  report.residual_history.push_back(report.relative_residual);
  // Eigen stops on its recursively updated residual; the true one may lag a little behind it.
  if (solver.info() != Eigen::Success || !(report.relative_residual <= 10.0 * tol)) {
    std::ostringstream msg;
    msg << backend << " (" << label << "): no convergence after " << report.iterations << " of max_iter "
        << max_iter << " iterations, relative residual " << report.relative_residual << " (initial "
        << report.residual_history.front() << ") > tol " << tol
        << "; raise max_iter, loosen tol, or pick a stronger solver (hypre-pcg, cholmod)";
    throw SolverError(msg.str(), report);
  }
  return report;
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
    using Cg = Eigen::ConjugateGradient<RowMatrix, Eigen::Lower | Eigen::Upper, Preconditioner>;
    return run_eigen<Cg>("eigen-cg", "precond=" + precond_, tol_, max_iter_, true, a, b, x, [](Cg&) {});
  }

  std::string precond_, ordering_;
  double tol_;
  int max_iter_;
  std::string spec_;
};

class EigenBicgstab final : public LinearSolver {
 public:
  explicit EigenBicgstab(const SolverOptions& o)
      : precond_(o.choice("precond", {"ilut", "jacobi"})),
        tol_(o.number("tol", 1e-16, 1e-1)),
        droptol_(o.number("droptol", 0.0, 1.0)),
        fill_(o.integer("fill", 1, 100)),
        max_iter_(o.integer("max_iter", 1, 100000000)),
        spec_(o.spec()) {}

  SolveReport solve(const CsrMatrix& a, std::span<const double> b, std::span<double> x) override {
    const std::string label = "precond=" + precond_;
    if (precond_ == "jacobi") {
      using Bicg = Eigen::BiCGSTAB<RowMatrix, Eigen::DiagonalPreconditioner<double>>;
      return run_eigen<Bicg>("eigen-bicgstab", label, tol_, max_iter_, false, a, b, x, [](Bicg&) {});
    }
    using Bicg = Eigen::BiCGSTAB<RowMatrix, Eigen::IncompleteLUT<double, int>>;
    return run_eigen<Bicg>("eigen-bicgstab", label, tol_, max_iter_, false, a, b, x, [this](Bicg& s) {
      s.preconditioner().setDroptol(droptol_);
      s.preconditioner().setFillfactor(fill_);
    });
  }
  [[nodiscard]] std::string spec() const override { return spec_; }

 private:
  std::string precond_;
  double tol_, droptol_;
  int fill_, max_iter_;
  std::string spec_;
};

}  // namespace

SolverEntry eigen_cg_entry() {
  return {"eigen-cg",
          "Eigen conjugate gradients; the classic MPS baseline with precond=ic. Threads only its SpMV.",
          {{"precond", "ic", "ic (incomplete Cholesky, Eigen's IncompleteCholesky) | jacobi"},
           {"ordering", "natural", "IC fill ordering: natural (cell-sorted particles) | amd"},
           {"tol", "1e-8", "relative residual ||b-Ax||/||b|| to reach"},
           {"max_iter", "10000", "iterations before the solve is reported as failed"}},
          [](const SolverOptions& o, const SolverContext&) { return std::make_unique<EigenCg>(o); }};
}

SolverEntry eigen_bicgstab_entry() {
  return {"eigen-bicgstab",
          "Eigen BiCGSTAB; also takes nonsymmetric matrices. Two SpMVs per iteration, so slower than CG on the PPE.",
          {{"precond", "ilut", "ilut (incomplete LU with threshold, AMD-ordered) | jacobi"},
           {"droptol", "1e-4", "ILUT: entries below droptol * (row norm) are dropped"},
           {"fill", "2", "ILUT: at most fill * (nnz per row of A) entries per row of L and of U"},
           {"tol", "1e-8", "relative residual ||b-Ax||/||b|| to reach"},
           {"max_iter", "10000", "iterations before the solve is reported as failed"}},
          [](const SolverOptions& o, const SolverContext&) { return std::make_unique<EigenBicgstab>(o); }};
}

}  // namespace mps
