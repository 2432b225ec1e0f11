#pragma once
// Small helpers shared by the solver backends (private to lib/mps/solvers/*.cpp).
#include <mpi.h>

#include <algorithm>
#include <bit>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <mutex>
#include <span>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

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

// What one read of a block of rows finds (first_row: the global number of its first row). The input checks
// below take it from here instead of reading the arrays once per check (docs/benchmarks.md).
struct RowScan {
  std::vector<int> diagonal;  // where row r's diagonal sits in a.col; -1 where the row has none
  double largest = 0.0;       // the largest |a_ij|, where every entry is finite
  double largest_off_diagonal = 0.0;  // the same off the diagonal
  bool finite = true;  // no NaN or Inf among the values
};

// A CSR structure that is not one (CsrMatrix::validate), as a SolverError naming the backend.
inline void check_structure(const std::string& backend, const CsrMatrix& a, const SolveReport& report) {
  try {
    a.validate();
  } catch (const std::invalid_argument& e) {
    throw SolverError(backend + ": " + e.what(), report);
  }
}

// Reads every row once: a broken structure throws check_structure's error (validate's message, found again there
// so that it is worded in one place); the rest is recorded for the checks that follow. The loops are written for
// the compiler to vectorise: a finite double's magnitude orders as its bits with the sign cleared, and a NaN or Inf
// has the largest such bits, so one integer maximum gives both the largest entry and whether all are finite.
inline void scan_rows(const std::string& backend, const CsrMatrix& a, int first_row, RowScan& scan,
                      const SolveReport& report) {
  if (a.rows < 0 || a.cols < 0 || a.row_ptr.size() != static_cast<std::size_t>(a.rows) + 1 || a.row_ptr.front() != 0 ||
      static_cast<std::size_t>(a.row_ptr.back()) != a.col.size() || a.col.size() != a.val.size())
    check_structure(backend, a, report);
  constexpr std::uint64_t magnitude = ~(std::uint64_t{1} << 63), infinite = 0x7ff0000000000000;
  scan.diagonal.assign(static_cast<std::size_t>(a.rows), -1);
  const int* col = a.col.data();
  const auto cols = static_cast<unsigned>(a.cols);
  std::uint64_t off = 0, diagonal = 0;
  for (int i = 0; i < a.rows; ++i) {
    const int b = a.row_ptr[static_cast<std::size_t>(i)], e = a.row_ptr[static_cast<std::size_t>(i) + 1];
    if (e < b) check_structure(backend, a, report);
    // Columns in range and ascending; the diagonal's slot is where the columns below it end.
    bool bad = b < e && static_cast<unsigned>(col[b]) >= cols;
    int below = 0;
    const int target = first_row + i;
    for (int k = b + 1; k < e; ++k) bad |= (static_cast<unsigned>(col[k]) >= cols) | (col[k] <= col[k - 1]);
    for (int k = b; k < e; ++k) below += col[k] < target ? 1 : 0;
    if (bad) check_structure(backend, a, report);
    const int d = b + below < e && col[b + below] == target ? b + below : -1;
    scan.diagonal[static_cast<std::size_t>(i)] = d;
    std::uint64_t row = 0;
    for (int k = b; k < e; ++k) {
      const std::uint64_t bits = std::bit_cast<std::uint64_t>(a.val[static_cast<std::size_t>(k)]) & magnitude;
      row = std::max(row, k == d ? std::uint64_t{0} : bits);
    }
    off = std::max(off, row);
    if (d >= 0)
      diagonal = std::max(diagonal, std::bit_cast<std::uint64_t>(a.val[static_cast<std::size_t>(d)]) & magnitude);
  }
  const std::uint64_t all = std::max(off, diagonal);
  scan.finite = all < infinite;
  // Over the finite entries, as CsrMatrix::is_symmetric's scale; only read when every entry is finite.
  scan.largest = scan.finite ? std::bit_cast<double>(all) : 0.0;
  scan.largest_off_diagonal = off < infinite ? std::bit_cast<double>(off) : 0.0;
}

// Every row holds its diagonal entry, positive where the method needs a positive definite matrix: an empty row
// or a missing diagonal is a singular matrix, whatever the method.
inline void check_diagonal(const std::string& backend, const CsrMatrix& a, int first_row, const RowScan& scan,
                           bool positive, const SolveReport& report) {
  for (int i = 0; i < a.rows; ++i) {
    const int slot = scan.diagonal[static_cast<std::size_t>(i)];
    const bool stored = slot >= 0;
    const double d = stored ? a.val[static_cast<std::size_t>(slot)] : 0.0;
    if (stored && std::isfinite(d) && (positive ? d > 0.0 : d != 0.0)) continue;
    if (stored && !std::isfinite(d))
      throw SolverError(backend + ": row " + std::to_string(first_row + i) + " has a diagonal entry that is " +
                            (std::isnan(d) ? "NaN" : "infinite") + ": NaN or Inf in the matrix",
                        report);
    const bool empty = a.row_ptr[static_cast<std::size_t>(i)] == a.row_ptr[static_cast<std::size_t>(i) + 1];
    throw SolverError(backend + ": row " + std::to_string(first_row + i) +
                          (empty      ? " is empty"
                           : !stored  ? " has no diagonal entry"
                           : positive ? " has a diagonal entry <= 0"
                                      : " has a zero diagonal entry") +
                          ", so the matrix is singular" + (positive ? " or not positive definite" : "") +
                          " (a PPE row per unknown, each with its own diagonal, is what the solvers expect)",
                      report);
  }
}

// CsrMatrix::is_symmetric(1e-12) of a square block whose diagonals check_diagonal has found, without its passes.
inline bool symmetric(const CsrMatrix& a, const RowScan& scan) {
  std::vector<int> after(scan.diagonal.size());
  for (std::size_t r = 0; r < after.size(); ++r) after[r] = scan.diagonal[r] + 1;
  return is_symmetric_after(a, std::move(after), scan.largest);
}

// The checks every serial backend makes before touching the numbers: a valid CSR structure, square matrix, matching
// vector sizes, finite matrix and right-hand side, every diagonal stored (positive and the matrix symmetric for the
// symmetric positive definite methods). A non-finite initial guess is replaced by zeros (a broken warm start must
// not poison the solve).
inline void check_serial_input(const std::string& backend, const CsrMatrix& a, std::span<const double> b,
                               std::span<double> x, const SolveReport& report, bool spd) {
  RowScan scan;
  scan_rows(backend, a, 0, scan, report);
  if (a.rows != a.cols || b.size() != static_cast<std::size_t>(a.rows) || x.size() != b.size())
    throw SolverError(backend + ": matrix and vector sizes do not match (matrix " + std::to_string(a.rows) + " x " +
                          std::to_string(a.cols) + ", b " + std::to_string(b.size()) + ", x " +
                          std::to_string(x.size()) + ")",
                      report);
  if (!scan.finite) throw SolverError(backend + ": NaN or Inf in the matrix", report);
  if (!all_finite(b)) throw SolverError(backend + ": NaN or Inf in the right-hand side", report);
  check_diagonal(backend, a, 0, scan, spd, report);
  if (spd && !symmetric(a, scan))
    throw SolverError(backend + ": the matrix is not symmetric, which this method needs; use eigen-bicgstab for a "
                                "nonsymmetric matrix",
                      report);
  if (!all_finite(x))
    for (double& v : x) v = 0.0;
}

}  // namespace mps::solver_detail
