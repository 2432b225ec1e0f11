#include "mps/numerics/operators.hpp"
#include "mps/core/threads.hpp"
#include "mps/core/vec.hpp"
#include "mps/numerics/row_pairs.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <stdexcept>
#include <string>
#include <utility>

namespace mps {
namespace {

using Index = std::ptrdiff_t;

void check_size(std::size_t got, std::size_t want, const char* what) {
  if (got != want) throw std::invalid_argument(std::string("operator: ") + what + " has the wrong length");
}

// Calls f(j, d, r2, r, w) for every neighbour j of i with w > 0, d = r_j - r_i, r2 = |d|^2, r = sqrt(r2).
template <int D, class F>
void for_each_pair_at_distance(const BasicStencil<D>& s, std::size_t i, F&& f) {
  const BasicParticles<D>& p = s.particles;
  std::array<const double*, D> X;
  for (std::size_t a = 0; a < D; ++a) X[a] = p.positions()[a]->data();
  const Displacement<D> displacement(s.domain);
  Vec<D> ri;
  for (std::size_t a = 0; a < D; ++a) ri[a] = X[a][i];
  for (int j : s.neighbors.of(i)) {
    const auto jj = static_cast<std::size_t>(j);
    Vec<D> rj;
    for (std::size_t a = 0; a < D; ++a) rj[a] = X[a][jj];
    const Vec<D> d = displacement(ri, rj);
    const double r2 = norm2<D>(d);
    const double r = std::sqrt(r2);
    const double w = s.kernel.w(r);
    if (w > 0.0) f(jj, d, r2, r, w);
  }
}

// Calls f(j, d, r2, w) for every neighbour j of i with w > 0, d = r_j - r_i.
template <int D, class F>
void for_each_pair(const BasicStencil<D>& s, std::size_t i, F&& f) {
  for_each_pair_at_distance(s, i, [&](std::size_t j, const Vec<D>& d, double r2, double, double w) { f(j, d, r2, w); });
}

// One pair's term of number_density_rate: w'(r) (r_ij . u_ij) / r, or 0 for coincident particles, whose distance has
// no direction to change along.
template <int D>
[[gnu::always_inline]] inline double rate_term(const BasicStencil<D>& s, const ConstComponents<D>& u, std::size_t i,
                                               std::size_t j, const Vec<D>& d, double r) {
  if (!(r > 0.0)) return 0.0;
  double approach = (u[0][j] - u[0][i]) * d[0];
  for (std::size_t a = 1; a < D; ++a) approach += (u[a][j] - u[a][i]) * d[a];
  return s.kernel.dw(r) * approach / r;
}

template <int D>
Index count(const BasicStencil<D>& s) {
  return static_cast<Index>(s.particles.size());
}

// Calls f(i, pairs, m) for every row i that `rows` flags (every row if empty) with its m pairs filled (and weighed
// unless Weighed is false), the rows shared among the threads as `schedule(static)` shares them.
template <bool Weighed = true, int D, class F>
void for_each_row_pairs(const BasicStencil<D>& s, std::span<const char> rows, F&& f) {
  const Index n = count(s);
#pragma omp parallel if (detail::worth_threads(n))
  {
    detail::RowPairs<D> pairs;
#pragma omp for schedule(static)
    for (Index ii = 0; ii < n; ++ii) {
      const auto i = static_cast<std::size_t>(ii);
      if (!rows.empty() && !rows[i]) continue;
      const std::size_t m = pairs.fill(s.particles, s.domain, s.neighbors, i);
      if constexpr (Weighed) pairs.weigh(s.kernel);
      f(i, pairs, m);
    }
  }
}

// terms(first + c) for c < K, each summed in list order, the K sums side by side: each is a chain of dependent
// additions, and K chains at once no longer wait on one another's latency.
template <std::size_t K, int D>
std::array<double, K> sums_side_by_side(detail::RowPairs<D>& pairs, std::size_t m, std::size_t first = 0) {
  std::array<const double*, K> terms{};
  for (std::size_t c = 0; c < K; ++c) terms[c] = pairs.terms(first + c);
  std::array<double, K> sum{};
  for (std::size_t k = 0; k < m; ++k)
    for (std::size_t c = 0; c < K; ++c) sum[c] += terms[c][k];
  return sum;
}

// sum_j r_ij/|r_ij|^2 w_ij over row i's pairs (filled and weighed): up the particle concentration's gradient
// (shifting), into the liquid (surface normals).
template <int D>
Vec<D> concentration_sum(detail::RowPairs<D>& pairs, std::size_t m) {
  const double* __restrict r2 = pairs.r2();
  const double* __restrict w = pairs.w();
  for (std::size_t a = 0; a < D; ++a) {
    const double* __restrict d = pairs.d(a);
    double* __restrict term = pairs.terms(a);
    for (std::size_t k = 0; k < m; ++k) term[k] = w[k] > 0.0 ? d[k] / r2[k] * w[k] : 0.0;
  }
  return sums_side_by_side<D, D>(pairs, m);
}

// A CSR matrix with one row per particle, built from per-pair coefficients in two passes; `diagonal`
// asks for an explicit diagonal entry placed in column order.
template <int D, class Coefficient>
CsrMatrix pair_matrix(const BasicStencil<D>& s, bool diagonal, Coefficient&& coefficient) {
  const Index n = count(s);
  CsrMatrix a;
  a.rows = a.cols = static_cast<int>(n);
  a.row_ptr.assign(static_cast<std::size_t>(n) + 1, 0);
#pragma omp parallel for schedule(static) if (detail::worth_threads(n))
  for (Index i = 0; i < n; ++i) {
    int c = diagonal ? 1 : 0;
    for_each_pair(s, static_cast<std::size_t>(i), [&](std::size_t, const Vec<D>&, double, double) { ++c; });
    a.row_ptr[static_cast<std::size_t>(i) + 1] = c;
  }
  for (std::size_t i = 1; i < a.row_ptr.size(); ++i) a.row_ptr[i] += a.row_ptr[i - 1];
  a.col.resize(static_cast<std::size_t>(a.row_ptr.back()));
  a.val.resize(a.col.size());
#pragma omp parallel for schedule(static) if (detail::worth_threads(n))
  for (Index i = 0; i < n; ++i) {
    auto k = static_cast<std::size_t>(a.row_ptr[static_cast<std::size_t>(i)]);
    std::size_t diag_slot = k;
    double diag = 0.0;
    bool placed = !diagonal;
    for_each_pair(s, static_cast<std::size_t>(i), [&](std::size_t j, const Vec<D>& d, double r2, double w) {
      if (!placed && j > static_cast<std::size_t>(i)) {
        diag_slot = k++;
        placed = true;
      }
      const double c = coefficient(d, r2, w);
      a.col[k] = static_cast<int>(j);
      a.val[k++] = c;
      diag -= c;
    });
    if (!placed) diag_slot = k++;
    if (diagonal) {
      a.col[diag_slot] = static_cast<int>(i);
      a.val[diag_slot] = diag;
    }
  }
  return a;
}

constexpr std::array<std::pair<GradientVariant, std::string_view>, 5> gradient_names{{
    {GradientVariant::plain, "plain"},
    {GradientVariant::min_reference, "min-reference"},
    {GradientVariant::corrected, "corrected"},
    {GradientVariant::corrected_min_reference, "corrected-min-reference"},
    {GradientVariant::conservative, "conservative"},
}};

}  // namespace

std::string_view to_string(GradientVariant variant) {
  for (const auto& [v, name] : gradient_names)
    if (v == variant) return name;
  return "unknown";
}

GradientVariant gradient_variant_from_name(std::string_view name) {
  for (const auto& [v, n] : gradient_names)
    if (n == name) return v;
  throw std::invalid_argument("unknown pressure gradient '" + std::string(name) +
                              "': choose plain, min-reference, corrected, corrected-min-reference or conservative");
}


template <int D>
std::vector<double> number_density(const BasicStencil<D>& s) {
  std::vector<double> out;
  number_density(s, out);
  return out;
}

template <int D>
void number_density(const BasicStencil<D>& s, std::vector<double>& out, std::span<const char> rows) {
  const Index n = count(s);
  if (!rows.empty()) check_size(rows.size(), s.particles.size(), "rows");
  out.assign(static_cast<std::size_t>(n), 0.0);
  for_each_row_pairs(s, rows, [&](std::size_t i, detail::RowPairs<D>& pairs, std::size_t m) {
    const double* w = pairs.w();
    double sum = 0.0;
    for (std::size_t k = 0; k < m; ++k) sum += w[k];
    out[i] = sum;
  });
}

template <int D>
void neighbour_asymmetry(const BasicStencil<D>& s, std::vector<double>& out, std::span<const char> rows) {
  const Index n = count(s);
  if (!rows.empty()) check_size(rows.size(), s.particles.size(), "rows");
  out.assign(static_cast<std::size_t>(n), 0.0);
  for_each_row_pairs(s, rows, [&](std::size_t i, detail::RowPairs<D>& pairs, std::size_t m) {
    const double* __restrict r = pairs.r();
    const double* __restrict w = pairs.w();
    for (std::size_t a = 0; a < D; ++a) {
      const double* __restrict d = pairs.d(a);
      double* __restrict term = pairs.terms(a);
      for (std::size_t k = 0; k < m; ++k) term[k] = (w[k] > 0.0) & (r[k] > 0.0) ? w[k] * d[k] / r[k] : 0.0;
    }
    out[i] = norm<D>(sums_side_by_side<D, D>(pairs, m)) / s.kernel.n0;
  });
}

double asymmetry_of_flat_surface(const Kernel& k, double l0) {
  const int n = static_cast<int>(std::ceil(k.re / l0));
  // The lattice below a flat surface: the last axis runs from -n to 0.
  double f = 0.0;
  if (k.dim == 2) {
    for (int j = -n; j <= 0; ++j)
      for (int i = -n; i <= n; ++i) {
        const double r = l0 * std::hypot(i, j);
        if (r > 0.0) f += k.w(r) * j * l0 / r;
      }
  } else {
    for (int c = -n; c <= 0; ++c)
      for (int j = -n; j <= n; ++j)
        for (int i = -n; i <= n; ++i) {
          const double r = l0 * std::hypot(i, j, c);
          if (r > 0.0) f += k.w(r) * c * l0 / r;
        }
  }
  return std::abs(f) / k.n0;
}

namespace {
// The corrective matrix's sums sum w r_a r_b / r^2 over a <= b (2-D: xx, xy, yy; 3-D: xx, xy, xz, yy, yz, zz).
template <int D>
using Moments = std::array<double, D * (D + 1) / 2>;

template <int D>
void add_moments(Moments<D>& m, const Vec<D>& d, double r2, double w) {
  std::size_t k = 0;
  for (std::size_t a = 0; a < D; ++a)
    for (std::size_t b = a; b < D; ++b) m[k++] += w * d[a] * d[b] / r2;
}

// The sums s = sum (phi_j - ref) w r_ij/|r_ij|^2 scaled to the gradient, multiplied by the inverse of the corrective
// matrix whose sums are m when `corrected`.
template <int D>
Vec<D> scaled_gradient(double scale, Vec<D> g, bool corrected, const Moments<D>& m) {
  for (std::size_t a = 0; a < D; ++a) g[a] *= scale;
  if constexpr (D == 2) {
    const double mxx = m[0], mxy = m[1], myy = m[2], sx = g[0], sy = g[1];
    const double det = scale * scale * (mxx * myy - mxy * mxy);
    // A neighbourhood too thin to span the plane (det near 0) keeps the uncorrected value.
    if (corrected && det > 1e-3) return {scale * (myy * sx - mxy * sy) / det, scale * (mxx * sy - mxy * sx) / det};
    return g;
  } else {
    if (!corrected) return g;
    const double xx = scale * m[0], xy = scale * m[1], xz = scale * m[2], yy = scale * m[3], yz = scale * m[4],
                 zz = scale * m[5];
    // The adjugate of the symmetric matrix over its determinant.
    const double cxx = yy * zz - yz * yz, cxy = xz * yz - xy * zz, cxz = xy * yz - xz * yy;
    const double cyy = xx * zz - xz * xz, cyz = xy * xz - xx * yz, czz = xx * yy - xy * xy;
    const double det = xx * cxx + xy * cxy + xz * cxz;
    // A neighbourhood too thin to span the space (det near 0) keeps the uncorrected value.
    if (!(det > 1e-3)) return g;
    return {(cxx * g[0] + cxy * g[1] + cxz * g[2]) / det, (cxy * g[0] + cyy * g[1] + cyz * g[2]) / det,
            (cxz * g[0] + cyz * g[1] + czz * g[2]) / det};
  }
}

// The velocity's gradient at particle i with the corrective matrix, built once for every component: the numbers of
// gradient(..., GradientVariant::corrected) for each. g[c][a] = d u_c / d x_a.
template <int D>
std::array<Vec<D>, D> corrected_velocity_gradient(const BasicStencil<D>& s, detail::RowPairs<D>& pairs, std::size_t m,
                                                  std::size_t i) {
  const auto vel = s.particles.velocities();
  const int* __restrict id = s.neighbors.of(i).data();
  const double* __restrict r2 = pairs.r2();
  const double* __restrict w = pairs.w();
  // Each pair's (u_c,j - u_c,i) w / r^2 and w r_a r_b / r^2 first (the divisions two to an instruction), then the sums
  // in list order over the pairs with w > 0.
  for (std::size_t c = 0; c < D; ++c) {
    const double* __restrict u = vel[c]->data();
    const double ui = u[i];
    double* __restrict f = pairs.terms(c);
    for (std::size_t k = 0; k < m; ++k) f[k] = (u[static_cast<std::size_t>(id[k])] - ui) * w[k] / r2[k];
  }
  std::size_t slot = D;
  for (std::size_t a = 0; a < D; ++a)
    for (std::size_t b = a; b < D; ++b) {
      const double* __restrict da = pairs.d(a);
      const double* __restrict db = pairs.d(b);
      double* __restrict t = pairs.terms(slot++);
      for (std::size_t k = 0; k < m; ++k) t[k] = w[k] * da[k] * db[k] / r2[k];
    }
  std::array<Vec<D>, D> g{};
  Moments<D> mo{};
  for (std::size_t k = 0; k < m; ++k) {
    if (!(w[k] > 0.0)) continue;
    for (std::size_t c = 0; c < D; ++c) {
      const double f = pairs.terms(c)[k];
      for (std::size_t a = 0; a < D; ++a) g[c][a] += f * pairs.d(a)[k];
    }
    for (std::size_t q = 0; q < mo.size(); ++q) mo[q] += pairs.terms(D + q)[k];
  }
  const double scale = D / s.kernel.n0;
  for (std::size_t c = 0; c < D; ++c) g[c] = scaled_gradient<D>(scale, g[c], true, mo);
  return g;
}

template <int D>
void check_components(const BasicStencil<D>& s, const Components<D>& g, const char* what) {
  for (std::size_t a = 0; a < D; ++a) check_size(g[a].size(), s.particles.size(), what);
}
}  // namespace

template <int D>
void gradient(const BasicStencil<D>& s, std::span<const double> phi, const Components<D>& g, GradientVariant variant,
              std::span<const char> carriers, const std::type_identity_t<Vec<D>>& min_tilt,
              std::span<const char> own_reference, std::span<const char> rows) {
  if (!carriers.empty()) check_size(carriers.size(), s.particles.size(), "carriers");
  if (!own_reference.empty()) check_size(own_reference.size(), s.particles.size(), "own_reference");
  if (!rows.empty()) check_size(rows.size(), s.particles.size(), "rows");
  const auto carries = [&](std::size_t j) { return carriers.empty() || carriers[j] != 0; };
  check_size(phi.size(), s.particles.size(), "phi");
  check_components(s, g, "gradient");
  const double scale = D / s.kernel.n0;
  const bool min_ref = variant == GradientVariant::min_reference || variant == GradientVariant::corrected_min_reference;
  const bool corrected = variant == GradientVariant::corrected || variant == GradientVariant::corrected_min_reference;
  for_each_row_pairs(s, rows, [&](std::size_t i, detail::RowPairs<D>& pairs, std::size_t m_pairs) {
    const int* __restrict id = s.neighbors.of(i).data();
    const double* __restrict r2 = pairs.r2();
    const double* __restrict w = pairs.w();
    double ref = variant == GradientVariant::conservative ? -phi[i] : phi[i];
    if (min_ref && (own_reference.empty() || own_reference[i] == 0)) {
      // The tilted minimum removes the known linear part from the classic one, never going below it: where
      // phi is imposed (P = 0 on a free surface) the tilt would otherwise invent a dip.
      double classic = phi[i], tilted = phi[i];
      for (std::size_t k = 0; k < m_pairs; ++k) {
        const auto j = static_cast<std::size_t>(id[k]);
        if (!(w[k] > 0.0) || !carries(j)) continue;
        classic = std::min(classic, phi[j]);
        double untilted = phi[j];
        for (std::size_t a = 0; a < D; ++a) untilted -= min_tilt[a] * pairs.d(a)[k];
        tilted = std::min(tilted, untilted);
      }
      ref = std::max(classic, tilted);
    }
    // (phi_j - ref) w / r^2 for every pair at once (the divisions two to an instruction), then the sums in list order.
    double* __restrict q = pairs.terms(0);
    for (std::size_t k = 0; k < m_pairs; ++k) q[k] = (phi[static_cast<std::size_t>(id[k])] - ref) * w[k] / r2[k];
    Vec<D> sum{};
    Moments<D> m{};
    for (std::size_t k = 0; k < m_pairs; ++k) {
      const auto j = static_cast<std::size_t>(id[k]);
      if (!(w[k] > 0.0) || !carries(j)) continue;
      Vec<D> d;
      for (std::size_t a = 0; a < D; ++a) d[a] = pairs.d(a)[k];
      for (std::size_t a = 0; a < D; ++a) sum[a] += q[k] * d[a];
      if (corrected) add_moments<D>(m, d, r2[k], w[k]);
    }
    const Vec<D> gi = scaled_gradient<D>(scale, sum, corrected, m);
    for (std::size_t a = 0; a < D; ++a) g[a][i] = gi[a];
  });
}

template <int D>
void conservative_gradient_terms(const BasicStencil<D>& s, std::span<const double> phi, std::span<const char> sources,
                                 std::span<const char> targets, std::span<const char> carriers,
                                 const Components<D>& out) {
  const std::size_t n = s.particles.size();
  check_size(phi.size(), n, "phi");
  check_size(sources.size(), n, "sources");
  check_size(targets.size(), n, "targets");
  if (!carriers.empty()) check_size(carriers.size(), n, "carriers");
  check_components(s, out, "out");
  const double scale = D / s.kernel.n0;
#pragma omp parallel for schedule(static) if (detail::worth_threads(count(s)))
  for (Index jj = 0; jj < count(s); ++jj) {
    const auto j = static_cast<std::size_t>(jj);
    Vec<D> sum{};
    if (targets[j] && (carriers.empty() || carriers[j]))
      // d = r_i - r_j here, the negative of r_ij in i's gradient
      for_each_pair(s, j, [&](std::size_t i, const Vec<D>& d, double r2, double w) {
        if (!sources[i]) return;
        const double f = (phi[i] + phi[j]) * w / r2;
        for (std::size_t a = 0; a < D; ++a) sum[a] -= f * d[a];
      });
    for (std::size_t a = 0; a < D; ++a) out[a][j] = scale * sum[a];
  }
}

template <int D>
void divergence(const BasicStencil<D>& s, const ConstComponents<D>& u, std::span<double> out,
                std::span<const char> rows) {
  const Index n = count(s);
  for (std::size_t a = 0; a < D; ++a) check_size(u[a].size(), s.particles.size(), "velocity");
  check_size(out.size(), s.particles.size(), "out");
  if (!rows.empty()) check_size(rows.size(), s.particles.size(), "rows");
  const double scale = D / s.kernel.n0;
#pragma omp parallel for schedule(static) if (detail::worth_threads(n))
  for (Index ii = 0; ii < n; ++ii) {
    const auto i = static_cast<std::size_t>(ii);
    if (!rows.empty() && !rows[i]) continue;
    double sum = 0.0;
    for_each_pair(s, i, [&](std::size_t j, const Vec<D>& d, double r2, double w) {
      double flux = (u[0][j] - u[0][i]) * d[0];
      for (std::size_t a = 1; a < D; ++a) flux += (u[a][j] - u[a][i]) * d[a];
      sum += flux * w / r2;
    });
    out[i] = scale * sum;
  }
}

template <int D>
void number_density_rate(const BasicStencil<D>& s, const ConstComponents<D>& u, std::span<double> out) {
  const Index n = count(s);
  for (std::size_t a = 0; a < D; ++a) check_size(u[a].size(), s.particles.size(), "velocity");
  check_size(out.size(), s.particles.size(), "out");
#pragma omp parallel for schedule(static) if (detail::worth_threads(n))
  for (Index ii = 0; ii < n; ++ii) {
    const auto i = static_cast<std::size_t>(ii);
    double sum = 0.0;
    for_each_pair_at_distance(s, i, [&](std::size_t j, const Vec<D>& d, double, double r, double) {
      sum += rate_term<D>(s, u, i, j, d, r);
    });
    out[i] = sum;
  }
}

template <int D>
void number_density_and_rate(const BasicStencil<D>& s, const ConstComponents<D>& u, std::vector<double>& n_out,
                             std::span<double> rate, std::span<const char> rows) {
  const Index n = count(s);
  for (std::size_t a = 0; a < D; ++a) check_size(u[a].size(), s.particles.size(), "velocity");
  check_size(rate.size(), s.particles.size(), "rate");
  if (!rows.empty()) check_size(rows.size(), s.particles.size(), "rows");
  n_out.assign(static_cast<std::size_t>(n), 0.0);
  const double re = s.kernel.re;
  const bool bounded = s.kernel.weight == Weight::bounded;
  for_each_row_pairs(s, rows, [&](std::size_t i, detail::RowPairs<D>& pairs, std::size_t m) {
    // rate_term's operations, pair by pair, an axis at a time; +0 where a pair has no weight or no direction.
    const int* __restrict id = s.neighbors.of(i).data();
    const double* __restrict r = pairs.r();
    const double* __restrict w = pairs.w();
    double* __restrict term = pairs.terms(0);
    for (std::size_t a = 0; a < D; ++a) {
      const double* __restrict v = u[a].data();
      const double* __restrict d = pairs.d(a);
      const double vi = v[i];
      if (a == 0)
        for (std::size_t k = 0; k < m; ++k) term[k] = (v[static_cast<std::size_t>(id[k])] - vi) * d[k];
      else
        for (std::size_t k = 0; k < m; ++k) term[k] += (v[static_cast<std::size_t>(id[k])] - vi) * d[k];
    }
    for (std::size_t k = 0; k < m; ++k) {
      const double sk = 0.85 * r[k] + 0.15 * re;
      const double dw = bounded ? -0.85 * re / (sk * sk) : -re / (r[k] * r[k]);
      const double t = dw * term[k] / r[k];
      term[k] = (w[k] > 0.0) & (r[k] > 0.0) ? t : 0.0;
    }
    double density = 0.0, sum = 0.0;
    for (std::size_t k = 0; k < m; ++k) {
      density += w[k];
      sum += term[k];
    }
    n_out[i] = density;
    rate[i] = sum;
  });
}

namespace {

// The Laplacian of K fields in one pass over the pairs: each pair's distance and weight serve them all.
template <int D, std::size_t K>
void laplacian_of(const BasicStencil<D>& s, const std::array<std::span<const double>, K>& in,
                  const std::array<std::span<double>, K>& out, std::span<const char> rows = {}) {
  for (std::size_t f = 0; f < K; ++f) {
    check_size(in[f].size(), s.particles.size(), "field");
    check_size(out[f].size(), s.particles.size(), "out");
  }
  if (!rows.empty()) check_size(rows.size(), s.particles.size(), "rows");
  const Index n = count(s);
  const double scale = s.kernel.laplacian_scale(D);
  const bool higher_order = s.kernel.higher_order_laplacian;
  if (!higher_order) {
    // Every listed pair adds its term (Kernel::w_unbranched): the w > 0 loop's bits, without its branch to
    // mispredict where a list reaches past re (one carried over from the last step, SimulationConfig::neighbor_skin).
    const Kernel& kernel = s.kernel;
    for_each_row_pairs<false>(s, rows, [&](std::size_t i, detail::RowPairs<D>& pairs, std::size_t m) {
      const int* __restrict id = s.neighbors.of(i).data();
      const double* __restrict r = pairs.r();
      double* __restrict w = pairs.terms(0);
      for (std::size_t k = 0; k < m; ++k) w[k] = kernel.w_unbranched(r[k]);
      for (std::size_t f = 0; f < K; ++f) {
        const double* __restrict field = in[f].data();
        double* __restrict term = pairs.terms(1 + f);
        const double fi = field[i];
        for (std::size_t k = 0; k < m; ++k) term[k] = (field[static_cast<std::size_t>(id[k])] - fi) * w[k];
      }
      const std::array<double, K> sum = sums_side_by_side<K, D>(pairs, m, 1);
      for (std::size_t f = 0; f < K; ++f) out[f][i] = scale * sum[f];
    });
    return;
  }
#pragma omp parallel for schedule(static) if (detail::worth_threads(n))
  for (Index ii = 0; ii < n; ++ii) {
    const auto i = static_cast<std::size_t>(ii);
    if (!rows.empty() && !rows[i]) continue;
    std::array<double, K> sum{};
    for_each_pair(s, i, [&](std::size_t j, const Vec<D>&, double r2, double) {
      const double weight = s.kernel.higher_order_weight(std::sqrt(r2));
      for (std::size_t f = 0; f < K; ++f) sum[f] += (in[f][j] - in[f][i]) * weight;
    });
    for (std::size_t f = 0; f < K; ++f) out[f][i] = scale * sum[f];
  }
}

}  // namespace

template <int D>
void laplacian(const BasicStencil<D>& s, std::span<const double> phi, std::span<double> out) {
  laplacian_of<D, 1>(s, {phi}, {out});
}

template <int D>
void laplacian(const BasicStencil<D>& s, const ConstComponents<D>& u, const Components<D>& out,
               std::span<const char> rows) {
  laplacian_of<D, static_cast<std::size_t>(D)>(s, u, out, rows);
}

template <int D>
CsrMatrix laplacian_matrix(const BasicStencil<D>& s) {
  const double scale = s.kernel.laplacian_scale(D);
  const Kernel& k = s.kernel;
  return pair_matrix(s, true, [scale, &k](const Vec<D>&, double r2, double w) {
    return scale * (k.higher_order_laplacian ? k.higher_order_weight(std::sqrt(r2)) : w);
  });
}

GradientMatrices gradient_matrices(const Stencil& s) {
  const double scale = 2 / s.kernel.n0;
  return {pair_matrix(s, true, [scale](const Vec<2>& d, double r2, double w) { return scale * d[0] * w / r2; }),
          pair_matrix(s, true, [scale](const Vec<2>& d, double r2, double w) { return scale * d[1] * w / r2; })};
}

template <int D>
void surface_normals(const BasicStencil<D>& s, std::span<const char> want, std::type_identity_t<std::array<std::vector<double>, D>>& normal) {
  const Index n = count(s);
  check_size(want.size(), static_cast<std::size_t>(n), "want");
  for (auto& c : normal) c.assign(static_cast<std::size_t>(n), 0.0);
  for_each_row_pairs(s, want, [&](std::size_t i, detail::RowPairs<D>& pairs, std::size_t m) {
    const Vec<D> g = concentration_sum(pairs, m);
    // Inside a full kernel the sum is round-off, whose direction means nothing.
    const double length = norm<D>(g);
    if (length > 1e-9 * s.kernel.n0 / s.kernel.re)
      for (std::size_t a = 0; a < D; ++a) normal[a][i] = -g[a] / length;
  });
}

template <int D>
double shift_particles(const BasicStencil<D>& s, double diffusion, double max_shift, std::span<const char> movable,
                       BasicParticles<D>& particles, const ConstComponents<D>& normal) {
  if (&s.particles != &particles) throw std::invalid_argument("shift_particles: the stencil must see the particles moved");
  if (!(diffusion >= 0.0) || !(max_shift >= 0.0)) throw std::invalid_argument("shift_particles: need diffusion, max_shift >= 0");
  const Index n = count(s);
  check_size(movable.size(), static_cast<std::size_t>(n), "movable");
  const auto size = static_cast<std::size_t>(n);
  const bool along_surface = !normal[0].empty();
  if (along_surface)
    for (std::size_t a = 0; a < D; ++a) check_size(normal[a].size(), size, "normal");
  std::vector<Vec<D>> shift(size, Vec<D>{});
  // The velocity gradients before any particle moves, only where a particle moves.
  std::vector<std::array<Vec<D>, D>> grad(size);
  const double scale = diffusion * static_cast<double>(D) / s.kernel.n0;
  for_each_row_pairs(s, movable, [&](std::size_t i, detail::RowPairs<D>& pairs, std::size_t m) {
    const Vec<D> g = concentration_sum(pairs, m);
    Vec<D> sh;
    for (std::size_t a = 0; a < D; ++a) sh[a] = -scale * g[a];
    if (along_surface) {
      double normal_part = sh[0] * normal[0][i];
      for (std::size_t a = 1; a < D; ++a) normal_part += sh[a] * normal[a][i];
      for (std::size_t a = 0; a < D; ++a) sh[a] -= normal_part * normal[a][i];
    }
    const double length = norm<D>(sh);
    if (length > max_shift)
      for (std::size_t a = 0; a < D; ++a) sh[a] *= max_shift / length;
    shift[i] = sh;
    grad[i] = corrected_velocity_gradient(s, pairs, m, i);
  });
  const auto positions = particles.positions();
  const auto velocities = particles.velocities();
  double largest = 0.0;
  for (std::size_t i = 0; i < size; ++i) {
    if (!movable[i]) continue;
    for (std::size_t c = 0; c < D; ++c) (*velocities[c])[i] += dot<D>(shift[i], grad[i][c]);
    Vec<D> r;
    for (std::size_t a = 0; a < D; ++a) r[a] = (*positions[a])[i] + shift[i][a];
    s.domain.wrap(r);
    for (std::size_t a = 0; a < D; ++a) (*positions[a])[i] = r[a];
    largest = std::max(largest, norm<D>(shift[i]));
  }
  return largest;
}

namespace {
// What collisions and the dynamic stabilisation share: every pair of a movable fluid particle i and a neighbour j
// nearer than `reach` gets the speed speed_along(r, approach) (approach > 0: closing in) taken off i along r_ij, shared
// between two movable fluid particles and all i's when j is fixed. A speed of 0 or less skips the pair.
template <int D, class SpeedAlong>
long close_pair_velocity_changes(const BasicParticles<D>& p, const BasicDomain<D>& domain, const NeighborList& neighbors,
                                 double reach, std::span<const char> movable, std::array<std::vector<double>, D>& change,
                                 SpeedAlong speed_along) {
  check_size(movable.size(), p.size(), "movable");
  const auto n = static_cast<Index>(p.size());
  for (auto& c : change) c.assign(p.size(), 0.0);
  const auto vel = p.velocities();
  // Most of a list lies far beyond the reach: a pair whose squared distance clears reach^2 by far more than rounding
  // is skipped without the square root (docs/benchmarks.md); the others decide as before.
  const double clearly_out2 = reach * reach * (1.0 + 1e-12);
  long pairs = 0;
#pragma omp parallel if (detail::worth_threads(n))
  {
    detail::RowPairs<D> row;
#pragma omp for schedule(static) reduction(+ : pairs)
    for (Index ii = 0; ii < n; ++ii) {
      const auto i = static_cast<std::size_t>(ii);
      if (p.kind[i] != Kind::fluid || !movable[i]) continue;
      const std::size_t m = row.fill_displacements(p, domain, neighbors, i);
      const int* id = neighbors.of(i).data();
      const double* r2 = row.r2();
      for (std::size_t k = 0; k < m; ++k) {
        if (r2[k] > clearly_out2) continue;
        const auto j = static_cast<std::size_t>(id[k]);
        if (p.kind[j] == Kind::ghost) continue;
        Vec<D> d;
        for (std::size_t a = 0; a < D; ++a) d[a] = row.d(a)[k];
        const double r = norm<D>(d);
        if (r >= reach || r == 0.0) continue;
        Vec<D> unit;
        for (std::size_t a = 0; a < D; ++a) unit[a] = d[a] / r;
        double approach = ((*vel[0])[i] - (*vel[0])[j]) * unit[0];  // > 0: closing in
        for (std::size_t a = 1; a < D; ++a) approach += ((*vel[a])[i] - (*vel[a])[j]) * unit[a];
        const double speed = speed_along(r, approach);
        if (!(speed > 0.0)) continue;
        // A wall, dummy or prescribed fluid particle does not give way: the moving one takes all of the change.
        const double share = p.kind[j] == Kind::fluid && movable[j] ? 0.5 : 1.0;
        for (std::size_t a = 0; a < D; ++a) change[a][i] -= share * speed * unit[a];
        ++pairs;
      }
    }
  }
  return pairs;
}
}  // namespace

template <int D>
long collision_velocity_changes(const BasicParticles<D>& p, const BasicDomain<D>& domain,
                                const NeighborList& neighbors, double reach, double restitution,
                                std::span<const char> movable, std::type_identity_t<std::array<std::vector<double>, D>>& change) {
  return close_pair_velocity_changes<D>(p, domain, neighbors, reach, movable, change,
                                        [restitution](double, double approach) {
                                          return approach > 0.0 ? (1.0 + restitution) * approach : 0.0;
                                        });
}

template <int D>
long stabilisation_velocity_changes(const BasicParticles<D>& p, const BasicDomain<D>& domain,
                                    const NeighborList& neighbors, double reach, double dt, std::span<const char> movable,
                                    std::type_identity_t<std::array<std::vector<double>, D>>& change) {
  return close_pair_velocity_changes<D>(p, domain, neighbors, reach, movable, change,
                                        [reach, dt](double r, double) { return (reach - r) / dt; });
}

#define MPS_OPERATORS_FOR(D)                                                                                          \
  template std::vector<double> number_density(const BasicStencil<D>&);                                               \
  template void number_density(const BasicStencil<D>&, std::vector<double>&, std::span<const char>);                 \
  template void neighbour_asymmetry(const BasicStencil<D>&, std::vector<double>&, std::span<const char>);            \
  template void gradient<D>(const BasicStencil<D>&, std::span<const double>, const Components<D>&, GradientVariant,     \
                         std::span<const char>, const Vec<D>&, std::span<const char>, std::span<const char>);        \
  template void conservative_gradient_terms<D>(const BasicStencil<D>&, std::span<const double>, std::span<const char>,  \
                                            std::span<const char>, std::span<const char>, const Components<D>&);     \
  template void divergence<D>(const BasicStencil<D>&, const ConstComponents<D>&, std::span<double>,                   \
                              std::span<const char>);                                                                \
  template void number_density_rate<D>(const BasicStencil<D>&, const ConstComponents<D>&, std::span<double>);           \
  template void number_density_and_rate<D>(const BasicStencil<D>&, const ConstComponents<D>&, std::vector<double>&,    \
                                           std::span<double>, std::span<const char>);                                 \
  template void laplacian(const BasicStencil<D>&, std::span<const double>, std::span<double>);                       \
  template void laplacian<D>(const BasicStencil<D>&, const ConstComponents<D>&, const Components<D>&,                  \
                             std::span<const char>);                                                                  \
  template CsrMatrix laplacian_matrix(const BasicStencil<D>&);                                                       \
  template void surface_normals<D>(const BasicStencil<D>&, std::span<const char>, std::array<std::vector<double>, D>&); \
  template double shift_particles<D>(const BasicStencil<D>&, double, double, std::span<const char>, BasicParticles<D>&, \
                                  const ConstComponents<D>&);                                                        \
  template long stabilisation_velocity_changes<D>(const BasicParticles<D>&, const BasicDomain<D>&, const NeighborList&, \
                                                 double, double, std::span<const char>,                            \
                                                 std::array<std::vector<double>, D>&);                             \
  template long collision_velocity_changes<D>(const BasicParticles<D>&, const BasicDomain<D>&, const NeighborList&,     \
                                           double, double, std::span<const char>, std::array<std::vector<double>, D>&);
MPS_OPERATORS_FOR(2)
MPS_OPERATORS_FOR(3)
#undef MPS_OPERATORS_FOR

}  // namespace mps
