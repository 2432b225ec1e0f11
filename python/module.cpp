// The sparsemps Python module: the solver registry on SciPy sparse matrices, PPE assembly from particle arrays and
// the time loop (docs/python.md). This file holds the module, its exceptions and the array conversions.
#include <algorithm>
#include <climits>
#include <cmath>
#include <exception>
#include <new>
#include <string>

#include "convert.hpp"
#include "mps/boundaries/boundary.hpp"
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
  if (a.ndim() != 1)  // the array's shape: obj may be a scalar or a nested list, which have none
    throw py::value_error(what + " must be 1-D, got " +
                          (a.ndim() == 0 ? std::string("a scalar")
                                         : "shape " + py::str(a.attr("shape")).cast<std::string>()));
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

std::vector<double> to_finite_doubles(py::handle obj, const std::string& what, py::ssize_t n) {
  std::vector<double> values = to_doubles(obj, what, n);
  const auto bad = std::find_if(values.begin(), values.end(), [](double v) { return !std::isfinite(v); });
  if (bad != values.end())
    throw py::value_error(what + "[" + std::to_string(bad - values.begin()) + "] is " +
                          py::repr(py::float_(*bad)).cast<std::string>() + ": every entry must be a finite number");
  return values;
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

namespace {

// An index array of a sparse matrix as 64-bit integers (a copy unless it is int64 already).
py::array_t<long long> index_array(const py::object& matrix, const char* name, const std::string& what,
                                   const std::string& fix) {
  const py::array a = py::array::ensure(matrix.attr(name));
  if (!a || (a.dtype().kind() != 'i' && a.dtype().kind() != 'u'))
    throw py::value_error(what + ": " + name + " must be an array of integers" + fix);
  if (a.ndim() != 1)
    throw py::value_error(what + ": " + name + " must be 1-D, got " + std::to_string(a.ndim()) + "-D" + fix);
  return py::array_t<long long, py::array::c_style | py::array::forcecast>::ensure(a);
}

py::ssize_t stored_values(const py::object& matrix, const std::string& what, const std::string& fix, int block_dims) {
  const py::array data = py::array::ensure(matrix.attr("data"));
  if (!data || data.ndim() != 1 + block_dims)
    throw py::value_error(what + ": data must be a " + std::to_string(1 + block_dims) + "-D array" + fix);
  return data.shape(0);
}

// SciPy's conversions and sum_duplicates trust a compressed matrix's arrays: a damaged indptr or index would have them
// write out of bounds. So the structure is checked here first, in the layout given (CSR, CSC or BSR).
void check_compressed(const py::object& matrix, const std::string& format, long long rows, long long cols) {
  const std::string what = "A (" + format + ")";
  const std::string fix = "; repair A's indptr, indices and data, or rebuild it with scipy.sparse";
  long long major = format == "csc" ? cols : rows, minor = format == "csc" ? rows : cols;
  int block_dims = 0;
  if (format == "bsr") {
    const auto block = matrix.attr("blocksize").cast<std::pair<long long, long long>>();
    if (block.first <= 0 || block.second <= 0 || rows % block.first != 0 || cols % block.second != 0)
      throw py::value_error(what + ": blocks of " + std::to_string(block.first) + " x " + std::to_string(block.second) +
                            " do not tile the shape " + std::to_string(rows) + " x " + std::to_string(cols) + fix);
    major = rows / block.first;
    minor = cols / block.second;
    block_dims = 2;
  }
  const auto indptr_array = index_array(matrix, "indptr", what, fix);
  const auto indices_array = index_array(matrix, "indices", what, fix);
  const auto indptr = indptr_array.unchecked<1>();
  const auto indices = indices_array.unchecked<1>();
  const py::ssize_t values = stored_values(matrix, what, fix, block_dims);
  const long long entries = indices.shape(0);
  const char* line = format == "csc" ? "columns" : "rows";
  if (indptr.shape(0) != major + 1)
    throw py::value_error(what + ": indptr has " + std::to_string(indptr.shape(0)) + " entries, expected " + line +
                          " + 1 = " + std::to_string(major + 1) + fix);
  if (values != entries)
    throw py::value_error(what + ": data holds " + std::to_string(values) + " values but indices " +
                          std::to_string(entries) + "; give one value per index" + fix);
  if (indptr(0) != 0) throw py::value_error(what + ": indptr starts at " + std::to_string(indptr(0)) + ", not 0" + fix);
  for (py::ssize_t k = 1; k <= major; ++k) {
    if (indptr(k) < indptr(k - 1))
      throw py::value_error(what + ": indptr decreases from indptr[" + std::to_string(k - 1) + "] = " +
                            std::to_string(indptr(k - 1)) + " to indptr[" + std::to_string(k) + "] = " +
                            std::to_string(indptr(k)) + "; it must not decrease" + fix);
    if (indptr(k) > entries)
      throw py::value_error(what + ": indptr[" + std::to_string(k) + "] = " + std::to_string(indptr(k)) +
                            " is beyond the " + std::to_string(entries) + " stored indices" + fix);
  }
  if (indptr(major) != entries)
    throw py::value_error(what + ": indptr ends at " + std::to_string(indptr(major)) + " but " +
                          std::to_string(entries) + " indices are stored; it must end at their count" + fix);
  for (py::ssize_t k = 0; k < entries; ++k)
    if (indices(k) < 0 || indices(k) >= minor)
      throw py::value_error(what + ": indices[" + std::to_string(k) + "] = " + std::to_string(indices(k)) +
                            " is outside [0, " + std::to_string(minor) + ")" + fix);
}

// COO's conversion to CSR trusts its row and col arrays the same way.
void check_coo(const py::object& matrix, long long rows, long long cols) {
  const std::string what = "A (coo)";
  const std::string fix = "; repair A's row, col and data, or rebuild it with scipy.sparse";
  const auto row_array = index_array(matrix, "row", what, fix);
  const auto col_array = index_array(matrix, "col", what, fix);
  const auto row = row_array.unchecked<1>();
  const auto col = col_array.unchecked<1>();
  const py::ssize_t values = stored_values(matrix, what, fix, 0);
  if (row.shape(0) != values || col.shape(0) != values)
    throw py::value_error(what + ": row, col and data hold " + std::to_string(row.shape(0)) + ", " +
                          std::to_string(col.shape(0)) + " and " + std::to_string(values) +
                          " entries; they must be equally long" + fix);
  for (py::ssize_t k = 0; k < values; ++k) {
    if (row(k) < 0 || row(k) >= rows)
      throw py::value_error(what + ": row[" + std::to_string(k) + "] = " + std::to_string(row(k)) + " is outside [0, " +
                            std::to_string(rows) + ")" + fix);
    if (col(k) < 0 || col(k) >= cols)
      throw py::value_error(what + ": col[" + std::to_string(k) + "] = " + std::to_string(col(k)) + " is outside [0, " +
                            std::to_string(cols) + ")" + fix);
  }
}

// A SciPy sparse matrix's arrays checked in its own format, before any SciPy method that trusts them runs on it.
void check_sparse_structure(const py::object& matrix) {
  const auto shape = matrix.attr("shape").cast<std::pair<long long, long long>>();
  if (shape.first < 0 || shape.second < 0)
    throw py::value_error("A has shape (" + std::to_string(shape.first) + ", " + std::to_string(shape.second) +
                          "); a shape is never negative");
  const auto format = matrix.attr("format").cast<std::string>();
  if (format == "csr" || format == "csc" || format == "bsr")
    check_compressed(matrix, format, shape.first, shape.second);
  else if (format == "coo") check_coo(matrix, shape.first, shape.second);
}

}  // namespace

mps::CsrMatrix to_csr(py::handle obj) {
  const py::module_ sparse = py::module_::import("scipy.sparse");
  const bool is_sparse = sparse.attr("issparse")(obj).cast<bool>();
  if (is_sparse) check_sparse_structure(py::reinterpret_borrow<py::object>(obj));
  const bool given_csr = is_sparse && obj.attr("format").cast<std::string>() == "csr";
  py::object csr;
  try {
    csr = sparse.attr("csr_matrix")(obj);
  } catch (py::error_already_set& e) {
    // The exception's own words, without the traceback what() appends.
    throw py::type_error("A must be a scipy.sparse matrix or convertible to one; scipy.sparse.csr_matrix(A) raised " +
                         py::str(e.type().attr("__name__")).cast<std::string>() + ": " +
                         py::str(e.value()).cast<std::string>());
  }
  // Formats checked above convert safely; the others (LIL, DOK, DIA, dense) are checked as the CSR they became.
  if (!given_csr) check_sparse_structure(csr);
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
    } catch (const std::bad_alloc&) {  // pybind11's own translation says only "std::bad_alloc"
      PyErr_SetString(PyExc_MemoryError,
                      "out of memory: this needs more memory than the machine has; use fewer particles (a larger l0, "
                      "a smaller rectangle or domain) or a smaller matrix");
    }
  });

  sparsemps::bind_solvers(m);
  sparsemps::bind_scene(m);
}
