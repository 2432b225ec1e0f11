// SuiteSparse CHOLMOD: supernodal Cholesky LL^T through its C API. The supernodal kernels are dense BLAS
// calls, so the speed comes from the BLAS CHOLMOD is linked with (Debian's OpenBLAS, through the libblas.so.3
// alternative). The symbolic analysis (fill-reducing ordering, elimination tree, supernodes) is kept and
// reused for as long as the sparsity pattern does not change; only the numeric factorisation is redone.
#include <cholmod.h>

#include <algorithm>
#include <cmath>
#include <sstream>

#include "mps/solvers/backend_util.hpp"
#include "mps/solvers/registry.hpp"

namespace mps {
namespace {

using solver_detail::Clock;
using solver_detail::seconds_since;

std::string status_text(int status) {
  switch (status) {
    case CHOLMOD_OK:
      return "ok";
    case CHOLMOD_NOT_INSTALLED:
      return "method not installed";
    case CHOLMOD_OUT_OF_MEMORY:
      return "out of memory";
    case CHOLMOD_TOO_LARGE:
      return "integer overflow (matrix too large)";
    case CHOLMOD_INVALID:
      return "invalid input";
    case CHOLMOD_NOT_POSDEF:
      return "matrix not positive definite";
    case CHOLMOD_DSMALL:
      return "tiny diagonal entry in the factor";
    default:
      return "status " + std::to_string(status);
  }
}

class Cholmod final : public LinearSolver {
 public:
  explicit Cholmod(const SolverOptions& o)
      : ordering_(o.choice("ordering", {"auto", "amd", "metis", "nesdis", "natural"})), spec_(o.spec()) {
    cholmod_start(&common_);
    common_.print = 0;  // errors are reported through SolverError, not printed
    common_.supernodal = CHOLMOD_SUPERNODAL;
    common_.quick_return_if_not_posdef = 1;
    if (ordering_ != "auto") {
      common_.nmethods = 1;
      common_.method[0].ordering = ordering_ == "amd"      ? CHOLMOD_AMD
                                   : ordering_ == "metis"  ? CHOLMOD_METIS
                                   : ordering_ == "nesdis" ? CHOLMOD_NESDIS
                                                           : CHOLMOD_NATURAL;
      common_.postorder = ordering_ != "natural";
    }
  }
  ~Cholmod() override {
    forget_analysis();
    cholmod_finish(&common_);
  }
  Cholmod(const Cholmod&) = delete;
  Cholmod& operator=(const Cholmod&) = delete;

  SolveReport solve(const CsrMatrix& a, std::span<const double> b, std::span<double> x) override {
    SolveReport report;
    report.backend = "cholmod";
    // Symmetry checked: CHOLMOD reads one triangle, and would factorise a nonsymmetric matrix as something else.
    solver_detail::check_serial_input("cholmod", a, b, x, report, true);
    const std::size_t n = b.size();
    if (n == 0) return report;

    const auto t0 = Clock::now();
    // The CSR arrays of a symmetric matrix are the CSC arrays of the same matrix: view them without copying.
    // stype = 1 makes CHOLMOD read the upper triangle of the CSC view and ignore the rest.
    cholmod_sparse view{};
    view.nrow = view.ncol = n;
    view.nzmax = a.nnz();
    view.p = const_cast<int*>(a.row_ptr.data());
    view.i = const_cast<int*>(a.col.data());
    view.x = const_cast<double*>(a.val.data());
    view.stype = 1;
    view.itype = CHOLMOD_INT;
    view.xtype = CHOLMOD_REAL;
    view.dtype = CHOLMOD_DOUBLE;
    view.sorted = 1;
    view.packed = 1;

    report.setup_reused = factor_ != nullptr && a.row_ptr == pattern_row_ptr_ && a.col == pattern_col_;
    if (!report.setup_reused) {
      forget_analysis();
      factor_ = cholmod_analyze(&view, &common_);
      if (factor_ == nullptr || common_.status < CHOLMOD_OK) {
        report.setup_seconds = seconds_since(t0);
        forget_analysis();
        throw SolverError("cholmod: symbolic analysis failed: " + status_text(common_.status), report);
      }
      pattern_row_ptr_ = a.row_ptr;
      pattern_col_ = a.col;
    }
    const int ok = cholmod_factorize(&view, factor_, &common_);
    report.setup_seconds = seconds_since(t0);
    if (common_.status == CHOLMOD_NOT_POSDEF) {
      std::ostringstream msg;
      msg << "cholmod: the matrix is not positive definite (the Cholesky pivot of column " << factor_->minor << " of "
          << n << ", in the fill-reducing order, is not positive); the PPE is SPD only when every group of unknowns "
          << "touches a free surface or carries the closed-domain gauge";
      forget_analysis();  // the factor is half-built; start from a fresh analysis next time
      throw SolverError(msg.str(), report);
    }
    if (!ok || common_.status < CHOLMOD_OK) {
      forget_analysis();
      throw SolverError("cholmod: numeric factorisation failed: " + status_text(common_.status), report);
    }

    const auto t1 = Clock::now();
    cholmod_dense rhs{};
    rhs.nrow = rhs.d = rhs.nzmax = n;
    rhs.ncol = 1;
    rhs.x = const_cast<double*>(b.data());
    rhs.xtype = CHOLMOD_REAL;
    rhs.dtype = CHOLMOD_DOUBLE;
    cholmod_dense* solution = cholmod_solve(CHOLMOD_A, factor_, &rhs, &common_);
    if (solution == nullptr) throw SolverError("cholmod: solve failed: " + status_text(common_.status), report);
    const auto* values = static_cast<const double*>(solution->x);
    std::copy(values, values + n, x.begin());
    cholmod_free_dense(&solution, &common_);
    report.solve_seconds = seconds_since(t1);
    report.iterations = 1;  // one forward and one backward triangular solve
    report.relative_residual = relative_residual(a, x, b);
    report.residual_history.push_back(report.relative_residual);
    if (!solver_detail::all_finite(x) || !std::isfinite(report.relative_residual))
      throw SolverError("cholmod: the solution contains NaN or Inf", report);
    return report;
  }
  [[nodiscard]] std::string spec() const override { return spec_; }

 private:
  void forget_analysis() {
    if (factor_ != nullptr) cholmod_free_factor(&factor_, &common_);
    factor_ = nullptr;
    pattern_row_ptr_.clear();
    pattern_col_.clear();
  }

  std::string ordering_;
  std::string spec_;
  cholmod_common common_{};
  cholmod_factor* factor_ = nullptr;
  std::vector<int> pattern_row_ptr_, pattern_col_;  // the pattern factor_'s analysis was made for
};

}  // namespace

SolverEntry cholmod_entry() {
  return {"cholmod",
          "SuiteSparse CHOLMOD supernodal Cholesky LL^T (OpenBLAS). Exact to rounding; reuses the symbolic "
          "analysis while the pattern is unchanged. Best below ~1e5 unknowns or for many right-hand sides; "
          "memory and time grow fastest with N. Requires a symmetric positive definite matrix.",
          {{"ordering", "auto",
            "fill-reducing ordering: auto (AMD, METIS if AMD fills badly) | amd | metis | nesdis | natural"}},
          [](const SolverOptions& o, const SolverContext&) { return std::make_unique<Cholmod>(o); }};
}

}  // namespace mps
