#include "mps/csr.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

namespace mps {

void CsrMatrix::multiply(std::span<const double> x, std::span<double> y) const {
  if (x.size() != static_cast<std::size_t>(cols) || y.size() != static_cast<std::size_t>(rows))
    throw std::invalid_argument("CsrMatrix::multiply: vector sizes do not match the matrix");
#pragma omp parallel for schedule(static)
  for (int i = 0; i < rows; ++i) {
    double s = 0.0;
    for (int k = row_ptr[static_cast<std::size_t>(i)]; k < row_ptr[static_cast<std::size_t>(i) + 1]; ++k)
      s += val[static_cast<std::size_t>(k)] * x[static_cast<std::size_t>(col[static_cast<std::size_t>(k)])];
    y[static_cast<std::size_t>(i)] = s;
  }
}

double CsrMatrix::at(int i, int j) const {
  const auto b = col.begin() + row_ptr[static_cast<std::size_t>(i)];
  const auto e = col.begin() + row_ptr[static_cast<std::size_t>(i) + 1];
  const auto it = std::lower_bound(b, e, j);
  return (it != e && *it == j) ? val[static_cast<std::size_t>(it - col.begin())] : 0.0;
}

bool CsrMatrix::is_symmetric(double tol) const {
  if (rows != cols) return false;
  double scale = 0.0;
  for (double v : val) scale = std::max(scale, std::abs(v));
  for (int i = 0; i < rows; ++i)
    for (int k = row_ptr[static_cast<std::size_t>(i)]; k < row_ptr[static_cast<std::size_t>(i) + 1]; ++k) {
      const int j = col[static_cast<std::size_t>(k)];
      if (std::abs(val[static_cast<std::size_t>(k)] - at(j, i)) > tol * scale) return false;
    }
  return true;
}

void CsrMatrix::validate() const {
  if (rows < 0 || cols < 0 || row_ptr.size() != static_cast<std::size_t>(rows) + 1 || row_ptr.front() != 0 ||
      static_cast<std::size_t>(row_ptr.back()) != col.size() || col.size() != val.size())
    throw std::invalid_argument("CsrMatrix: row_ptr, col and val sizes are inconsistent");
  for (int i = 0; i < rows; ++i) {
    const int b = row_ptr[static_cast<std::size_t>(i)], e = row_ptr[static_cast<std::size_t>(i) + 1];
    if (e < b) throw std::invalid_argument("CsrMatrix: row_ptr decreases at row " + std::to_string(i));
    for (int k = b; k < e; ++k) {
      const int j = col[static_cast<std::size_t>(k)];
      if (j < 0 || j >= cols || (k > b && j <= col[static_cast<std::size_t>(k) - 1]))
        throw std::invalid_argument("CsrMatrix: columns must be in range and ascending (row " +
                                    std::to_string(i) + ")");
    }
  }
}

double norm2(std::span<const double> x) {
  double s = 0.0;
  for (double v : x) s += v * v;
  return std::sqrt(s);
}

double relative_residual(const CsrMatrix& a, std::span<const double> x, std::span<const double> b) {
  std::vector<double> r(b.size());
  a.multiply(x, r);
  for (std::size_t i = 0; i < r.size(); ++i) r[i] = b[i] - r[i];
  const double nb = norm2(b);
  return nb > 0.0 ? norm2(r) / nb : norm2(r);
}

}  // namespace mps
