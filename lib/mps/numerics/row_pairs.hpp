#pragma once
/// \file
/// One particle's listed pairs as arrays, for the pair loops of the operators and the PPE (private to the library).
#include <array>
#include <cmath>
#include <cstddef>
#include <vector>

#include "mps/core/domain.hpp"
#include "mps/core/kernel.hpp"
#include "mps/core/neighbors.hpp"
#include "mps/core/particles.hpp"

namespace mps::detail {

/// Row i's pairs in the list's order: d[a][k] = r_j - r_i, r2[k] = |d|^2 and r[k] = |d| for its k-th neighbour j,
/// and the kernel's w at r. Their square roots and divisions go two to an SSE2 instruction: the loops below carry no
/// branch and write through restrict pointers, so GCC vectorises them (operators.cpp and ppe.cpp build with
/// -fno-math-errno -fno-trapping-math for that). An operator then sums terms from these arrays pair by pair in list
/// order: each term is the same IEEE operations as a pair at a time, so every sum keeps its bits (docs/benchmarks.md).
template <int D>
class RowPairs {
 public:
  /// Fills d, r2 and r for row i of `neighbors`; returns the row's length.
  std::size_t fill(const BasicParticles<D>& p, const BasicDomain<D>& domain, const NeighborList& neighbors,
                   std::size_t i) {
    const std::size_t m = fill_displacements(p, domain, neighbors, i);
    const double* __restrict r2 = r2_.data();
    double* __restrict r = r_.data();
    for (std::size_t k = 0; k < m; ++k) r[k] = std::sqrt(r2[k]);
    return m;
  }
  /// Same without r: for a pass that keeps few of the pairs and reads r2 to choose them (r() is stale).
  std::size_t fill_displacements(const BasicParticles<D>& p, const BasicDomain<D>& domain,
                                 const NeighborList& neighbors, std::size_t i) {
    const auto row = neighbors.of(i);
    const std::size_t m = row.size();
    if (r_.size() < m) {
      for (auto* v : {&d_[0], &d_[1], &d_[D - 1], &r2_, &r_, &w_}) v->resize(2 * m);
      for (auto& t : t_) t.resize(2 * m);
    }
    const int* __restrict id = row.data();
    const auto periodic = domain.periodic();
    for (std::size_t a = 0; a < D; ++a) {
      const double* __restrict x = p.positions()[a]->data();
      double* __restrict out = d_[a].data();
      const double xi = x[i];
      for (std::size_t k = 0; k < m; ++k) out[k] = x[static_cast<std::size_t>(id[k])] - xi;
      // Displacement's nearest image, an axis at a time: a pair's position is not copied through a call.
      if (periodic[a]) {
        const double length = domain.extent(static_cast<int>(a));
        for (std::size_t k = 0; k < m; ++k) out[k] = BasicDomain<D>::nearest_image(out[k], length);
      }
    }
    const double* __restrict dx = d_[0].data();
    const double* __restrict dy = d_[1].data();
    double* __restrict r2 = r2_.data();
    if constexpr (D == 2) {
      for (std::size_t k = 0; k < m; ++k) r2[k] = dx[k] * dx[k] + dy[k] * dy[k];
    } else {
      const double* __restrict dz = d_[2].data();
      for (std::size_t k = 0; k < m; ++k) r2[k] = dx[k] * dx[k] + dy[k] * dy[k] + dz[k] * dz[k];
    }
    size_ = m;
    return m;
  }
  /// Kernel::w at each pair's distance into w(), +0 where Kernel::w is not above 0 (Kernel::w's bits elsewhere).
  void weigh(const Kernel& kernel) {
    const double re = kernel.re;
    const double* __restrict r = r_.data();
    double* __restrict w = w_.data();
    if (kernel.weight == Weight::bounded) {
      for (std::size_t k = 0; k < size_; ++k) {
        const double v = re / (0.85 * r[k] + 0.15 * re) - 1.0;
        w[k] = (r[k] < re) & (v > 0.0) ? v : 0.0;
      }
    } else {
      for (std::size_t k = 0; k < size_; ++k) {
        const double v = re / r[k] - 1.0;
        w[k] = (r[k] < re) & (v > 0.0) ? v : 0.0;
      }
    }
  }
  /// Kernel::laplacian_weight at each pair's distance into w() (weigh's +0s for the MPS weight).
  void weigh_laplacian(const Kernel& kernel) {
    if (!kernel.higher_order_laplacian) return weigh(kernel);
    for (std::size_t k = 0; k < size_; ++k) w_[k] = kernel.higher_order_weight(r_[k]);
  }
  [[nodiscard]] const double* d(std::size_t axis) const { return d_[axis].data(); }
  [[nodiscard]] const double* r2() const { return r2_.data(); }
  [[nodiscard]] const double* r() const { return r_.data(); }
  [[nodiscard]] const double* w() const { return w_.data(); }
  /// Room for up to nine terms per pair, which an operator computes here before it sums them.
  [[nodiscard]] double* terms(std::size_t which) { return t_[which].data(); }

 private:
  std::array<std::vector<double>, D> d_;
  std::vector<double> r2_, r_, w_;
  std::array<std::vector<double>, 9> t_;
  std::size_t size_ = 0;
};

}  // namespace mps::detail
