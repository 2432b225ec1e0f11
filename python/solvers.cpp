// The solver registry: Solver objects made from spec strings, solving scipy.sparse systems.
#include <pybind11/stl.h>

#include <memory>
#include <mutex>
#include <sstream>
#include <string>
#include <utility>

#include "convert.hpp"
#include "mps/solvers/registry.hpp"

namespace sparsemps {
namespace {

// One solver object keeps state between solves (a factorisation, an AMG hierarchy) and is not re-entrant; the lock
// keeps two Python threads from solving with it at once while the GIL is released.
struct Solver {
  std::unique_ptr<mps::LinearSolver> solver;
  std::mutex mutex;

  explicit Solver(const std::string& spec) : solver(mps::make_solver(spec)) {}

  std::pair<py::array_t<double>, mps::SolveReport> solve(Typed<SparseLike> a_in, Typed<ArrayLike> b_in,
                                                         Typed<OptionalArray> x0) {
    const mps::CsrMatrix a = to_csr(a_in);
    // A length that differs is the library's to report (with both sizes); any other shape is refused here.
    const py::array b_array = py::array::ensure(b_in);
    if (b_array && b_array.ndim() != 1)
      throw py::value_error("b must be a 1-D array of A's size (" + std::to_string(a.rows) + " entries), got " +
                            (b_array.ndim() == 0 ? std::string("a scalar")
                                                 : "shape " + py::str(b_array.attr("shape")).cast<std::string>()));
    const std::vector<double> b = to_doubles(b_in, "b");
    // The library checks sizes against A (a SolverError naming both); an x0 of the wrong length is refused here,
    // where it is the caller's argument and not the library's.
    std::vector<double> x = x0.is_none() ? std::vector<double>(b.size(), 0.0)
                                         : to_doubles(x0, "x0", static_cast<py::ssize_t>(b.size()));
    mps::SolveReport report;
    {
      const py::gil_scoped_release release;
      const std::lock_guard<std::mutex> lock(mutex);
      report = solver->solve(a, b, x);
    }
    return {to_numpy(x), std::move(report)};
  }
};

const char* solve_doc =
    "Solves A x = b; returns (x, SolveReport).\n\n"
    "A: scipy.sparse matrix (or anything scipy.sparse.csr_matrix takes), square, symmetric positive definite for\n"
    "   every backend but eigen-bicgstab. b: 1-D array. x0: initial guess (default zeros).\n"
    "Raises SolverError (with .report) when the solve fails or A and b do not fit together, TypeError for\n"
    "arguments that are not real arrays.";

}  // namespace

void bind_solvers(py::module_& m) {
  py::class_<mps::SolveReport>(m, "SolveReport", "What one solve did (mps::SolveReport).")
      .def_readonly("backend", &mps::SolveReport::backend, "the backend that solved, e.g. 'eigen-cg'")
      .def_readonly("iterations", &mps::SolveReport::iterations, "iterations the solve took")
      .def_readonly("relative_residual", &mps::SolveReport::relative_residual,
                    "||b - A x|| / ||b|| of the returned x, computed afresh")
      .def_readonly("setup_seconds", &mps::SolveReport::setup_seconds, "preconditioner or factorisation")
      .def_readonly("solve_seconds", &mps::SolveReport::solve_seconds, "wall-clock seconds of the solve itself")
      .def_readonly("setup_reused", &mps::SolveReport::setup_reused,
                    "hypre: AMG hierarchy kept (reuse=N); cholmod: symbolic analysis kept")
      .def_property_readonly(
          "residual_history", [](const mps::SolveReport& r) { return to_numpy(r.residual_history); },
          "relative residuals from the initial guess on (every iteration for hypre; first and last for Eigen)")
      .def("__repr__", [](const mps::SolveReport& r) {
        std::ostringstream s;
        s << "SolveReport(backend='" << r.backend << "', iterations=" << r.iterations
          << ", relative_residual=" << r.relative_residual << ", setup_seconds=" << r.setup_seconds
          << ", solve_seconds=" << r.solve_seconds << ", setup_reused=" << (r.setup_reused ? "True" : "False") << ")";
        return s.str();
      });

  py::class_<Solver>(m, "Solver",
                     "A linear solver made from a spec 'name[:key=value,...]' (see solvers()). It keeps its state\n"
                     "between solves: hypre's AMG hierarchy with reuse=N, CHOLMOD's symbolic analysis.")
      .def(py::init<const std::string&>(), py::arg("spec") = "auto",
           "Raises ValueError naming what is valid for an unknown solver, key or value.")
      .def_property_readonly(
          "spec", [](const Solver& s) { return s.solver->spec(); }, "the full spec, every key with its value")
      .def("solve", &Solver::solve, py::arg("A"), py::arg("b"), py::arg("x0") = py::none(), solve_doc)
      .def("__repr__", [](const Solver& s) { return "Solver('" + s.solver->spec() + "')"; });

  m.def(
      "solve",
      [](Typed<SparseLike> a, Typed<ArrayLike> b, const std::string& spec, Typed<OptionalArray> x0) {
        Solver solver(spec);
        return solver.solve(a, b, x0);
      },
      py::arg("A"), py::arg("b"), py::arg("spec") = "auto", py::arg("x0") = py::none(),
      (std::string("Makes Solver(spec) and solves once. ") + solve_doc).c_str());

  m.def("solver_names", &mps::solver_names, "The registered backends' names.");
  m.def("describe_solvers", &mps::describe_solvers, "What every app's --list-solvers prints.");
  m.def(
      "solvers",
      [] {
        py::list out;
        for (const mps::SolverEntry& entry : mps::solver_registry()) {
          py::dict keys;
          for (const mps::SolverKey& key : entry.keys)
            keys[py::str(key.name)] = py::dict(py::arg("default") = key.default_value, py::arg("help") = key.help);
          out.append(py::dict(py::arg("name") = entry.name, py::arg("summary") = entry.summary,
                              py::arg("keys") = keys, py::arg("passes_other_keys") = entry.passes_other_keys));
        }
        return out;
      },
      "Every registered backend as a dict: name, summary (when to use it), keys {key: {default, help}} and "
      "passes_other_keys (True for petsc: any other key is one of PETSc's options).");
}

}  // namespace sparsemps
