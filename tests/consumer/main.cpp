// Assembles the PPE of a small water tank through the installed headers and library and solves it with each kind
// of backend (Eigen, CHOLMOD, hypre: a static library must bring all of their dependencies) for a right-hand side
// whose solution is known: exits non-zero if any answer, or the version, is off.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <string>
#include <vector>

#include "mps/boundaries/geometry.hpp"
#include "mps/numerics/ppe.hpp"
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
  if (sys.size() < 200 || !sys.matrix.is_symmetric()) {
    std::printf("consumer: %zu unknowns, symmetric %d: not the tank's PPE\n", sys.size(), sys.matrix.is_symmetric());
    return 1;
  }
  // A known answer: x* = 1 + y at each unknown, b = A x*.
  std::vector<double> exact(sys.size()), b(sys.size());
  for (std::size_t k = 0; k < sys.size(); ++k) exact[k] = 1.0 + p.y[sys.particle[k]];
  sys.matrix.multiply(exact, b);
  int failures = 0;
  for (const char* spec : {"eigen-cg:tol=1e-12", "cholmod", "hypre-pcg:tol=1e-12"}) {
    std::vector<double> x(sys.size(), 0.0);
    const mps::SolveReport r = mps::make_solver(spec)->solve(sys.matrix, b, x);
    double error = 0;
    for (std::size_t k = 0; k < x.size(); ++k) error = std::max(error, std::abs(x[k] - exact[k]));
    const bool ok = error < 1e-8 && r.backend.find(std::string(spec).substr(0, 5)) == 0;
    std::printf("consumer: %s (%s): %zu unknowns, %d iterations, max error %.2e %s\n", spec, r.backend.c_str(),
                sys.size(), r.iterations, error, ok ? "ok" : "FAIL");
    failures += ok ? 0 : 1;
  }
  return failures == 0 ? 0 : 1;
}
