// PETSc's KSP for the petsc backend, a module the library opens at the first petsc solver (petsc.cpp reads the spec
// and checks every input). PETSc's options live under a prefix of this solver's own, so solvers never read each
// other's; PETSc's errors come back as exceptions, never printed, and its signal handlers stay off.
#include <petscksp.h>

#include <algorithm>
#include <mutex>
#include <sstream>
#include <type_traits>
#include <vector>

#include "mps/solvers/backend_util.hpp"
#include "mps/solvers/petsc_module.hpp"

namespace mps {
namespace {

using solver_detail::Clock;
using solver_detail::any_rank;
using solver_detail::seconds_since;

std::mutex& petsc_mutex() {
  static auto* m = new std::mutex;  // never destroyed: solvers may be destroyed during static destruction
  return *m;
}
bool g_petsc_finalised = false;
std::string g_petsc_error;  // the first message of the last error PETSc raised (under petsc_mutex)

PetscErrorCode remember_error(MPI_Comm, int, const char* function, const char*, PetscErrorCode code,
                              PetscErrorType type, const char* message, void*) {
  if (type == PETSC_ERROR_INITIAL)
    g_petsc_error = std::string(message != nullptr ? message : "") + " (in " + (function != nullptr ? function : "?") +
                    ")";
  return code;
}

// PetscFinalize needs MPI: it runs as MPI_Finalize begins (which first deletes MPI_COMM_SELF's attributes), whoever
// calls MPI_Finalize and when: the host program, or our own finaliser at exit.
int finalize_petsc(MPI_Comm, int, void*, void*) {
  const std::lock_guard lock(petsc_mutex());
  PetscFinalize();
  g_petsc_finalised = true;
  return MPI_SUCCESS;
}

void ensure_runtime() {
  static std::once_flag once;
  std::call_once(once, [] {
    solver_detail::ensure_mpi("petsc");
    const std::lock_guard lock(petsc_mutex());
    if (PetscOptionsSetValue(nullptr, "-no_signal_handler", nullptr) != 0 || PetscInitializeNoArguments() != 0)
      throw std::runtime_error("petsc: PetscInitialize failed");
    PetscPushErrorHandler(remember_error, nullptr);
    int key = MPI_KEYVAL_INVALID;
    MPI_Comm_create_keyval(MPI_COMM_NULL_COPY_FN, finalize_petsc, &key, nullptr);
    MPI_Comm_set_attr(MPI_COMM_SELF, key, nullptr);
  });
}

// Throws SolverError naming the call and PETSc's own message if a PETSc call failed.
void check(PetscErrorCode code, const char* call, const SolveReport& report) {
  if (code == 0) return;
  throw SolverError("petsc: " + std::string(call) + " failed: " + g_petsc_error, report);
}

// Our 32-bit indices as PetscInt, converted only when PETSc was built with wider ones.
const PetscInt* as_petsc(const std::vector<int>& v, std::vector<PetscInt>& scratch) {
  if constexpr (std::is_same_v<PetscInt, int>) {
    return v.data();
  } else {
    scratch.assign(v.begin(), v.end());
    return scratch.data();
  }
}

class KspSolver final : public LinearSolver {
 public:
  explicit KspSolver(const petsc_module::Request& request)
      : tol_(request.tol),
        max_iter_(request.max_iter),
        reuse_(request.reuse),
        spec_(request.spec),
        symmetric_(request.options.at("ksp_type") == "cg") {
    ensure_runtime();
    comm_ = request.mpi_comm ? MPI_Comm_f2c(*request.mpi_comm) : MPI_COMM_SELF;
    if (comm_ == MPI_COMM_NULL)
      throw std::invalid_argument("petsc: the communicator passed in SolverContext is MPI_COMM_NULL");
    const std::lock_guard lock(petsc_mutex());
    static int made = 0;
    prefix_ = "sparsemps" + std::to_string(made++) + "_";
    const SolveReport none;
    try {
      for (const auto& [key, value] : request.options) {
        passed_.push_back(key);
        check(PetscOptionsSetValue(nullptr, option(key).c_str(), value.c_str()), "PetscOptionsSetValue", none);
      }
      make_ksp(none);
    } catch (const SolverError& e) {
      clear();
      throw std::invalid_argument(std::string(e.what()) + " (spec " + spec_ + ")");
    }
    unread_ = passed_;
    forget_read_options();
    // A sub-solver's options (mg_levels_ksp_type, sub_pc_type, ...) are read at the first setup, the rest by now.
    std::string misread;
    for (const auto& key : unread_)
      if (!sub_solver_option(key)) misread += (misread.empty() ? "" : ", ") + key;
    if (!misread.empty()) {
      clear();
      throw std::invalid_argument(unread_message(misread));
    }
  }
  ~KspSolver() override {
    const std::lock_guard lock(petsc_mutex());
    clear();
  }
  KspSolver(const KspSolver&) = delete;
  KspSolver& operator=(const KspSolver&) = delete;

  SolveReport solve(const CsrMatrix& a, std::span<const double> b, std::span<double> x) override {
    const std::lock_guard lock(petsc_mutex());
    SolveReport report;
    report.backend = "petsc";
    const long long rows = a.rows;
    long long total = 0;
    MPI_Allreduce(&rows, &total, 1, MPI_LONG_LONG, MPI_SUM, comm_);
    if (total == 0) return report;

    const auto t0 = Clock::now();
    bool converged = false;
    Mat m = nullptr;
    Vec vb = nullptr, vx = nullptr, vr = nullptr;
    auto destroy = [&] {
      MatDestroy(&m);
      VecDestroy(&vb);
      VecDestroy(&vx);
      VecDestroy(&vr);
    };
    try {
      std::vector<PetscInt> row_scratch, col_scratch;
      const PetscInt* row_ptr = as_petsc(a.row_ptr, row_scratch);
      const PetscInt* col = as_petsc(a.col, col_scratch);
      check(MatCreate(comm_, &m), "MatCreate", report);
      check(MatSetSizes(m, a.rows, a.rows, static_cast<PetscInt>(total), static_cast<PetscInt>(total)), "MatSetSizes",
            report);
      check(MatSetType(m, MATAIJ), "MatSetType", report);
      // Only the call matching the matrix's type (one rank or more) acts; both copy our arrays.
      check(MatSeqAIJSetPreallocationCSR(m, row_ptr, col, a.val.data()), "MatSeqAIJSetPreallocationCSR", report);
      check(MatMPIAIJSetPreallocationCSR(m, row_ptr, col, a.val.data()), "MatMPIAIJSetPreallocationCSR", report);
      check(MatCreateVecs(m, &vx, &vb), "MatCreateVecs", report);
      check(VecDuplicate(vb, &vr), "VecDuplicate", report);
      set(vb, b, report);
      set(vx, x, report);
      // The hierarchy (or factorisation) is kept for `reuse` further solves while the unknown count holds.
      const bool count_changed = any_rank(a.rows != setup_rows_, comm_);
      const bool reuse = !count_changed && reuses_ < reuse_ && !rebuild_pending_;
      report.setup_reused = reuse;
      // A KSP keeps its sizes once used: a new count needs a new one.
      if (count_changed && setup_rows_ >= 0) {
        KSPDestroy(&ksp_);
        make_ksp(report);
      }
      converged = run(m, vb, vx, reuse, t0, report);
      if (!converged && reuse) {  // a stale preconditioner is the likeliest cause: rebuild it and solve again
        set(vx, x, report);
        const double first_setup = report.setup_seconds;
        report.setup_reused = false;
        converged = run(m, vb, vx, false, Clock::now(), report);
        report.setup_seconds += first_setup;
      }
      if (report.setup_reused) {
        ++reuses_;
      } else {
        reuses_ = 0;
        setup_rows_ = a.rows;
      }
      rebuild_pending_ = !converged;
      get(vx, x, report);
      report.relative_residual = true_residual(m, vb, vx, vr, report);
    } catch (...) {
      destroy();
      throw;
    }
    destroy();
    if (any_rank(!solver_detail::all_finite(x), comm_) || !std::isfinite(report.relative_residual))
      throw SolverError("petsc: the solution contains NaN or Inf after " + std::to_string(report.iterations) +
                            " iterations (matrix not symmetric positive definite for " + spec_ + "?)",
                        report);
    if (!converged) {
      std::ostringstream msg;
      msg << "petsc: no convergence (PETSc: " << reason_ << ") after " << report.iterations << " of max_iter "
          << max_iter_ << " iterations, relative residual " << report.relative_residual << " (tol " << tol_ << ", "
          << spec_ << "); raise max_iter, loosen tol or choose another ksp_type/pc_type";
      throw SolverError(msg.str(), report);
    }
    return report;
  }

  [[nodiscard]] std::string spec() const override { return spec_; }
  void renumbered() override { rebuild_pending_ = true; }  // a kept preconditioner is tied to the rows' order
  [[nodiscard]] bool keeps_setup() const override { return setup_rows_ >= 0 && !rebuild_pending_ && reuses_ < reuse_; }

 private:
  // A KSP reading the spec's options (under this solver's prefix), with our defaults beneath them.
  void make_ksp(const SolveReport& report) {
    check(KSPCreate(comm_, &ksp_), "KSPCreate", report);
    check(KSPSetOptionsPrefix(ksp_, prefix_.c_str()), "KSPSetOptionsPrefix", report);
    check(KSPSetTolerances(ksp_, tol_, 0.0, PETSC_DEFAULT, max_iter_), "KSPSetTolerances", report);
    // CG measures its preconditioned residual by default; the true one makes tol mean ||b - Ax||/||b||, as in
    // every other backend (ksp_norm_type overrides it; other Krylov methods keep PETSc's default norm).
    if (symmetric_)
      check(KSPSetNormType(ksp_, KSP_NORM_UNPRECONDITIONED), "KSPSetNormType", report);
    check(KSPSetInitialGuessNonzero(ksp_, PETSC_TRUE), "KSPSetInitialGuessNonzero", report);
    check(KSPSetResidualHistory(ksp_, nullptr, PETSC_DECIDE, PETSC_TRUE), "KSPSetResidualHistory", report);
    check(KSPSetFromOptions(ksp_), "KSPSetFromOptions", report);
    // A direct solve (preonly with a factorisation) takes no initial guess.
    PetscBool preonly = PETSC_FALSE;
    check(PetscObjectTypeCompare(reinterpret_cast<PetscObject>(ksp_), KSPPREONLY, &preonly), "KSPGetType", report);
    if (preonly) check(KSPSetInitialGuessNonzero(ksp_, PETSC_FALSE), "KSPSetInitialGuessNonzero", report);
  }

  [[nodiscard]] std::string option(const std::string& key) const { return "-" + prefix_ + key; }

  static bool sub_solver_option(const std::string& key) {
    for (const char* prefix : {"mg_", "sub_", "fieldsplit_", "redundant_", "telescope_"})
      if (key.rfind(prefix, 0) == 0) return true;
    return false;
  }
  [[nodiscard]] std::string unread_message(const std::string& keys) const {
    return "solver 'petsc': PETSc read no option " + keys + " with " + spec_ +
           " (misspelt, or not one that the chosen ksp_type and pc_type take; PETSc's manual pages list each type's "
           "options, without their leading dash here)";
  }

  // The options PETSc has read so far leave unread_; a sub-solver's (mg_levels_ksp_type, ...) are read only at the
  // first setup, after which whatever is left was never going to be read.
  void forget_read_options() {
    std::vector<std::string> still;
    for (const auto& key : unread_) {
      PetscBool used = PETSC_FALSE;
      PetscOptionsUsed(nullptr, (prefix_ + key).c_str(), &used);  // the database keeps names without the dash
      if (!used) still.push_back(key);
    }
    unread_ = std::move(still);
  }

  // The solver's KSP and its options leave PETSc with it.
  void clear() {
    if (g_petsc_finalised) return;
    if (ksp_ != nullptr) KSPDestroy(&ksp_);
    for (const auto& key : passed_) PetscOptionsClearValue(nullptr, option(key).c_str());
  }

  void set(Vec v, std::span<const double> values, const SolveReport& report) const {
    PetscScalar* data = nullptr;
    check(VecGetArray(v, &data), "VecGetArray", report);
    std::copy(values.begin(), values.end(), data);
    check(VecRestoreArray(v, &data), "VecRestoreArray", report);
  }
  void get(Vec v, std::span<double> values, const SolveReport& report) const {
    const PetscScalar* data = nullptr;
    check(VecGetArrayRead(v, &data), "VecGetArrayRead", report);
    std::copy(data, data + values.size(), values.begin());
    check(VecRestoreArrayRead(v, &data), "VecRestoreArrayRead", report);
  }

  // One setup (unless reused) and solve; true if PETSc reports convergence.
  bool run(Mat m, Vec vb, Vec vx, bool reuse, Clock::time_point t0, SolveReport& report) {
    check(KSPSetOperators(ksp_, m, m), "KSPSetOperators", report);
    check(KSPSetReusePreconditioner(ksp_, reuse ? PETSC_TRUE : PETSC_FALSE), "KSPSetReusePreconditioner", report);
    check(KSPSetUp(ksp_), "KSPSetUp", report);
    if (!unread_.empty()) {
      forget_read_options();
      if (!unread_.empty()) {
        std::string keys;
        for (const auto& key : unread_) keys += (keys.empty() ? "" : ", ") + key;
        throw SolverError(unread_message(keys), report);
      }
    }
    report.setup_seconds = seconds_since(t0);
    const auto t1 = Clock::now();
    check(KSPSolve(ksp_, vb, vx), "KSPSolve", report);
    report.solve_seconds = seconds_since(t1);
    PetscInt iterations = 0;
    KSPGetIterationNumber(ksp_, &iterations);
    report.iterations = static_cast<int>(iterations);
    KSPConvergedReason reason = KSP_CONVERGED_ITERATING;
    KSPGetConvergedReason(ksp_, &reason);
    reason_ = KSPConvergedReasons[reason];
    PetscReal b_norm = 0.0;
    VecNorm(vb, NORM_2, &b_norm);
    const PetscReal* history = nullptr;
    PetscInt count = 0;
    KSPGetResidualHistory(ksp_, &history, &count);
    report.residual_history.clear();
    for (PetscInt i = 0; i < count; ++i) report.residual_history.push_back(b_norm > 0 ? history[i] / b_norm : 0.0);
    return reason > 0;
  }

  double true_residual(Mat m, Vec vb, Vec vx, Vec vr, const SolveReport& report) const {
    check(MatMult(m, vx, vr), "MatMult", report);
    check(VecAYPX(vr, -1.0, vb), "VecAYPX", report);
    PetscReal r = 0.0, b_norm = 0.0;
    VecNorm(vr, NORM_2, &r);
    VecNorm(vb, NORM_2, &b_norm);
    return b_norm > 0.0 ? r / b_norm : r;
  }

  double tol_;
  int max_iter_, reuse_;
  std::string spec_, prefix_, reason_;
  std::vector<std::string> passed_;  // the spec's PETSc options
  std::vector<std::string> unread_;  // those PETSc has not read yet
  MPI_Comm comm_ = MPI_COMM_SELF;
  KSP ksp_ = nullptr;
  int setup_rows_ = -1, reuses_ = 0;
  bool symmetric_;  // ksp_type=cg: the matrix must be symmetric positive definite
  bool rebuild_pending_ = false;
};

}  // namespace

}  // namespace mps

extern "C" mps::LinearSolver* sparsemps_petsc_make(const mps::petsc_module::Request& request) {
  return new mps::KspSolver(request);
}
