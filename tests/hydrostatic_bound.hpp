#pragma once
// How far a solve may leave the hydrostatic tank's pressure from rho g (H - y) (tests of the tank in the time loop).
#include <algorithm>
#include <cmath>
#include <vector>

#include "mps/solvers/solver.hpp"
#include "mps/step/step.hpp"

namespace tank_bound {

// With the hydrostatic split the tank's PPE at rest on the lattice is solved exactly by P' = rho g H (the held
// surface value; the source is 0), i.e. by P = rho g (H - y): a pressure is off only by its solve's error
// e = A^-1 r. |e|_inf <= ||A^-1||_inf |r|_2 with |r|_2 <= tol |b|_2 (the solver's relative residual), and A is an
// M-matrix (off-diagonals <= 0, rows summing to >= 0, > 0 at the surface), so A^-1 >= 0 and ||A^-1||_inf = max A^-1 1.
// Returns tol |b|_2 max(A^-1 1) for the simulation's last PPE [Pa].
template <int D>
inline double solve_error_bound(const mps::BasicSimulation<D>& sim, double tol) {
  const mps::PpeSystem& ppe = sim.last_ppe();
  const std::vector<double> ones(ppe.size(), 1.0);
  std::vector<double> z(ppe.size(), 0.0);
  (void)mps::make_solver("cholmod")->solve(ppe.matrix, ones, z);
  double b2 = 0.0;
  for (double b : ppe.rhs) b2 += b * b;
  return tol * std::sqrt(b2) * *std::max_element(z.begin(), z.end());
}

}  // namespace tank_bound
