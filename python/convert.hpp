#pragma once
// Conversions between the library's plain arrays and NumPy / SciPy, shared by the binding files. Everything is copied:
// a NumPy array never aliases a std::vector the library may reallocate.
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>

#include <algorithm>
#include <cstddef>
#include <string>
#include <vector>

#include "mps/core/csr.hpp"

namespace sparsemps {

namespace py = pybind11;

// An argument taken as it comes and converted by the function itself (with the library's messages), under the name of
// the types it takes: help() and editors show `A: scipy.sparse.spmatrix | numpy.typing.ArrayLike`, not `handle`.
// Returned, it shows its name too (read_particles returns Particles or Particles3).
template <class Name>
struct Typed {
  py::object obj;
  operator py::handle() const { return obj; }  // NOLINT: passed on wherever a handle is taken
  [[nodiscard]] bool is_none() const { return obj.is_none(); }
};
struct ArrayLike {
  static constexpr auto name = py::detail::const_name("numpy.typing.ArrayLike");
};
struct OptionalArray {
  static constexpr auto name = py::detail::const_name("numpy.typing.ArrayLike | None");
};
struct SparseLike {
  static constexpr auto name = py::detail::const_name("scipy.sparse.spmatrix | numpy.typing.ArrayLike");
};
struct KindLike {
  static constexpr auto name = py::detail::const_name("sparsemps.Kind | str | int");
};
struct RectLike {
  static constexpr auto name = py::detail::const_name("tuple[float, float, float, float]");
};
struct BoxLike {
  static constexpr auto name = py::detail::const_name("tuple[float, float, float, float, float, float]");
};
struct AxisBoxLike {
  static constexpr auto name = py::detail::const_name("tuple[float, ...]");
};
struct DomainLike {
  static constexpr auto name = py::detail::const_name("sparsemps.Domain | tuple[float, float, float, float]");
};
struct OptionalDomain {
  static constexpr auto name = py::detail::const_name("sparsemps.Domain | tuple[float, float, float, float] | None");
};
struct Domain3Like {
  static constexpr auto name =
      py::detail::const_name("sparsemps.Domain3 | tuple[float, float, float, float, float, float]");
};
struct ConfigLike {
  static constexpr auto name = py::detail::const_name("sparsemps.SimulationConfig | dict | None");
};
struct SidesLike {
  static constexpr auto name = py::detail::const_name("str | list[str]");
};
struct FieldValue {
  static constexpr auto name = py::detail::const_name("float | int | bool | str");
};
struct EitherParticles {
  static constexpr auto name = py::detail::const_name("sparsemps.Particles | sparsemps.Particles3");
};

template <class T>
py::array_t<T> to_numpy(const std::vector<T>& v) {
  py::array_t<T> out(static_cast<py::ssize_t>(v.size()));
  std::copy(v.begin(), v.end(), out.mutable_data());
  return out;
}

// Flags (std::vector<char>) as a NumPy bool array.
py::array_t<bool> flags_to_numpy(const std::vector<char>& v);

// A 1-D array of real numbers (any real dtype) as doubles; `n` >= 0 demands that length. The messages name `what`.
std::vector<double> to_doubles(py::handle obj, const std::string& what, py::ssize_t n = -1);
// Same, every value finite: a ValueError names the first NaN or Inf by its index.
std::vector<double> to_finite_doubles(py::handle obj, const std::string& what, py::ssize_t n = -1);
// A 1-D array of integers as ints; `n` >= 0 demands that length.
std::vector<int> to_ints(py::handle obj, const std::string& what, py::ssize_t n = -1);

// Anything scipy.sparse.csr_matrix accepts (a CSR, COO, ... matrix or array, a dense array) as the library's CSR:
// duplicates summed, columns sorted, indices checked to fit 32 bits. A sparse matrix's own arrays (indptr, indices,
// row, col, data) are checked before SciPy converts it: a ValueError names the damaged entry.
mps::CsrMatrix to_csr(py::handle obj);
// scipy.sparse.csr_matrix over copies of the arrays (int32 indices, float64 values).
py::object to_scipy(const mps::CsrMatrix& a);

void bind_solvers(py::module_& m);
void bind_scene(py::module_& m);

}  // namespace sparsemps

namespace pybind11::detail {
template <class Name>
struct type_caster<sparsemps::Typed<Name>> {
  PYBIND11_TYPE_CASTER(sparsemps::Typed<Name>, Name::name);
  bool load(handle src, bool) {
    value.obj = reinterpret_borrow<object>(src);
    return true;
  }
  static handle cast(const sparsemps::Typed<Name>& src, return_value_policy, handle) { return src.obj.inc_ref(); }
};
}  // namespace pybind11::detail
