#pragma once
/// \file
/// Compressed sparse row matrix with 32-bit indices and sorted columns: the layout Eigen, CHOLMOD and hypre
/// all accept, so every backend reads the PPE without converting it.
#include <cstddef>
#include <span>
#include <vector>

namespace mps {

/// A sparse matrix in CSR form: row i's entries are val[row_ptr[i] .. row_ptr[i + 1]) in columns col[...].
struct CsrMatrix {
  /// @{ dimensions
  int rows = 0, cols = 0;  /// @}
  std::vector<int> row_ptr{0};  ///< rows + 1 entries
  std::vector<int> col;         ///< ascending within a row
  std::vector<double> val;      ///< the entries, in the order of col

  [[nodiscard]] std::size_t nnz() const { return val.size(); }  ///< stored entries
  void multiply(std::span<const double> x, std::span<double> y) const;  ///< y = A x
  [[nodiscard]] double at(int i, int j) const;                          ///< 0 where no entry is stored
  /// max |a_ij - a_ji| <= tol * max |a_ij| over the stored pattern and its transpose
  [[nodiscard]] bool is_symmetric(double tol = 1e-12) const;
  void validate() const;  ///< throws std::invalid_argument if the arrays do not form a CSR matrix
};

/// M = A with each off-diagonal entry of magnitude below `threshold` moved onto its row's diagonal (row sums kept).
/// M is symmetric where A is, and diagonally dominant where A is: a sparser matrix for building a preconditioner.
/// first_row: the global number of a's first row when a is one rank's block of rows.
void lump_weak_entries(const CsrMatrix& a, double threshold, CsrMatrix& m, int first_row = 0);
/// The largest |a_ij| with i != j (0 for a diagonal matrix).
double largest_off_diagonal(const CsrMatrix& a, int first_row = 0);
/// CsrMatrix::is_symmetric's test for a square matrix whose row r holds only columns greater than r from entry
/// after[r] on (one past its diagonal, where it has one), and whose largest |a_ij| is `largest`: a caller that has
/// read every row already (the solvers' input checks) skips is_symmetric's own passes for these two.
[[nodiscard]] bool is_symmetric_after(const CsrMatrix& a, std::vector<int> after, double largest, double tol = 1e-12);

double norm2(std::span<const double> x);  ///< Euclidean norm
/// ||b - A x|| / ||b|| (or ||b - A x|| when b = 0)
double relative_residual(const CsrMatrix& a, std::span<const double> x, std::span<const double> b);

}  // namespace mps
