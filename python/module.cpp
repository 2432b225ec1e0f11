// The sparsemps Python module: the solver registry on SciPy sparse matrices, PPE assembly from particle arrays and
// the time loop (docs/python.md). This file holds the module, its exceptions and the array conversions.
#include <climits>
#include <exception>
#include <string>

#include "convert.hpp"
#include "mps/boundary.hpp"
#include "mps/solvers/solver.hpp"
#include "mps/version.hpp"

namespace sparsemps {

py::array_t<bool> flags_to_numpy(const std::vector<char>& v) {
  py::array_t<bool> out(static_cast<py::ssize_t>(v.size()));
  bool* data = out.mutable_data();
  for (std::size_t i = 0; i < v.size(); ++i) data[i] = v[i] != 0;
  return out;
}

namespace {

// NumPy's forced cast would drop an imaginary part or parse nothing silently: only real dtypes are taken.
py::array real_array(py::handle obj, const std::string& what, const char* kinds) {
  py::array a = py::array::ensure(obj);
  if (!a) throw py::type_error(what + " must be an array of numbers");
  const char kind = a.dtype().kind();
  if (std::string(kinds).find(kind) == std::string::npos)
    throw py::type_error(what + " must hold real numbers, got dtype " + py::str(a.dtype()).cast<std::string>());
  if (a.ndim() != 1)
    throw py::value_error(what + " must be 1-D, got shape " + py::str(obj.attr("shape")).cast<std::string>());
  return a;
}

void check_length(const py::array& a, const std::string& what, py::ssize_t n) {
  if (n >= 0 && a.shape(0) != n)
    throw py::value_error(what + " has length " + std::to_string(a.shape(0)) + ", expected " + std::to_string(n));
}

}  // namespace

std::vector<double> to_doubles(py::handle obj, const std::string& what, py::ssize_t n) {
  const py::array a = real_array(obj, what, "biuf");
  check_length(a, what, n);
  const auto d = py::array_t<double, py::array::c_style | py::array::forcecast>::ensure(a);
  return {d.data(), d.data() + d.size()};
}

std::vector<int> to_ints(py::handle obj, const std::string& what, py::ssize_t n) {
  const py::array a = real_array(obj, what, "biu");
  check_length(a, what, n);
  const auto wide = py::array_t<long long, py::array::c_style | py::array::forcecast>::ensure(a);
  std::vector<int> out(static_cast<std::size_t>(wide.size()));
  for (py::ssize_t i = 0; i < wide.size(); ++i) {
    const long long v = wide.data()[i];
    if (v < INT_MIN || v > INT_MAX) throw py::value_error(what + " holds " + std::to_string(v) + ", beyond 32 bits");
    out[static_cast<std::size_t>(i)] = static_cast<int>(v);
  }
  return out;
}

mps::CsrMatrix to_csr(py::handle obj) {
  const py::module_ sparse = py::module_::import("scipy.sparse");
  py::object csr;
  try {
    csr = sparse.attr("csr_matrix")(obj);
  } catch (py::error_already_set& e) {
    // The exception's own words, without the traceback what() appends.
    throw py::type_error("A must be a scipy.sparse matrix or convertible to one; scipy.sparse.csr_matrix(A) raised " +
                         py::str(e.type().attr("__name__")).cast<std::string>() + ": " +
                         py::str(e.value()).cast<std::string>());
  }
  // The library wants each row's columns ascending and unique; a copy leaves the caller's matrix as it was.
  if (!csr.attr("has_canonical_format").cast<bool>()) {
    csr = csr.attr("copy")();
    csr.attr("sum_duplicates")();
  }
  const auto shape = csr.attr("shape").cast<std::pair<long long, long long>>();
  const auto nnz = csr.attr("nnz").cast<long long>();
  if (shape.first > INT_MAX || shape.second > INT_MAX || nnz > INT_MAX)
    throw py::value_error("A is too large for the library's 32-bit CSR indices");
  mps::CsrMatrix a;
  a.rows = static_cast<int>(shape.first);
  a.cols = static_cast<int>(shape.second);
  const py::object data = csr.attr("data");
  a.val = to_doubles(data, "A's values");
  a.col = to_ints(csr.attr("indices"), "A's column indices");
  a.row_ptr = to_ints(csr.attr("indptr"), "A's row pointers");
  return a;
}

py::object to_scipy(const mps::CsrMatrix& a) {
  const py::module_ sparse = py::module_::import("scipy.sparse");
  return sparse.attr("csr_matrix")(py::make_tuple(to_numpy(a.val), to_numpy(a.col), to_numpy(a.row_ptr)),
                                   py::arg("shape") = py::make_tuple(a.rows, a.cols));
}

}  // namespace sparsemps

PYBIND11_MODULE(sparsemps, m) {
  namespace py = pybind11;
  m.doc() =
      "SparseMPS from Python: the Moving Particle Semi-implicit method's pressure Poisson equation (PPE) and its\n"
      "sparse solvers.\n\n"
      "- Solver, solve, solvers: the library's solver registry (spec strings such as 'hypre-pcg:tol=1e-8') on\n"
      "  scipy.sparse matrices.\n"
      "- assemble_ppe: the PPE a time step assembles for particles given as NumPy arrays, as a CSR matrix.\n"
      "- Particles, Domain, SimulationConfig, Simulation: build a scene and run the time loop.\n\n"
      "docs/python.md has the details and an example.";
  m.attr("__version__") = mps::version;

  // Leaked on purpose: the translator may run until the interpreter is gone, and these are never destroyed then.
  static auto* solver_error = new py::exception<mps::SolverError>(m, "SolverError", PyExc_RuntimeError);
  static auto* simulation_error = new py::exception<mps::SimulationError>(m, "SimulationError", PyExc_RuntimeError);
  solver_error->doc() =
      "A solve that failed (no convergence, a matrix the method cannot take, NaN or Inf in or out, sizes that do "
      "not match); .report is the SolveReport of how far it got.";
  simulation_error->doc() = "A time step the stability guard stopped (the simulation keeps its previous state).";
  py::register_exception_translator([](std::exception_ptr p) {
    try {
      if (p) std::rethrow_exception(p);
    } catch (const mps::SolverError& e) {
      py::object error = py::handle(solver_error->ptr())(e.what());  // an instance, to carry the report
      error.attr("report") = py::cast(e.report());
      PyErr_SetObject(solver_error->ptr(), error.ptr());
    } catch (const mps::SimulationError& e) {
      PyErr_SetString(simulation_error->ptr(), e.what());
    }
  });

  sparsemps::bind_solvers(m);
  sparsemps::bind_scene(m);
}
