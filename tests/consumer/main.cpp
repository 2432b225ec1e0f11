// Assembles the PPE of a small water tank through the installed headers and library, solves it, and checks
// the solution: exits non-zero if anything is off.
#include <cstdio>
#include <cstring>

#include "mps/geometry.hpp"
#include "mps/ppe.hpp"
#include "mps/solvers/solver.hpp"
#include "mps/version.hpp"

int main() {
  if (std::strcmp(mps::version, EXPECTED_VERSION) != 0) {
    std::printf("consumer: mps/version.hpp says %s, the package %s\n", mps::version, EXPECTED_VERSION);
    return 1;
  }
  const double l0 = 0.05;
  mps::Particles p;
  mps::fill_rectangle(p, {0, 0, 1, 0.6}, l0, mps::Kind::fluid);
  mps::add_rectangle_walls(p, {0, 0, 1, 1}, l0, mps::left | mps::right | mps::bottom, 1, 4);
  const mps::Domain d{-0.5, 1.5, -0.5, 1.5};
  const mps::Kernel lap = mps::make_kernel(4.1, l0), small = mps::make_kernel(2.1, l0);
  const auto near = mps::find_neighbors(p, d, lap.re), close = mps::find_neighbors(p, d, small.re);
  const auto n = mps::number_density({p, d, close, small});
  const auto surface = mps::detect_free_surface(p, n, small.n0, 0.97, &close, small.lattice_neighbors, 0.85);
  const std::vector<double> source(p.size(), -1000.0);
  const mps::PpeSystem sys = mps::assemble_ppe({p, d, near, lap}, surface, source);
  std::vector<double> x(sys.size(), 0.0);
  const mps::SolveReport r = mps::make_solver("eigen-cg:tol=1e-10")->solve(sys.matrix, sys.rhs, x);
  const double residual = mps::relative_residual(sys.matrix, x, sys.rhs);
  std::printf("consumer: %zu unknowns, %d iterations, relative residual %.2e\n", sys.size(), r.iterations, residual);
  return (sys.size() > 100 && residual < 1e-9) ? 0 : 1;
}
