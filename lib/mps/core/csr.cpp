#include "mps/core/csr.hpp"
#include "mps/core/threads.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>
#include <utility>

namespace mps {

void CsrMatrix::multiply(std::span<const double> x, std::span<double> y) const {
  if (x.size() != static_cast<std::size_t>(cols) || y.size() != static_cast<std::size_t>(rows))
    throw std::invalid_argument("CsrMatrix::multiply: vector sizes do not match the matrix");
#pragma omp parallel for schedule(static) if (detail::worth_threads(rows))
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
  double largest = 0.0;
  for (double v : val) largest = std::max(largest, std::abs(v));
  const auto n = static_cast<std::size_t>(rows);
  std::vector<int> after(n);
  for (std::size_t j = 0; j < n; ++j) {
    int k = row_ptr[j];
    while (k < row_ptr[j + 1] && static_cast<std::size_t>(col[static_cast<std::size_t>(k)]) <= j) ++k;
    after[j] = k;
  }
  return is_symmetric_after(*this, std::move(after), largest, tol);
}

// One pass over the sorted arrays (a binary search per entry cost a tenth of a numeric factorisation at 1e5
// unknowns): one cursor per row j pairs each a_ij (j < i) with its a_ji; entries left unpaired must be zero.
bool is_symmetric_after(const CsrMatrix& a, std::vector<int> after, double largest, double tol) {
  if (a.rows != a.cols) return false;
  const double limit = tol * largest;
  const auto n = static_cast<std::size_t>(a.rows);
  std::vector<int>& cursor = after;
  for (std::size_t i = 0; i < n; ++i)
    for (int k = a.row_ptr[i]; k < a.row_ptr[i + 1]; ++k) {
      const auto j = static_cast<std::size_t>(a.col[static_cast<std::size_t>(k)]);
      if (j >= i) break;
      int& c = cursor[j];
      // entries (j, col < i) of row j had no partner in their rows: they must be zero
      while (c < a.row_ptr[j + 1] && static_cast<std::size_t>(a.col[static_cast<std::size_t>(c)]) < i)
        if (std::abs(a.val[static_cast<std::size_t>(c++)]) > limit) return false;
      const bool paired = c < a.row_ptr[j + 1] && static_cast<std::size_t>(a.col[static_cast<std::size_t>(c)]) == i;
      const double partner = paired ? a.val[static_cast<std::size_t>(c++)] : 0.0;
      if (std::abs(a.val[static_cast<std::size_t>(k)] - partner) > limit) return false;
    }
  for (std::size_t j = 0; j < n; ++j)
    for (int c = cursor[j]; c < a.row_ptr[j + 1]; ++c)
      if (std::abs(a.val[static_cast<std::size_t>(c)]) > limit) return false;
  return true;
}

void CsrMatrix::validate() const {
  if (rows < 0 || cols < 0 || row_ptr.size() != static_cast<std::size_t>(rows) + 1 || row_ptr.front() != 0 ||
      static_cast<std::size_t>(row_ptr.back()) != col.size() || col.size() != val.size())
    throw std::invalid_argument("CsrMatrix: row_ptr, col and val sizes are inconsistent (rows " + std::to_string(rows) +
                                ", row_ptr " + std::to_string(row_ptr.size()) + " entries, col " +
                                std::to_string(col.size()) + ", val " + std::to_string(val.size()) +
                                "; row_ptr needs rows + 1 entries from 0 to the entry count)");
  for (int i = 0; i < rows; ++i) {
    const int b = row_ptr[static_cast<std::size_t>(i)], e = row_ptr[static_cast<std::size_t>(i) + 1];
    if (e < b) throw std::invalid_argument("CsrMatrix: row_ptr decreases at row " + std::to_string(i));
    for (int k = b; k < e; ++k) {
      const int j = col[static_cast<std::size_t>(k)];
      if (j < 0 || j >= cols)
        throw std::invalid_argument("CsrMatrix: column index " + std::to_string(j) + " in row " + std::to_string(i) +
                                    " is outside [0, " + std::to_string(cols) + ")");
      if (k > b && j <= col[static_cast<std::size_t>(k) - 1])
        throw std::invalid_argument("CsrMatrix: columns of row " + std::to_string(i) +
                                    " are not ascending (sort each row's columns and merge duplicates)");
    }
  }
}

void lump_weak_entries(const CsrMatrix& a, double threshold, CsrMatrix& m, int first_row) {
  m.rows = a.rows;
  m.cols = a.cols;
  m.row_ptr.assign(a.row_ptr.size(), 0);
  m.col.clear();
  m.val.clear();
  m.col.reserve(a.col.size());
  m.val.reserve(a.val.size());
  for (std::size_t i = 0; i < static_cast<std::size_t>(a.rows); ++i) {
    const int row = first_row + static_cast<int>(i);
    double lumped = 0.0;
    std::size_t diagonal = 0;
    bool has_diagonal = false;
    for (int k = a.row_ptr[i]; k < a.row_ptr[i + 1]; ++k) {
      const int j = a.col[static_cast<std::size_t>(k)];
      const double v = a.val[static_cast<std::size_t>(k)];
      const bool on_diagonal = j == row;
      if (!on_diagonal && std::abs(v) < threshold) {
        lumped += v;
        continue;
      }
      if (on_diagonal) {
        diagonal = m.val.size();
        has_diagonal = true;
      }
      m.col.push_back(j);
      m.val.push_back(v);
    }
    if (has_diagonal) m.val[diagonal] += lumped;
    else if (lumped != 0.0) {  // the diagonal slot is made where the columns pass i
      auto at = std::lower_bound(m.col.begin() + m.row_ptr[i], m.col.end(), row);
      const auto slot = at - m.col.begin();
      m.col.insert(at, row);
      m.val.insert(m.val.begin() + slot, lumped);
    }
    m.row_ptr[i + 1] = static_cast<int>(m.col.size());
  }
}

double largest_off_diagonal(const CsrMatrix& a, int first_row) {
  double largest = 0.0;
  for (std::size_t i = 0; i < static_cast<std::size_t>(a.rows); ++i)
    for (int k = a.row_ptr[i]; k < a.row_ptr[i + 1]; ++k)
      if (a.col[static_cast<std::size_t>(k)] != first_row + static_cast<int>(i))
        largest = std::max(largest, std::abs(a.val[static_cast<std::size_t>(k)]));
  return largest;
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
