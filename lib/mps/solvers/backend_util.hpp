#pragma once
// Small helpers shared by the solver backends (private to lib/mps/solvers/*.cpp).
#include <mpi.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <mutex>
#include <span>
#include <stdexcept>
#include <string>

#include "mps/solvers/solver.hpp"

namespace mps::solver_detail {

using Clock = std::chrono::steady_clock;

inline double seconds_since(Clock::time_point t0) { return std::chrono::duration<double>(Clock::now() - t0).count(); }

// A lone process needs neither Open MPI's runtime daemon nor UCX's device probe, which made most of a singleton's
// start (docs/solvers.md). Only without a launcher, never over a setting of the user's.
inline void quick_singleton_start() {
  for (const char* launcher : {"OMPI_COMM_WORLD_SIZE", "PMIX_RANK", "PMI_SIZE"})
    if (std::getenv(launcher) != nullptr) return;
  setenv("OMPI_MCA_ess_singleton_isolated", "1", 0);
  setenv("OMPI_MCA_pml", "ob1", 0);
}

// MPI for the backends that need it (hypre, PETSc), started once if the host program has not: a singleton MPI_Init
// needs no mpirun. Its finaliser is registered before any backend's, so it runs after theirs at exit.
inline void ensure_mpi(const std::string& backend) {
  static std::once_flag once;
  std::call_once(once, [&] {
    int initialised = 0, finalized = 0;
    MPI_Initialized(&initialised);
    MPI_Finalized(&finalized);
    if (finalized)
      throw std::runtime_error(backend + ": MPI has already been finalised; create " + backend +
                               " solvers before MPI_Finalize");
    if (initialised) return;
    quick_singleton_start();
    int provided = 0;
    if (MPI_Init_thread(nullptr, nullptr, MPI_THREAD_SERIALIZED, &provided) != MPI_SUCCESS)
      throw std::runtime_error(backend + ": MPI_Init_thread failed");
    std::atexit([] {
      int done = 0;
      MPI_Finalized(&done);
      if (!done) MPI_Finalize();
    });
  });
}

// True on every rank if it is true on any rank (so that all ranks throw, rebuild or return together).
inline bool any_rank(bool local, MPI_Comm comm) {
  int in = local ? 1 : 0, out = 0;
  MPI_Allreduce(&in, &out, 1, MPI_INT, MPI_LOR, comm);
  return out != 0;
}

inline bool all_finite(std::span<const double> x) {
  for (double v : x)
    if (!std::isfinite(v)) return false;
  return true;
}

// Every row holds its diagonal entry, positive where the method needs a positive definite matrix: an empty row
// or a missing diagonal is a singular matrix, whatever the method.
inline void check_diagonal(const std::string& backend, const CsrMatrix& a, int first_row, bool positive,
                           const SolveReport& report) {
  for (int i = 0; i < a.rows; ++i) {
    const auto b = a.col.begin() + a.row_ptr[static_cast<std::size_t>(i)];
    const auto e = a.col.begin() + a.row_ptr[static_cast<std::size_t>(i) + 1];
    const auto it = std::lower_bound(b, e, first_row + i);
    const bool stored = it != e && *it == first_row + i;
    const double d = stored ? a.val[static_cast<std::size_t>(it - a.col.begin())] : 0.0;
    if (stored && !std::isfinite(d))
      throw SolverError(backend + ": row " + std::to_string(first_row + i) + " has a diagonal entry that is " +
                            (std::isnan(d) ? "NaN" : "infinite") + ": NaN or Inf in the matrix",
                        report);
    if (!stored || (positive ? !(d > 0.0) : d == 0.0))
      throw SolverError(backend + ": row " + std::to_string(first_row + i) +
                            (b == e      ? " is empty"
                             : !stored   ? " has no diagonal entry"
                             : positive  ? " has a diagonal entry <= 0"
                                         : " has a zero diagonal entry") +
                            ", so the matrix is singular" + (positive ? " or not positive definite" : "") +
                            " (a PPE row per unknown, each with its own diagonal, is what the solvers expect)",
                        report);
  }
}

// A CSR structure that is not one (CsrMatrix::validate), as a SolverError naming the backend.
inline void check_structure(const std::string& backend, const CsrMatrix& a, const SolveReport& report) {
  try {
    a.validate();
  } catch (const std::invalid_argument& e) {
    throw SolverError(backend + ": " + e.what(), report);
  }
}

// The checks every serial backend makes before touching the numbers: a valid CSR structure, square matrix, matching
// vector sizes, finite matrix and right-hand side, every diagonal stored (positive and the matrix symmetric for the
// symmetric positive definite methods: a cheap one-pass check). A non-finite initial guess is replaced by zeros (a
// broken warm start must not poison the solve).
inline void check_serial_input(const std::string& backend, const CsrMatrix& a, std::span<const double> b,
                               std::span<double> x, const SolveReport& report, bool spd) {
  check_structure(backend, a, report);
  if (a.rows != a.cols || b.size() != static_cast<std::size_t>(a.rows) || x.size() != b.size())
    throw SolverError(backend + ": matrix and vector sizes do not match (matrix " + std::to_string(a.rows) + " x " +
                          std::to_string(a.cols) + ", b " + std::to_string(b.size()) + ", x " +
                          std::to_string(x.size()) + ")",
                      report);
  if (!all_finite(a.val)) throw SolverError(backend + ": NaN or Inf in the matrix", report);
  if (!all_finite(b)) throw SolverError(backend + ": NaN or Inf in the right-hand side", report);
  check_diagonal(backend, a, 0, spd, report);
  if (spd && !a.is_symmetric(1e-12))
    throw SolverError(backend + ": the matrix is not symmetric, which this method needs; use eigen-bicgstab for a "
                                "nonsymmetric matrix",
                      report);
  if (!all_finite(x))
    for (double& v : x) v = 0.0;
}

}  // namespace mps::solver_detail
