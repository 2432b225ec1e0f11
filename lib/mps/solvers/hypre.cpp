// hypre BoomerAMG through the IJ/ParCSR interface: hypre-amg (AMG V-cycles as the solver) and hypre-pcg
// (conjugate gradients preconditioned by one V-cycle).
//
// Process-wide runtime: MPI is initialised on first use if the host program has not done it (a singleton
// MPI_Init needs no mpirun; finalised at exit only if we started it), HYPRE_Init runs once, and an atexit handler
// runs HYPRE_Finalize once. hypre is not re-entrant, so every call into it holds one process-wide mutex.
//
// Setup reuse (reuse=N): the AMG hierarchy built for one matrix preconditions up to N further solves while
// the number of unknowns stays the same; the finest level always smooths with the current matrix (BoomerAMG
// takes the matrix it is given at solve time as level 0), the coarse levels stay those of the setup. The
// hierarchy is rebuilt when N reuses are spent, when the unknown count changes, after a solve whose
// iterations exceed 1.5x those of the first solve after the setup, and immediately (with the solve redone)
// if a reused hierarchy fails to converge. With refresh=galerkin a kept hierarchy's coarse operators are made again
// from the new matrix whenever rows joined or left the solve (a free surface's, with a row for every particle:
// PpeRows::every_particle; on ranks the numbering then holds between migrations), its coarsening and interpolation
// kept.
#include <HYPRE.h>
#include <HYPRE_IJ_mv.h>
#include <HYPRE_krylov.h>
#include <HYPRE_parcsr_ls.h>
#include <HYPRE_parcsr_mv.h>
#include <HYPRE_utilities.h>
#include <_hypre_parcsr_ls.h>  // hypre_ParAMGData: refresh=galerkin redoes a kept hierarchy's coarse operators
#include <_hypre_parcsr_mv.h>  // hypre_ParCSRMatrix internals: on one rank A is lent, its filtered copy filled
#include <krylov.h>             // hypre_PCGData: the per-iteration residual norms PCG logs (no public getter for them)
#include <mpi.h>

#include <algorithm>
#include <cstdlib>
#include <limits>
#include <mutex>
#include <span>
#include <sstream>
#include <type_traits>

#include "mps/solvers/backend_util.hpp"
#include "mps/solvers/registry.hpp"

namespace mps {
namespace {

using solver_detail::Clock;
using solver_detail::any_rank;
using solver_detail::seconds_since;

// ---------------------------------------------------------------------------------------------------------
// Runtime: MPI and hypre, initialised once, finalised once at exit.

std::mutex& hypre_mutex() {
  static auto* m = new std::mutex;  // never destroyed: solvers may be destroyed during static destruction
  return *m;
}
bool g_runtime_finalised = false;  // after the atexit handler: hypre objects are leaked, not destroyed

void ensure_runtime() {
  static std::once_flag once;
  std::call_once(once, [] {
    solver_detail::ensure_mpi("hypre");
    if (HYPRE_Init() != 0) throw std::runtime_error("hypre: HYPRE_Init failed");
    // Registered after MPI/hypre are up, so it runs after the destructors of solvers created from now on, and
    // before MPI's finaliser.
    std::atexit([] {
      const std::lock_guard lock(hypre_mutex());
      HYPRE_Finalize();
      g_runtime_finalised = true;
    });
  });
}

std::string describe_error(HYPRE_Int code) {
  char text[512] = {};
  HYPRE_DescribeError(code, text);
  return text;
}

// Throws SolverError if a hypre call reported an error.
void check(HYPRE_Int code, const std::string& backend, const char* call, const SolveReport& report) {
  if (code == 0) return;
  const std::string text = describe_error(code);
  HYPRE_ClearAllErrors();
  throw SolverError(backend + ": " + call + " failed: " + text, report);
}

// ---------------------------------------------------------------------------------------------------------
// One linear system handed to hypre: A, b, x (the warm start) and a residual vector, destroyed together.

struct ParVector {
  HYPRE_IJVector ij = nullptr;
  HYPRE_ParVector par = nullptr;
};

struct ParSystem {
  HYPRE_ParCSRMatrix a = nullptr;
  HYPRE_ParCSRMatrix m = nullptr;  // the matrix the AMG preconditioner is built on: a, or a filtered
  ParVector b, x, r;
  ParSystem() = default;
  ParSystem(const ParSystem&) = delete;
  ParSystem& operator=(const ParSystem&) = delete;
  ~ParSystem() {
    if (g_runtime_finalised) return;
    for (ParVector* v : {&b, &x, &r})
      if (v->ij != nullptr) HYPRE_IJVectorDestroy(v->ij);
  }
};

// On one rank hypre reads A from the caller's arrays: a copy doubled the PPE's memory (docs/benchmarks.md). Its
// smoothers take each row's first entry as the diagonal, so each diagonal swaps to the front for the solve and back
// after it: the order a copy had, so the same sums and the same numbers.
class SwappedDiagonals {
 public:
  SwappedDiagonals() = default;
  SwappedDiagonals(const SwappedDiagonals&) = delete;
  SwappedDiagonals& operator=(const SwappedDiagonals&) = delete;
  ~SwappedDiagonals() { swap_all(); }  // a swap undoes itself
  // slot[r]: where row r's diagonal sits in a's own order. a's arrays are the caller's, changed only until the
  // solve returns.
  void swap(const CsrMatrix& a, std::span<const int> slot) {
    a_ = const_cast<CsrMatrix*>(&a);
    slot_ = slot;
    swap_all();
  }

 private:
  void swap_all() {
    if (a_ == nullptr) return;
    for (std::size_t r = 0; r < slot_.size(); ++r) {
      const auto first = static_cast<std::size_t>(a_->row_ptr[r]), d = static_cast<std::size_t>(slot_[r]);
      std::swap(a_->col[first], a_->col[d]);
      std::swap(a_->val[first], a_->val[d]);
    }
  }
  CsrMatrix* a_ = nullptr;
  std::span<const int> slot_;
};

// A ParCSR matrix kept from solve to solve, refilled in place while its rows and capacity fit.
struct KeptMatrix {
  hypre_ParCSRMatrix* matrix = nullptr;
  HYPRE_Int rows = -1, capacity = 0;
  HYPRE_BigInt first_row = -1;  // the global number of this rank's first row
  HYPRE_Int offd_capacity = 0;  // room for entries in other ranks' columns
  KeptMatrix() = default;
  KeptMatrix(const KeptMatrix&) = delete;
  KeptMatrix& operator=(const KeptMatrix&) = delete;
  ~KeptMatrix() {
    if (matrix != nullptr && !g_runtime_finalised) hypre_ParCSRMatrixDestroy(matrix);
  }
};

// The preconditioner of a filtered hypre-pcg: one V-cycle of the hierarchy built on the filtered matrix, smoothing
// with that matrix too, whatever matrix PCG passes.
struct FilteredPrecond {
  HYPRE_Solver amg;
  HYPRE_ParCSRMatrix m;
};

HYPRE_Int filtered_vcycle(HYPRE_Solver data, HYPRE_ParCSRMatrix /*a*/, HYPRE_ParVector b, HYPRE_ParVector x) {
  const auto* p = reinterpret_cast<const FilteredPrecond*>(data);
  return HYPRE_BoomerAMGSolve(p->amg, p->m, b, x);
}

struct Partition {
  MPI_Comm comm = MPI_COMM_SELF;
  int ranks = 1;
  HYPRE_BigInt ilower = 0, iupper = -1;  // this rank's rows, inclusive
  HYPRE_BigInt global_rows = 0;
  [[nodiscard]] HYPRE_Int local_rows() const { return static_cast<HYPRE_Int>(iupper - ilower + 1); }
};

// ---------------------------------------------------------------------------------------------------------
// BoomerAMG options shared by both backends.

struct AmgOptions {
  int coarsen_type, interp_type, p_max, relax_down, relax_up, relax_coarse, sweeps, agg_levels, max_levels;
  double strong_threshold;
};

int int_choice(const SolverOptions& o, const std::string& key, std::initializer_list<const char*> allowed) {
  return std::stoi(o.choice(key, allowed));
}

AmgOptions read_amg_options(const SolverOptions& o) {
  AmgOptions a{};
  a.coarsen_type = int_choice(o, "coarsen_type", {"0", "1", "3", "6", "8", "10", "21", "22"});
  a.interp_type = o.integer("interp_type", 0, 18);
  a.p_max = o.integer("p_max", 0, 100);
  a.strong_threshold = o.number("strong_threshold", 0.0, 1.0);
  const std::initializer_list<const char*> relax = {"0", "3", "4", "6", "7", "8", "13", "14", "16", "18"};
  a.relax_down = int_choice(o, "relax_down", relax);
  a.relax_up = int_choice(o, "relax_up", relax);
  a.relax_coarse = int_choice(o, "relax_coarse", {"0", "3", "4", "6", "7", "8", "9", "13", "14", "16", "18", "99"});
  a.sweeps = o.integer("sweeps", 1, 20);
  a.agg_levels = o.integer("agg_levels", 0, 25);
  a.max_levels = o.integer("max_levels", 2, 100);
  return a;
}

std::vector<SolverKey> amg_keys() {
  return {{"coarsen_type", "10", "BoomerAMG coarsening: 10 HMIS | 8 PMIS | 6 Falgout | 0 CLJP | 3 RS | 1 | 21 | 22"},
          {"interp_type", "6", "interpolation: 6 ext+i | 0 classical | 8 standard | 14 extended | ... (0-18)"},
          {"p_max", "4", "max interpolation entries per row (0: no limit)"},
          {"strong_threshold", "0.25", "strength threshold (0.25 for 2-D, ~0.5 for 3-D)"},
          {"relax_down", "13",
           "smoother before restriction: 13 l1-Gauss-Seidel forward | 8 l1 sym. GS | 18 l1-Jacobi | ..."},
          {"relax_up", "14",
           "smoother after interpolation: 14 l1-Gauss-Seidel backward (13/14 keep the V-cycle symmetric)"},
          {"relax_coarse", "9", "coarsest level: 9 Gaussian elimination | 99 GE with pivoting | a smoother"},
          {"sweeps", "1", "smoothing sweeps per level, down and up"},
          {"agg_levels", "0", "levels of aggressive coarsening (cheaper setup, more iterations)"},
          {"max_levels", "25", "maximum number of AMG levels"}};
}

// A configured BoomerAMG that does exactly one V-cycle per HYPRE_BoomerAMGSolve call from the x it is given
// (tolerance 0, one iteration): the preconditioner of PCG, and the step of the hypre-amg loop.
HYPRE_Solver make_amg(const AmgOptions& o) {
  HYPRE_Solver amg = nullptr;
  HYPRE_BoomerAMGCreate(&amg);
  HYPRE_BoomerAMGSetCoarsenType(amg, o.coarsen_type);
  HYPRE_BoomerAMGSetInterpType(amg, o.interp_type);
  HYPRE_BoomerAMGSetPMaxElmts(amg, o.p_max);
  HYPRE_BoomerAMGSetStrongThreshold(amg, o.strong_threshold);
  HYPRE_BoomerAMGSetAggNumLevels(amg, o.agg_levels);
  HYPRE_BoomerAMGSetMaxLevels(amg, o.max_levels);
  HYPRE_BoomerAMGSetCycleRelaxType(amg, o.relax_down, 1);
  HYPRE_BoomerAMGSetCycleRelaxType(amg, o.relax_up, 2);
  HYPRE_BoomerAMGSetCycleRelaxType(amg, o.relax_coarse, 3);
  HYPRE_BoomerAMGSetCycleNumSweeps(amg, o.sweeps, 1);
  HYPRE_BoomerAMGSetCycleNumSweeps(amg, o.sweeps, 2);
  HYPRE_BoomerAMGSetCycleNumSweeps(amg, 1, 3);
  HYPRE_BoomerAMGSetRelaxOrder(amg, 0);  // lexicographic: forward down, backward up is then symmetric
  HYPRE_BoomerAMGSetTol(amg, 0.0);
  HYPRE_BoomerAMGSetMaxIter(amg, 1);
  HYPRE_BoomerAMGSetPrintLevel(amg, 0);
  HYPRE_BoomerAMGSetLogging(amg, 0);
  return amg;
}

// PCG must not redo the AMG setup (we build and keep the hierarchy ourselves).
HYPRE_Int no_setup(HYPRE_Solver, HYPRE_Matrix, HYPRE_Vector, HYPRE_Vector) { return 0; }

// ---------------------------------------------------------------------------------------------------------

enum class Method { amg, pcg };

class HypreSolver final : public LinearSolver {
 public:
  HypreSolver(Method method, const SolverOptions& o, const SolverContext& context)
      : method_(method),
        name_(method == Method::amg ? "hypre-amg" : "hypre-pcg"),
        amg_options_(read_amg_options(o)),
        tol_(o.number("tol", 1e-16, 1e-1)),
        max_iter_(o.integer("max_iter", 1, 100000)),
        reuse_(o.integer("reuse", 0, 1000000)),
        filter_(method == Method::pcg ? o.number("filter", 0.0, 1.0) : 0.0),
        galerkin_refresh_(o.choice("refresh", {"none", "galerkin"}) == "galerkin"),
        jacobi_(method == Method::pcg && o.choice("precond", {"amg", "jacobi"}) == "jacobi"),
        spec_(o.spec()) {
    if (jacobi_ && filter_ > 0.0)
      throw std::invalid_argument(name_ + ": filter builds the AMG preconditioner; precond=jacobi has none: leave "
                                          "filter out");
    if (jacobi_ && galerkin_refresh_)
      throw std::invalid_argument(name_ + ": refresh remakes the AMG hierarchy; precond=jacobi has none: leave "
                                          "refresh out");
    ensure_runtime();
    comm_ = context.mpi_comm ? MPI_Comm_f2c(*context.mpi_comm) : MPI_COMM_SELF;
    if (comm_ == MPI_COMM_NULL)
      throw std::invalid_argument(name_ + ": the communicator passed in SolverContext is MPI_COMM_NULL");
  }
  ~HypreSolver() override {
    const std::lock_guard lock(hypre_mutex());
    drop_hierarchy();
  }
  HypreSolver(const HypreSolver&) = delete;
  HypreSolver& operator=(const HypreSolver&) = delete;

  SolveReport solve(const CsrMatrix& a, std::span<const double> b, std::span<double> x) override {
    const std::lock_guard lock(hypre_mutex());
    HYPRE_ClearAllErrors();
    SolveReport report;
    report.backend = jacobi_ ? name_ + ":precond=jacobi" : name_;
    const Partition part = partition(a, b, x, report);
    if (part.global_rows == 0) return report;

    const auto t0 = Clock::now();
    ParSystem sys;
    SwappedDiagonals swapped;  // puts A's own order back however the solve ends
    upload(a, b, x, part, sys, swapped, report);
    const bool count_changed = any_rank(part.local_rows() != setup_local_rows_, comm_);
    // Jacobi has no hierarchy: hypre's DiagScale reads the diagonal in the solve itself.
    const bool rebuild = !jacobi_ && (amg_ == nullptr || count_changed || reuses_ >= reuse_ || rebuild_pending_);
    // Recorded at every solve, so that it compares with the matrix the hierarchy was last made or refreshed for.
    const bool lone_changed = galerkin_refresh_ && !jacobi_ && any_rank(lone_rows_changed(a), comm_);
    if (rebuild) build_hierarchy(sys, part, report);
    else if (lone_changed) refresh_or_drop(sys, report);
    report.setup_reused = !rebuild && !jacobi_;
    report.setup_seconds = seconds_since(t0);

    const std::vector<double> guess(x.begin(), x.end());
    const auto t1 = Clock::now();
    bool converged = run(sys, part, report);
    double retry_setup = 0.0;
    if (!converged && report.setup_reused) {
      // A stale hierarchy is the likeliest cause: rebuild it and solve again from the same guess.
      const auto t2 = Clock::now();
      set_vector(sys.x, part, guess, report);
      build_hierarchy(sys, part, report);
      retry_setup = seconds_since(t2);
      report.setup_reused = false;
      report.setup_seconds += retry_setup;
      converged = run(sys, part, report);
    }
    read_solution(sys, part, x, report);
    // A converged run has measured ||b - A x|| on the x it returns (the AMG loop at every cycle, PCG in its
    // recomputed final check); only a failed PCG run leaves the recursive residual, which may have drifted.
    if (!(converged && report.relative_residual >= 0.0)) report.relative_residual = true_residual(sys);
    report.solve_seconds = seconds_since(t1) - retry_setup;

    const bool bad_output = any_rank(!solver_detail::all_finite(x), comm_) || !std::isfinite(report.relative_residual);
    if (bad_output)
      throw SolverError(name_ + ": the solution contains NaN or Inf after " + std::to_string(report.iterations) +
                            " iterations (matrix not symmetric positive definite?)",
                        report);
    if (!converged || !(report.relative_residual <= 10.0 * tol_)) {
      std::ostringstream msg;
      msg << name_ << ": no convergence after " << report.iterations << " of max_iter " << max_iter_
          << " iterations, relative residual " << report.relative_residual << " > tol " << tol_;
      if (!report.residual_history.empty()) {
        msg << "; residual history:";
        const std::size_t n = report.residual_history.size();
        for (std::size_t i = 0; i < n; ++i) {
          if (n > 12 && i == 6) {
            msg << " ...";
            i = n - 6;
          }
          msg << " " << report.residual_history[i];
        }
      }
      msg << "; raise max_iter or loosen tol";
      drop_hierarchy();  // do not carry a hierarchy that just failed into the next solve
      throw SolverError(msg.str(), report);
    }

    if (report.setup_reused) ++reuses_;
    if (first_iterations_ < 0) {
      first_iterations_ = report.iterations;
    } else if (report.iterations > 1.5 * first_iterations_) {
      rebuild_pending_ = true;
    }
    return report;
  }

  [[nodiscard]] std::string spec() const override { return spec_; }
  // A hierarchy's interpolation maps rows by number: kept across a renumbering it costs tens of times the
  // iterations of a fresh one (docs/scaling.md).
  void renumbered() override { rebuild_pending_ = true; }
  [[nodiscard]] bool keeps_setup() const override { return amg_ != nullptr && !rebuild_pending_ && reuses_ < reuse_; }
  [[nodiscard]] bool wants_fixed_rows() const override { return galerkin_refresh_ && reuse_ > 0; }

 private:
  Partition partition(const CsrMatrix& a, std::span<const double> b, std::span<double> x, SolveReport& report) {
    Partition p;
    p.comm = comm_;
    MPI_Comm_size(comm_, &p.ranks);
    const long long local = a.rows;
    long long before = 0, total = 0;
    MPI_Exscan(&local, &before, 1, MPI_LONG_LONG, MPI_SUM, comm_);
    int rank = 0;
    MPI_Comm_rank(comm_, &rank);
    if (rank == 0) before = 0;
    MPI_Allreduce(&local, &total, 1, MPI_LONG_LONG, MPI_SUM, comm_);
    p.ilower = static_cast<HYPRE_BigInt>(before);
    p.iupper = static_cast<HYPRE_BigInt>(before + local - 1);
    p.global_rows = static_cast<HYPRE_BigInt>(total);

    // Structure, diagonals and (on one rank, where the whole matrix is here) symmetry, as the serial backends check.
    std::string bad_input;
    try {
      solver_detail::scan_rows(name_, a, static_cast<int>(p.ilower), scan_, report);
      solver_detail::check_diagonal(name_, a, static_cast<int>(p.ilower), scan_, true, report);
      // With a NaN or Inf in A the symmetry is moot: the finiteness check below names it.
      if (p.ranks == 1 && scan_.finite && !solver_detail::symmetric(a, scan_))
        throw SolverError(name_ + ": the matrix is not symmetric, which PCG and the symmetric smoothers need; use "
                                  "eigen-bicgstab for a nonsymmetric matrix",
                          report);
    } catch (const SolverError& e) {
      bad_input = e.what();
    }
    if (any_rank(!bad_input.empty(), comm_))
      throw SolverError(bad_input.empty() ? name_ + ": another rank's block of the matrix is malformed" : bad_input,
                        report);
    const bool sizes_bad =
        any_rank(b.size() != static_cast<std::size_t>(a.rows) || x.size() != b.size() || a.cols != total, comm_);
    if (sizes_bad)
      throw SolverError(name_ + ": matrix and vector sizes do not match (each rank passes its block of rows of a " +
                            "square matrix, with a.cols the global size)",
                        report);
    if (any_rank(!scan_.finite, comm_))
      throw SolverError(name_ + ": NaN or Inf in the matrix", report);
    if (any_rank(!solver_detail::all_finite(b), comm_))
      throw SolverError(name_ + ": NaN or Inf in the right-hand side", report);
    if (!solver_detail::all_finite(x))
      for (double& v : x) v = 0.0;
    return p;
  }

  void set_vector(ParVector& v, const Partition& part, std::span<const double> values, const SolveReport& report) {
    if (v.ij == nullptr) {
      check(HYPRE_IJVectorCreate(comm_, part.ilower, part.iupper, &v.ij), name_, "HYPRE_IJVectorCreate", report);
      HYPRE_IJVectorSetObjectType(v.ij, HYPRE_PARCSR);
    }
    check(HYPRE_IJVectorInitialize(v.ij), name_, "HYPRE_IJVectorInitialize", report);
    if (part.local_rows() > 0)
      check(HYPRE_IJVectorSetValues(v.ij, part.local_rows(), rows_.data(), values.data()), name_,
            "HYPRE_IJVectorSetValues", report);
    check(HYPRE_IJVectorAssemble(v.ij), name_, "HYPRE_IJVectorAssemble", report);
    void* object = nullptr;
    HYPRE_IJVectorGetObject(v.ij, &object);
    v.par = static_cast<HYPRE_ParVector>(object);
  }

  void upload(const CsrMatrix& a, std::span<const double> b, std::span<const double> x, const Partition& part,
              ParSystem& sys, SwappedDiagonals& swapped, const SolveReport& report) {
    const HYPRE_Int n = part.local_rows();
    rows_.resize(static_cast<std::size_t>(n));
    for (HYPRE_Int i = 0; i < n; ++i) rows_[static_cast<std::size_t>(i)] = part.ilower + i;
    const bool one_rank = part.ranks == 1;
    sys.m = sys.a = one_rank ? lend(a) : copy_kept(a, part, kept_, 0.0);
    if (filter_ > 0.0) {
      double largest = scan_.largest_off_diagonal;
      if (!one_rank) MPI_Allreduce(&scan_.largest_off_diagonal, &largest, 1, MPI_DOUBLE, MPI_MAX, comm_);
      sys.m = copy_kept(a, part, kept_filtered_, filter_ * largest);
    }
    // After the filtered copy, which reads a in its own order.
    if (one_rank) swapped.swap(a, scan_.diagonal);
    set_vector(sys.b, part, b, report);
    set_vector(sys.x, part, x, report);
    set_vector(sys.r, part, b, report);
  }

  // A's rows (on ranks), or its filtered matrix (entries below `threshold` lumped onto the diagonal as
  // lump_weak_entries does), copied into a ParCSR matrix kept from solve to solve, laid out as the IJ assembly lays
  // them out: in the diagonal block each row's diagonal swapped to the front (hypre's smoothers take a row's first
  // entry as its diagonal), in the off-diagonal block the entries in A's order, their columns numbered in increasing
  // global order. Through IJ every step allocated fresh matrices and filled them entry by entry (docs/scaling.md).
  // partition() has checked the structure and the diagonals.
  hypre_ParCSRMatrix* copy_kept(const CsrMatrix& a, const Partition& part, KeptMatrix& kept, double threshold) {
    const HYPRE_Int n = part.local_rows();
    const auto outside = [&](HYPRE_BigInt c) { return c < part.ilower || c > part.iupper; };
    offd_columns_.clear();
    HYPRE_Int diag_nnz = 0;
    for (HYPRE_Int r = 0; r < n; ++r) {
      const HYPRE_BigInt row = part.ilower + r;
      for (int k = a.row_ptr[static_cast<std::size_t>(r)]; k < a.row_ptr[static_cast<std::size_t>(r) + 1]; ++k) {
        const HYPRE_BigInt c = a.col[static_cast<std::size_t>(k)];
        if (c != row && std::abs(a.val[static_cast<std::size_t>(k)]) < threshold) continue;  // lumped
        if (outside(c))
          offd_columns_.push_back(c);
        else
          ++diag_nnz;
      }
    }
    const auto offd_nnz = static_cast<HYPRE_Int>(offd_columns_.size());
    std::sort(offd_columns_.begin(), offd_columns_.end());
    offd_columns_.erase(std::unique(offd_columns_.begin(), offd_columns_.end()), offd_columns_.end());
    const auto offd_cols = static_cast<HYPRE_Int>(offd_columns_.size());

    // Made anew on every rank together: a new matrix's assumed partition is made collectively.
    if (any_rank(kept.matrix == nullptr || kept.rows != n || kept.first_row != part.ilower ||
                     hypre_ParCSRMatrixGlobalNumRows(kept.matrix) != part.global_rows || kept.capacity < diag_nnz ||
                     kept.offd_capacity < offd_nnz,
                 comm_)) {
      if (kept.matrix != nullptr) hypre_ParCSRMatrixDestroy(kept.matrix);
      HYPRE_BigInt starts[2] = {part.ilower, part.iupper + 1};
      kept.capacity = diag_nnz + diag_nnz / 16;  // room for the pattern to grow a little from step to step
      kept.offd_capacity = offd_nnz + offd_nnz / 4 + 64;
      kept.matrix = hypre_ParCSRMatrixCreate(comm_, part.global_rows, part.global_rows, starts, starts, 0,
                                             kept.capacity, kept.offd_capacity);
      hypre_ParCSRMatrixInitialize(kept.matrix);
      kept.rows = n;
      kept.first_row = part.ilower;
    }
    hypre_ParCSRMatrix* m = kept.matrix;
    // The other ranks' columns this matrix reaches, and the exchange pattern of its products, made afresh.
    if (hypre_ParCSRMatrixCommPkg(m) != nullptr) hypre_MatvecCommPkgDestroy(hypre_ParCSRMatrixCommPkg(m));
    hypre_ParCSRMatrixCommPkg(m) = nullptr;
    hypre_TFree(hypre_ParCSRMatrixColMapOffd(m), HYPRE_MEMORY_HOST);
    hypre_ParCSRMatrixColMapOffd(m) = hypre_CTAlloc(HYPRE_BigInt, offd_cols, HYPRE_MEMORY_HOST);
    std::copy(offd_columns_.begin(), offd_columns_.end(), hypre_ParCSRMatrixColMapOffd(m));

    hypre_CSRMatrix* diag = hypre_ParCSRMatrixDiag(m);
    hypre_CSRMatrix* offd = hypre_ParCSRMatrixOffd(m);
    HYPRE_Int *diag_start = hypre_CSRMatrixI(diag), *diag_column = hypre_CSRMatrixJ(diag);
    HYPRE_Int *offd_start = hypre_CSRMatrixI(offd), *offd_column = hypre_CSRMatrixJ(offd);
    HYPRE_Complex *diag_value = hypre_CSRMatrixData(diag), *offd_value = hypre_CSRMatrixData(offd);
    HYPRE_Int dn = 0, on = 0;
    for (HYPRE_Int r = 0; r < n; ++r) {
      const HYPRE_BigInt row = part.ilower + r;
      const HYPRE_Int first = dn;
      diag_start[r] = dn;
      offd_start[r] = on;
      HYPRE_Int d = first;
      double lumped = 0.0;
      for (int k = a.row_ptr[static_cast<std::size_t>(r)]; k < a.row_ptr[static_cast<std::size_t>(r) + 1]; ++k) {
        const HYPRE_BigInt c = a.col[static_cast<std::size_t>(k)];
        const double v = a.val[static_cast<std::size_t>(k)];
        if (c == row) {
          d = dn;
        } else if (std::abs(v) < threshold) {
          lumped += v;
          continue;
        }
        if (outside(c)) {
          offd_column[on] = static_cast<HYPRE_Int>(
              std::lower_bound(offd_columns_.begin(), offd_columns_.end(), c) - offd_columns_.begin());
          offd_value[on++] = v;
        } else {
          diag_column[dn] = static_cast<HYPRE_Int>(c - part.ilower);
          diag_value[dn++] = v;
        }
      }
      diag_value[d] += lumped;
      std::swap(diag_column[first], diag_column[d]);
      std::swap(diag_value[first], diag_value[d]);
    }
    diag_start[n] = dn;
    offd_start[n] = on;
    hypre_CSRMatrixNumNonzeros(diag) = dn;
    hypre_CSRMatrixNumNonzeros(offd) = on;
    hypre_CSRMatrixNumCols(offd) = offd_cols;
    hypre_ParCSRMatrixSetNumNonzeros(m);
    hypre_ParCSRMatrixSetDNumNonzeros(m);
    hypre_MatvecCommPkgCreate(m);
    return m;
  }

  // A ParCSR matrix on one rank whose column and value arrays are a's own (hypre neither copies nor frees them);
  // only its row starts are hypre's. The caller swaps the diagonals to the front before hypre reads it.
  HYPRE_ParCSRMatrix lend(const CsrMatrix& a) {
    static_assert(std::is_same_v<HYPRE_Int, int> && std::is_same_v<HYPRE_Complex, double>,
                  "hypre built with other index or value types cannot read our CSR arrays");
    const HYPRE_Int n = a.rows;
    if (kept_.matrix == nullptr || kept_.rows != n) {
      if (kept_.matrix != nullptr) hypre_ParCSRMatrixDestroy(kept_.matrix);
      HYPRE_BigInt starts[2] = {0, static_cast<HYPRE_BigInt>(n)};
      kept_.matrix = hypre_ParCSRMatrixCreate(comm_, n, n, starts, starts, 0, 0, 0);
      hypre_ParCSRMatrixInitialize(kept_.matrix);  // with no entries: the row starts only
      hypre_CSRMatrixOwnsData(hypre_ParCSRMatrixDiag(kept_.matrix)) = 0;
      hypre_MatvecCommPkgCreate(kept_.matrix);
      kept_.rows = n;
    }
    hypre_CSRMatrix* diag = hypre_ParCSRMatrixDiag(kept_.matrix);
    std::copy(a.row_ptr.begin(), a.row_ptr.end(), hypre_CSRMatrixI(diag));
    hypre_CSRMatrixJ(diag) = const_cast<int*>(a.col.data());
    hypre_CSRMatrixData(diag) = const_cast<double*>(a.val.data());
    hypre_CSRMatrixNumNonzeros(diag) = static_cast<HYPRE_Int>(a.nnz());
    hypre_ParCSRMatrixSetNumNonzeros(kept_.matrix);
    hypre_ParCSRMatrixSetDNumNonzeros(kept_.matrix);
    return kept_.matrix;
  }

  void build_hierarchy(ParSystem& sys, const Partition& part, const SolveReport& report) {
    drop_hierarchy();
    amg_ = make_amg(amg_options_);
    check(HYPRE_BoomerAMGSetup(amg_, sys.m, sys.b.par, sys.x.par), name_, "HYPRE_BoomerAMGSetup", report);
    setup_local_rows_ = part.local_rows();
    reuses_ = 0;
    first_iterations_ = -1;
    rebuild_pending_ = false;
  }

  // Whether a row of A stands alone (its diagonal only) where it did not at the hierarchy's last matrix, or the
  // reverse: a particle that joined or left the solved rows (a free surface's), for which the kept coarse operators
  // were not made. Remembers this matrix's.
  bool lone_rows_changed(const CsrMatrix& a) {
    bool changed = lone_.size() != static_cast<std::size_t>(a.rows);
    lone_.resize(static_cast<std::size_t>(a.rows));
    for (std::size_t r = 0; r < lone_.size(); ++r) {
      const char lone = a.row_ptr[r + 1] - a.row_ptr[r] == 1 ? 1 : 0;
      changed = changed || lone != lone_[r];
      lone_[r] = lone;
    }
    return changed;
  }

  // A refresh that fails part-way leaves levels of two matrices: no hierarchy is kept then.
  void refresh_or_drop(ParSystem& sys, const SolveReport& report) {
    try {
      refresh_coarse_operators(sys, report);
    } catch (...) {
      drop_hierarchy();
      throw;
    }
  }

  // refresh=galerkin: the kept hierarchy's coarsening and interpolation P stay, and each coarse operator is made
  // again as P^T A P from the new matrix, with the smoothers' l1 norms and the coarsest level's dense copy. A
  // Galerkin hierarchy of an SPD matrix stays SPD, where coarse operators kept from an older matrix overshoot.
  void refresh_coarse_operators(ParSystem& sys, const SolveReport& report) {
    auto* data = reinterpret_cast<hypre_ParAMGData*>(amg_);
    const HYPRE_Int levels = hypre_ParAMGDataNumLevels(data);
    hypre_ParCSRMatrix** a = hypre_ParAMGDataAArray(data);
    hypre_ParCSRMatrix** p = hypre_ParAMGDataPArray(data);
    a[0] = reinterpret_cast<hypre_ParCSRMatrix*>(sys.m);  // the caller's, as BoomerAMGSolve sets it
    if (!hypre_ParCSRMatrixCommPkg(a[0])) hypre_MatvecCommPkgCreate(a[0]);  // an IJ matrix on ranks has none yet
    for (HYPRE_Int l = 0; l + 1 < levels; ++l) {
      hypre_ParCSRMatrix* coarse = nullptr;
      check(hypre_BoomerAMGBuildCoarseOperatorKT(p[l], a[l], p[l], 0, &coarse), name_,
            "hypre_BoomerAMGBuildCoarseOperatorKT", report);
      if (!hypre_ParCSRMatrixCommPkg(coarse)) hypre_MatvecCommPkgCreate(coarse);
      hypre_ParCSRMatrixDestroy(a[l + 1]);
      a[l + 1] = coarse;
    }
    if (hypre_Vector** l1 = hypre_ParAMGDataL1Norms(data); l1 != nullptr) {
      for (HYPRE_Int l = 0; l < levels; ++l) {
        if (l1[l] == nullptr) continue;
        HYPRE_Real* norms = nullptr;
        check(hypre_ParCSRComputeL1Norms(a[l], 4, nullptr, &norms), name_, "hypre_ParCSRComputeL1Norms", report);
        hypre_SeqVectorDestroy(l1[l]);
        l1[l] = hypre_SeqVectorCreate(hypre_ParCSRMatrixNumRows(a[l]));
        hypre_VectorData(l1[l]) = norms;
        hypre_SeqVectorInitialize_v2(l1[l], hypre_ParCSRMatrixMemoryLocation(a[l]));
      }
    }
    // The coarsest level solved by Gaussian elimination: its dense copy is made again on every rank together (a
    // rank without coarse rows holds none but takes part in the sub-communicator's making).
    if (hypre_ParAMGDataGSSetup(data)) {
      hypre_TFree(hypre_ParAMGDataAMat(data), HYPRE_MEMORY_HOST);
      hypre_TFree(hypre_ParAMGDataBVec(data), HYPRE_MEMORY_HOST);
      hypre_TFree(hypre_ParAMGDataCommInfo(data), HYPRE_MEMORY_HOST);
      hypre_ParAMGDataAMat(data) = nullptr;
      hypre_ParAMGDataBVec(data) = nullptr;
      hypre_ParAMGDataCommInfo(data) = nullptr;
      if (hypre_ParAMGDataNewComm(data) != hypre_MPI_COMM_NULL) hypre_MPI_Comm_free(&hypre_ParAMGDataNewComm(data));
      check(hypre_GaussElimSetup(data, levels - 1, amg_options_.relax_coarse), name_, "hypre_GaussElimSetup", report);
    }
  }

  void drop_hierarchy() {
    if (amg_ != nullptr && !g_runtime_finalised) HYPRE_BoomerAMGDestroy(amg_);
    amg_ = nullptr;
    setup_local_rows_ = -1;
  }

  // ||b - A x|| with x, b and r of sys (r is overwritten).
  double residual_norm(ParSystem& sys) {
    HYPRE_ParVectorCopy(sys.b.par, sys.r.par);
    HYPRE_ParCSRMatrixMatvec(-1.0, sys.a, sys.x.par, 1.0, sys.r.par);
    double rr = 0.0;
    HYPRE_ParVectorInnerProd(sys.r.par, sys.r.par, &rr);
    return std::sqrt(rr);
  }
  double rhs_norm(ParSystem& sys) {
    double bb = 0.0;
    HYPRE_ParVectorInnerProd(sys.b.par, sys.b.par, &bb);
    return std::sqrt(bb);
  }
  double true_residual(ParSystem& sys) {
    const double nb = rhs_norm(sys), nr = residual_norm(sys);
    return nb > 0.0 ? nr / nb : nr;
  }

  // Iterates on sys.x; fills iterations and residual history, and relative_residual where the true residual of the
  // final x was measured (else -1); returns whether tol was reached.
  bool run(ParSystem& sys, const Partition& part, SolveReport& report) {
    report.residual_history.clear();
    report.iterations = 0;
    report.relative_residual = -1.0;
    const double nb = rhs_norm(sys);
    if (nb == 0.0) {  // b = 0: the solution is 0
      const std::vector<double> zeros(static_cast<std::size_t>(part.local_rows()), 0.0);
      set_vector(sys.x, part, zeros, report);
      report.residual_history.push_back(0.0);
      report.relative_residual = 0.0;
      return true;
    }
    return method_ == Method::amg ? run_amg(sys, nb, report) : run_pcg(sys, nb, report);
  }

  bool run_amg(ParSystem& sys, double nb, SolveReport& report) {
    double rel = residual_norm(sys) / nb;
    report.residual_history.push_back(rel);
    while (!(rel < tol_) && report.iterations < max_iter_) {
      check(HYPRE_BoomerAMGSolve(amg_, sys.a, sys.b.par, sys.x.par), name_, "HYPRE_BoomerAMGSolve", report);
      ++report.iterations;
      rel = residual_norm(sys) / nb;
      report.residual_history.push_back(rel);
      if (!std::isfinite(rel)) return false;
    }
    report.relative_residual = rel;
    return rel < tol_;
  }

  bool run_pcg(ParSystem& sys, double nb, SolveReport& report) {
    HYPRE_Solver pcg = nullptr;
    HYPRE_ParCSRPCGCreate(comm_, &pcg);
    struct Guard {
      HYPRE_Solver s;
      ~Guard() { HYPRE_ParCSRPCGDestroy(s); }
    } guard{pcg};
    // Every tolerance explicit: stop on the 2-norm relative residual ||r||/||b|| < tol only, confirmed on
    // the recomputed true residual.
    HYPRE_PCGSetTol(pcg, tol_);
    HYPRE_PCGSetAbsoluteTol(pcg, 0.0);
    HYPRE_PCGSetResidualTol(pcg, 0.0);
    HYPRE_PCGSetConvergenceFactorTol(pcg, 0.0);
    HYPRE_PCGSetRelChange(pcg, 0);
    HYPRE_PCGSetTwoNorm(pcg, 1);
    HYPRE_PCGSetRecomputeResidual(pcg, 1);
    HYPRE_PCGSetMaxIter(pcg, max_iter_);
    HYPRE_PCGSetPrintLevel(pcg, 0);
    HYPRE_PCGSetLogging(pcg, 1);
    FilteredPrecond filtered{amg_, sys.m};
    if (jacobi_)
      HYPRE_PCGSetPrecond(pcg, reinterpret_cast<HYPRE_PtrToSolverFcn>(HYPRE_ParCSRDiagScale),
                          reinterpret_cast<HYPRE_PtrToSolverFcn>(HYPRE_ParCSRDiagScaleSetup), nullptr);
    else if (sys.m != sys.a)
      HYPRE_PCGSetPrecond(pcg, reinterpret_cast<HYPRE_PtrToSolverFcn>(filtered_vcycle),
                          reinterpret_cast<HYPRE_PtrToSolverFcn>(no_setup), reinterpret_cast<HYPRE_Solver>(&filtered));
    else
      HYPRE_PCGSetPrecond(pcg, reinterpret_cast<HYPRE_PtrToSolverFcn>(HYPRE_BoomerAMGSolve),
                          reinterpret_cast<HYPRE_PtrToSolverFcn>(no_setup), amg_);
    check(HYPRE_ParCSRPCGSetup(pcg, sys.a, sys.b.par, sys.x.par), name_, "HYPRE_ParCSRPCGSetup", report);
    const HYPRE_Int code = HYPRE_ParCSRPCGSolve(pcg, sys.a, sys.b.par, sys.x.par);
    HYPRE_Int iterations = 0, converged = 0;
    HYPRE_PCGGetNumIterations(pcg, &iterations);
    HYPRE_PCGGetConverged(pcg, &converged);
    report.iterations = static_cast<int>(iterations);
    // hypre logs ||r|| of the initial guess in norms[0] (rel_norms[0] stays unset) and ||r||/||b|| per iteration.
    const auto* data = reinterpret_cast<const hypre_PCGData*>(pcg);
    if (data->norms != nullptr) report.residual_history.push_back(data->norms[0] / nb);
    if (data->rel_norms != nullptr)
      for (HYPRE_Int i = 1; i <= iterations; ++i) report.residual_history.push_back(data->rel_norms[i]);
    // With RecomputeResidual the convergence test is repeated on b - A x computed afresh, and this is its value.
    if (converged != 0) HYPRE_PCGGetFinalRelativeResidualNorm(pcg, &report.relative_residual);
    if (code != 0 && !HYPRE_CheckError(code, HYPRE_ERROR_CONV)) check(code, name_, "HYPRE_ParCSRPCGSolve", report);
    HYPRE_ClearAllErrors();
    return converged != 0;
  }

  void read_solution(ParSystem& sys, const Partition& part, std::span<double> x, const SolveReport& report) {
    if (part.local_rows() > 0)
      check(HYPRE_IJVectorGetValues(sys.x.ij, part.local_rows(), rows_.data(), x.data()), name_,
            "HYPRE_IJVectorGetValues", report);
  }

  Method method_;
  std::string name_;
  AmgOptions amg_options_;
  double tol_;
  int max_iter_, reuse_;
  double filter_;
  bool galerkin_refresh_;  // refresh=galerkin
  bool jacobi_;  // precond=jacobi: PCG with the diagonal, no AMG
  std::string spec_;
  MPI_Comm comm_ = MPI_COMM_SELF;

  std::vector<HYPRE_BigInt> rows_;  // this rank's global row numbers
  KeptMatrix kept_;                 // A: on one rank lent (its arrays are the caller's), on ranks a copy
  KeptMatrix kept_filtered_;        // the copy of A's filtered matrix
  std::vector<HYPRE_BigInt> offd_columns_;  // the other ranks' columns a copy reaches, sorted
  solver_detail::RowScan scan_;     // the last matrix's: its diagonals (hypre's swap) and largest entries
  std::vector<char> lone_;          // refresh=galerkin: which rows of the last matrix held their diagonal only
  HYPRE_Solver amg_ = nullptr;      // the kept hierarchy
  HYPRE_Int setup_local_rows_ = -1;
  int reuses_ = 0;             // solves that reused amg_ since its setup
  int first_iterations_ = -1;  // iterations of the first solve after the setup
  bool rebuild_pending_ = false;
};

std::vector<SolverKey> hypre_keys(const char* tol, const char* max_iter) {
  std::vector<SolverKey> keys = {
      {"tol", tol, "relative residual ||b-Ax||/||b|| (2-norm) to reach"},
      {"max_iter", max_iter, "iterations before the solve is reported as failed"},
      {"reuse", "0",
       "keep the AMG hierarchy for up to N further solves while the unknown count is unchanged "
       "(rebuilt early if iterations grow by half); 0: set up every solve"},
      {"refresh", "none",
       "what a kept hierarchy takes from each new matrix: none (only the finest level's smoothing) | galerkin (its "
       "coarse operators made again from it, coarsening and interpolation kept)"}};
  for (auto& k : amg_keys()) keys.push_back(std::move(k));
  return keys;
}

// A filtered preconditioner changes what a V-cycle converges to, so only PCG, which iterates on A itself, offers it.
std::vector<SolverKey> pcg_keys() {
  std::vector<SolverKey> keys = hypre_keys("1e-8", "1000");
  keys.push_back({"precond", "amg",
                  "the preconditioner: amg (one BoomerAMG V-cycle) | jacobi (the diagonal: no setup; Jacobi-CG on MPI "
                  "ranks)"});
  keys.push_back({"filter", "0",
                  "build the AMG preconditioner on A with off-diagonal entries below FILTER x the largest one lumped "
                  "onto the diagonal (sparser, cheaper V-cycles; PCG still solves A); 0: on A itself"});
  return keys;
}

}  // namespace

SolverEntry hypre_amg_entry() {
  return {"hypre-amg",
          "hypre BoomerAMG V-cycles as the solver (IJ/ParCSR, one core per MPI rank). Usually a little slower than "
          "hypre-pcg; useful to see the bare multigrid convergence.",
          hypre_keys("1e-8", "200"), [](const SolverOptions& o, const SolverContext& c) {
            return std::make_unique<HypreSolver>(Method::amg, o, c);
          },
          /*distributed*/ true};
}

SolverEntry hypre_pcg_entry() {
  return {"hypre-pcg",
          "hypre PCG preconditioned by one BoomerAMG V-cycle: iterations nearly independent of N, the pick for large "
          "PPEs; with reuse=10 the setup is paid once every ~10 steps. precond=jacobi: by the diagonal (Jacobi-CG on "
          "MPI ranks).",
          pcg_keys(), [](const SolverOptions& o, const SolverContext& c) {
            return std::make_unique<HypreSolver>(Method::pcg, o, c);
          },
          /*distributed*/ true};
}

}  // namespace mps
