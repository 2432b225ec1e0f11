#include "mps/operators.hpp"
#include "mps/parallel.hpp"

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

// Calls f(j, dx, dy, r2, w) for every neighbour j of i with w > 0.
template <class F>
void for_each_pair(const Stencil& s, std::size_t i, F&& f) {
  const Particles& p = s.particles;
  for (int j : s.neighbors.of(i)) {
    const auto d = s.domain.displacement(p.x[i], p.y[i], p.x[static_cast<std::size_t>(j)],
                                         p.y[static_cast<std::size_t>(j)]);
    const double r2 = d[0] * d[0] + d[1] * d[1];
    const double w = s.kernel.w(std::sqrt(r2));
    if (w > 0.0) f(static_cast<std::size_t>(j), d[0], d[1], r2, w);
  }
}

Index count(const Stencil& s) { return static_cast<Index>(s.particles.size()); }

// sum_j r_ij/|r_ij|^2 w_ij: up the particle concentration's gradient (shifting), into the liquid (surface normals).
std::array<double, 2> concentration_sum(const Stencil& s, std::size_t i) {
  double gx = 0.0, gy = 0.0;
  for_each_pair(s, i, [&](std::size_t, double rx, double ry, double r2, double w) {
    gx += rx / r2 * w;
    gy += ry / r2 * w;
  });
  return {gx, gy};
}

// A CSR matrix with one row per particle, built from per-pair coefficients in two passes; `diagonal`
// asks for an explicit diagonal entry placed in column order.
template <class Coefficient>
CsrMatrix pair_matrix(const Stencil& s, bool diagonal, Coefficient&& coefficient) {
  const Index n = count(s);
  CsrMatrix a;
  a.rows = a.cols = static_cast<int>(n);
  a.row_ptr.assign(static_cast<std::size_t>(n) + 1, 0);
#pragma omp parallel for schedule(static) if (detail::worth_threads(n))
  for (Index i = 0; i < n; ++i) {
    int c = diagonal ? 1 : 0;
    for_each_pair(s, static_cast<std::size_t>(i), [&](std::size_t, double, double, double, double) { ++c; });
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
    for_each_pair(s, static_cast<std::size_t>(i), [&](std::size_t j, double dx, double dy, double r2, double w) {
      if (!placed && j > static_cast<std::size_t>(i)) {
        diag_slot = k++;
        placed = true;
      }
      const double c = coefficient(dx, dy, r2, w);
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

std::vector<double> number_density(const Stencil& s) {
  std::vector<double> out;
  number_density(s, out);
  return out;
}

void number_density(const Stencil& s, std::vector<double>& out) {
  const Index n = count(s);
  out.assign(static_cast<std::size_t>(n), 0.0);
#pragma omp parallel for schedule(static) if (detail::worth_threads(n))
  for (Index i = 0; i < n; ++i) {
    double sum = 0.0;
    for_each_pair(s, static_cast<std::size_t>(i), [&](std::size_t, double, double, double, double w) { sum += w; });
    out[static_cast<std::size_t>(i)] = sum;
  }
}

void neighbour_asymmetry(const Stencil& s, std::vector<double>& out) {
  const Index n = count(s);
  out.assign(static_cast<std::size_t>(n), 0.0);
#pragma omp parallel for schedule(static) if (detail::worth_threads(n))
  for (Index i = 0; i < n; ++i) {
    double fx = 0.0, fy = 0.0;
    for_each_pair(s, static_cast<std::size_t>(i), [&](std::size_t, double dx, double dy, double r2, double w) {
      const double r = std::sqrt(r2);
      if (r > 0.0) {
        fx += w * dx / r;
        fy += w * dy / r;
      }
    });
    out[static_cast<std::size_t>(i)] = std::hypot(fx, fy) / s.kernel.n0;
  }
}

double asymmetry_of_flat_surface(const Kernel& k, double l0) {
  const int n = static_cast<int>(std::ceil(k.re / l0));
  double fy = 0.0;
  for (int j = -n; j <= 0; ++j)
    for (int i = -n; i <= n; ++i) {
      const double r = l0 * std::hypot(i, j);
      if (r > 0.0) fy += k.w(r) * j * l0 / r;
    }
  return std::abs(fy) / k.n0;
}

namespace {
// The sums sx = sum (phi_j - ref) w r_ij/|r_ij|^2 (and its y part) scaled to the gradient, multiplied by the inverse of
// the corrective matrix whose sums are mxx, mxy, myy when `corrected`.
std::array<double, 2> scaled_gradient(double scale, double sx, double sy, bool corrected, double mxx, double mxy,
                                      double myy) {
  sx *= scale;
  sy *= scale;
  const double det = scale * scale * (mxx * myy - mxy * mxy);
  // A neighbourhood too thin to span the plane (det near 0) keeps the uncorrected value.
  if (corrected && det > 1e-3) return {scale * (myy * sx - mxy * sy) / det, scale * (mxx * sy - mxy * sx) / det};
  return {sx, sy};
}

// grad u and grad v at particle i with the corrective matrix, built once for both: the numbers of
// gradient(..., GradientVariant::corrected) for each.
std::array<double, 4> corrected_velocity_gradient(const Stencil& s, std::size_t i, std::span<const double> u,
                                                  std::span<const double> v) {
  double ux = 0.0, uy = 0.0, vx = 0.0, vy = 0.0, mxx = 0.0, mxy = 0.0, myy = 0.0;
  for_each_pair(s, i, [&](std::size_t j, double dx, double dy, double r2, double w) {
    const double fu = (u[j] - u[i]) * w / r2, fv = (v[j] - v[i]) * w / r2;
    ux += fu * dx;
    uy += fu * dy;
    vx += fv * dx;
    vy += fv * dy;
    mxx += w * dx * dx / r2;
    mxy += w * dx * dy / r2;
    myy += w * dy * dy / r2;
  });
  const double scale = kDim / s.kernel.n0;
  const auto gu = scaled_gradient(scale, ux, uy, true, mxx, mxy, myy);
  const auto gv = scaled_gradient(scale, vx, vy, true, mxx, mxy, myy);
  return {gu[0], gu[1], gv[0], gv[1]};
}
}  // namespace

void gradient(const Stencil& s, std::span<const double> phi, std::span<double> gx, std::span<double> gy,
              GradientVariant variant, std::span<const char> carriers, std::array<double, 2> min_tilt,
              std::span<const char> own_reference) {
  if (!carriers.empty()) check_size(carriers.size(), s.particles.size(), "carriers");
  if (!own_reference.empty()) check_size(own_reference.size(), s.particles.size(), "own_reference");
  const auto carries = [&](std::size_t j) { return carriers.empty() || carriers[j] != 0; };
  const Index n = count(s);
  check_size(phi.size(), s.particles.size(), "phi");
  check_size(gx.size(), s.particles.size(), "gx");
  check_size(gy.size(), s.particles.size(), "gy");
  const double scale = kDim / s.kernel.n0;
  const bool min_ref = variant == GradientVariant::min_reference || variant == GradientVariant::corrected_min_reference;
  const bool corrected = variant == GradientVariant::corrected || variant == GradientVariant::corrected_min_reference;
#pragma omp parallel for schedule(static) if (detail::worth_threads(n))
  for (Index ii = 0; ii < n; ++ii) {
    const auto i = static_cast<std::size_t>(ii);
    double ref = variant == GradientVariant::conservative ? -phi[i] : phi[i];
    if (min_ref && (own_reference.empty() || own_reference[i] == 0)) {
      // The tilted minimum removes the known linear part from the classic one, never going below it: where
      // phi is imposed (P = 0 on a free surface) the tilt would otherwise invent a dip.
      double classic = phi[i], tilted = phi[i];
      for_each_pair(s, i, [&](std::size_t j, double dx, double dy, double, double) {
        if (!carries(j)) return;
        classic = std::min(classic, phi[j]);
        tilted = std::min(tilted, phi[j] - min_tilt[0] * dx - min_tilt[1] * dy);
      });
      ref = std::max(classic, tilted);
    }
    double sx = 0.0, sy = 0.0, mxx = 0.0, mxy = 0.0, myy = 0.0;
    for_each_pair(s, i, [&](std::size_t j, double dx, double dy, double r2, double w) {
      if (!carries(j)) return;
      const double f = (phi[j] - ref) * w / r2;
      sx += f * dx;
      sy += f * dy;
      if (!corrected) return;
      mxx += w * dx * dx / r2;
      mxy += w * dx * dy / r2;
      myy += w * dy * dy / r2;
    });
    const auto g = scaled_gradient(scale, sx, sy, corrected, mxx, mxy, myy);
    gx[i] = g[0];
    gy[i] = g[1];
  }
}

void conservative_gradient_terms(const Stencil& s, std::span<const double> phi, std::span<const char> sources,
                                 std::span<const char> targets, std::span<const char> carriers, std::span<double> ox,
                                 std::span<double> oy) {
  const std::size_t n = s.particles.size();
  check_size(phi.size(), n, "phi");
  check_size(sources.size(), n, "sources");
  check_size(targets.size(), n, "targets");
  if (!carriers.empty()) check_size(carriers.size(), n, "carriers");
  check_size(ox.size(), n, "ox");
  check_size(oy.size(), n, "oy");
  const double scale = kDim / s.kernel.n0;
#pragma omp parallel for schedule(static) if (detail::worth_threads(count(s)))
  for (Index jj = 0; jj < count(s); ++jj) {
    const auto j = static_cast<std::size_t>(jj);
    double sx = 0.0, sy = 0.0;
    if (targets[j] && (carriers.empty() || carriers[j]))
      // (dx, dy) = r_i - r_j here, the negative of r_ij in i's gradient
      for_each_pair(s, j, [&](std::size_t i, double dx, double dy, double r2, double w) {
        if (!sources[i]) return;
        const double f = (phi[i] + phi[j]) * w / r2;
        sx -= f * dx;
        sy -= f * dy;
      });
    ox[j] = scale * sx;
    oy[j] = scale * sy;
  }
}

void divergence(const Stencil& s, std::span<const double> u, std::span<const double> v, std::span<double> out) {
  const Index n = count(s);
  check_size(u.size(), s.particles.size(), "u");
  check_size(v.size(), s.particles.size(), "v");
  check_size(out.size(), s.particles.size(), "out");
  const double scale = kDim / s.kernel.n0;
#pragma omp parallel for schedule(static) if (detail::worth_threads(n))
  for (Index ii = 0; ii < n; ++ii) {
    const auto i = static_cast<std::size_t>(ii);
    double sum = 0.0;
    for_each_pair(s, i, [&](std::size_t j, double dx, double dy, double r2, double w) {
      sum += ((u[j] - u[i]) * dx + (v[j] - v[i]) * dy) * w / r2;
    });
    out[i] = scale * sum;
  }
}

namespace {

// The Laplacian of K fields in one pass over the pairs: each pair's distance and weight serve them all.
template <std::size_t K>
void laplacian_of(const Stencil& s, const std::array<std::span<const double>, K>& in,
                  const std::array<std::span<double>, K>& out) {
  for (std::size_t f = 0; f < K; ++f) {
    check_size(in[f].size(), s.particles.size(), "field");
    check_size(out[f].size(), s.particles.size(), "out");
  }
  const Index n = count(s);
  const double scale = 2.0 * kDim / (s.kernel.lambda * s.kernel.n0);
#pragma omp parallel for schedule(static) if (detail::worth_threads(n))
  for (Index ii = 0; ii < n; ++ii) {
    const auto i = static_cast<std::size_t>(ii);
    std::array<double, K> sum{};
    for_each_pair(s, i, [&](std::size_t j, double, double, double, double w) {
      for (std::size_t f = 0; f < K; ++f) sum[f] += (in[f][j] - in[f][i]) * w;
    });
    for (std::size_t f = 0; f < K; ++f) out[f][i] = scale * sum[f];
  }
}

}  // namespace

void laplacian(const Stencil& s, std::span<const double> phi, std::span<double> out) {
  laplacian_of<1>(s, {phi}, {out});
}

void laplacian(const Stencil& s, std::span<const double> u, std::span<const double> v, std::span<double> lu,
               std::span<double> lv) {
  laplacian_of<2>(s, {u, v}, {lu, lv});
}

CsrMatrix laplacian_matrix(const Stencil& s) {
  const double scale = 2.0 * kDim / (s.kernel.lambda * s.kernel.n0);
  return pair_matrix(s, true, [scale](double, double, double, double w) { return scale * w; });
}

GradientMatrices gradient_matrices(const Stencil& s) {
  const double scale = kDim / s.kernel.n0;
  return {pair_matrix(s, true, [scale](double dx, double, double r2, double w) { return scale * dx * w / r2; }),
          pair_matrix(s, true, [scale](double, double dy, double r2, double w) { return scale * dy * w / r2; })};
}

void surface_normals(const Stencil& s, std::span<const char> want, std::vector<double>& nx, std::vector<double>& ny) {
  const Index n = count(s);
  check_size(want.size(), static_cast<std::size_t>(n), "want");
  nx.assign(static_cast<std::size_t>(n), 0.0);
  ny.assign(static_cast<std::size_t>(n), 0.0);
#pragma omp parallel for schedule(static) if (detail::worth_threads(n))
  for (Index ii = 0; ii < n; ++ii) {
    const auto i = static_cast<std::size_t>(ii);
    if (!want[i]) continue;
    const auto [gx, gy] = concentration_sum(s, i);
    // Inside a full kernel the sum is round-off, whose direction means nothing.
    const double length = std::hypot(gx, gy);
    if (length > 1e-9 * s.kernel.n0 / s.kernel.re) {
      nx[i] = -gx / length;
      ny[i] = -gy / length;
    }
  }
}

double shift_particles(const Stencil& s, double diffusion, double max_shift, std::span<const char> movable,
                       Particles& particles, std::span<const double> normal_x, std::span<const double> normal_y) {
  if (&s.particles != &particles) throw std::invalid_argument("shift_particles: the stencil must see the particles moved");
  if (!(diffusion >= 0.0) || !(max_shift >= 0.0)) throw std::invalid_argument("shift_particles: need diffusion, max_shift >= 0");
  const Index n = count(s);
  check_size(movable.size(), static_cast<std::size_t>(n), "movable");
  const auto size = static_cast<std::size_t>(n);
  const bool along_surface = !normal_x.empty();
  if (along_surface) {
    check_size(normal_x.size(), size, "normal_x");
    check_size(normal_y.size(), size, "normal_y");
  }
  std::vector<double> dx(size, 0.0), dy(size, 0.0);
  const double scale = diffusion * 2.0 / s.kernel.n0;  // d = 2
#pragma omp parallel for schedule(static) if (detail::worth_threads(n))
  for (Index ii = 0; ii < n; ++ii) {
    const auto i = static_cast<std::size_t>(ii);
    if (!movable[i]) continue;
    const auto [gx, gy] = concentration_sum(s, i);
    double sx = -scale * gx, sy = -scale * gy;
    if (along_surface) {
      const double normal_part = sx * normal_x[i] + sy * normal_y[i];
      sx -= normal_part * normal_x[i];
      sy -= normal_part * normal_y[i];
    }
    const double length = std::hypot(sx, sy);
    if (length > max_shift) {
      sx *= max_shift / length;
      sy *= max_shift / length;
    }
    dx[i] = sx;
    dy[i] = sy;
  }
  // The velocity gradients before any particle moves, only where a particle moves.
  std::vector<std::array<double, 4>> grad_uv(size);
#pragma omp parallel for schedule(static) if (detail::worth_threads(n))
  for (Index ii = 0; ii < n; ++ii) {
    const auto i = static_cast<std::size_t>(ii);
    if (movable[i]) grad_uv[i] = corrected_velocity_gradient(s, i, particles.u, particles.v);
  }
  double largest = 0.0;
  for (std::size_t i = 0; i < size; ++i) {
    if (!movable[i]) continue;
    const auto& [ux, uy, vx, vy] = grad_uv[i];
    particles.u[i] += dx[i] * ux + dy[i] * uy;
    particles.v[i] += dx[i] * vx + dy[i] * vy;
    particles.x[i] += dx[i];
    particles.y[i] += dy[i];
    s.domain.wrap(particles.x[i], particles.y[i]);
    largest = std::max(largest, std::hypot(dx[i], dy[i]));
  }
  return largest;
}

long collision_velocity_changes(const Particles& p, const Domain& domain, const NeighborList& neighbors, double reach,
                                double restitution, std::span<const char> movable, std::vector<double>& du,
                                std::vector<double>& dv) {
  check_size(movable.size(), p.size(), "movable");
  const auto n = static_cast<Index>(p.size());
  du.assign(p.size(), 0.0);
  dv.assign(p.size(), 0.0);
  long pairs = 0;
#pragma omp parallel for schedule(static) reduction(+ : pairs) if (detail::worth_threads(n))
  for (Index ii = 0; ii < n; ++ii) {
    const auto i = static_cast<std::size_t>(ii);
    if (p.kind[i] != Kind::fluid || !movable[i]) continue;
    for (int jn : neighbors.of(i)) {
      const auto j = static_cast<std::size_t>(jn);
      if (p.kind[j] == Kind::ghost) continue;
      const auto d = domain.displacement(p.x[i], p.y[i], p.x[j], p.y[j]);
      const double r = std::hypot(d[0], d[1]);
      if (r >= reach || r == 0.0) continue;
      const double nx = d[0] / r, ny = d[1] / r;
      const double approach = (p.u[i] - p.u[j]) * nx + (p.v[i] - p.v[j]) * ny;  // > 0: closing in
      if (approach <= 0.0) continue;
      // A wall, dummy or prescribed fluid particle does not give way: the moving one takes all of the impulse.
      const double share = p.kind[j] == Kind::fluid && movable[j] ? 0.5 : 1.0;
      du[i] -= share * (1.0 + restitution) * approach * nx;
      dv[i] -= share * (1.0 + restitution) * approach * ny;
      ++pairs;
    }
  }
  return pairs;
}

}  // namespace mps
