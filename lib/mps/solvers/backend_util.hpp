#pragma once
// Small helpers shared by the solver backends (private to lib/mps/solvers/*.cpp).
#include <chrono>
#include <cmath>
#include <span>
#include <string>

#include "mps/solvers/solver.hpp"

namespace mps::solver_detail {

using Clock = std::chrono::steady_clock;

inline double seconds_since(Clock::time_point t0) { return std::chrono::duration<double>(Clock::now() - t0).count(); }

inline bool all_finite(std::span<const double> x) {
  for (double v : x)
    if (!std::isfinite(v)) return false;
  return true;
}

// The checks every serial backend makes before touching the numbers: square matrix, matching vector sizes,
// finite matrix and right-hand side. A non-finite initial guess is replaced by zeros (a broken warm start
// must not poison the solve).
inline void check_serial_input(const std::string& backend, const CsrMatrix& a, std::span<const double> b,
                               std::span<double> x, const SolveReport& report) {
  if (a.rows != a.cols || b.size() != static_cast<std::size_t>(a.rows) || x.size() != b.size())
    throw SolverError(backend + ": matrix and vector sizes do not match (matrix " + std::to_string(a.rows) + " x " +
                          std::to_string(a.cols) + ", b " + std::to_string(b.size()) + ", x " +
                          std::to_string(x.size()) + ")",
                      report);
  if (!all_finite(a.val)) throw SolverError(backend + ": NaN or Inf in the matrix", report);
  if (!all_finite(b)) throw SolverError(backend + ": NaN or Inf in the right-hand side", report);
  if (!all_finite(x))
    for (double& v : x) v = 0.0;
}

}  // namespace mps::solver_detail
