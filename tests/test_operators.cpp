#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <random>
#include <string>
#include <vector>

#include "mps/boundaries/geometry.hpp"
#include "mps/numerics/operators.hpp"

namespace {

// A 40 x 40 perfect lattice; "interior" particles are at least 4.1 l0 from its edge.
struct Lattice {
  double l0 = 0.1;
  mps::Particles p;
  mps::Domain d{-1, 5, -1, 5};
  Lattice() { mps::fill_rectangle(p, {0, 0, 4, 4}, l0, mps::Kind::fluid); }
  bool interior(std::size_t i, double margin) const {
    return p.x[i] > margin && p.x[i] < 4 - margin && p.y[i] > margin && p.y[i] < 4 - margin;
  }
};

class OperatorsOnLattice : public ::testing::TestWithParam<mps::Weight> {};

TEST_P(OperatorsOnLattice, LaplacianOfQuadraticIsExactInTheInterior) {
  Lattice L;
  const mps::Kernel k = mps::make_kernel(4.1, L.l0, GetParam());
  const auto list = mps::find_neighbors(L.p, L.d, k.re);
  const mps::Stencil s{L.p, L.d, list, k};
  std::vector<double> phi(L.p.size()), lap(L.p.size());
  // lap(3x^2 - xy + 2y^2 + x) = 6 + 4 = 10
  for (std::size_t i = 0; i < phi.size(); ++i) {
    const double x = L.p.x[i], y = L.p.y[i];
    phi[i] = 3 * x * x - x * y + 2 * y * y + x;
  }
  mps::laplacian(s, phi, lap);
  int checked = 0;
  for (std::size_t i = 0; i < phi.size(); ++i)
    if (L.interior(i, 4.2 * L.l0)) {
      EXPECT_NEAR(lap[i], 10.0, 1e-9) << "at (" << L.p.x[i] << ", " << L.p.y[i] << ")";
      ++checked;
    }
  EXPECT_GT(checked, 900);
}

TEST_P(OperatorsOnLattice, GradientAndDivergenceOfLinearFieldsAreExact) {
  Lattice L;
  const mps::Kernel k = mps::make_kernel(2.1, L.l0, GetParam());
  const auto list = mps::find_neighbors(L.p, L.d, k.re);
  const mps::Stencil s{L.p, L.d, list, k};
  const std::size_t n = L.p.size();
  std::vector<double> phi(n), gx(n), gy(n), u(n), v(n), div(n);
  for (std::size_t i = 0; i < n; ++i) {
    phi[i] = 2.5 * L.p.x[i] - 1.5 * L.p.y[i] + 7;
    u[i] = 0.3 * L.p.x[i] + 2 * L.p.y[i];  // div (u, v) = 0.3 - 1.1 = -0.8
    v[i] = -L.p.x[i] - 1.1 * L.p.y[i];
  }
  mps::gradient(s, phi, gx, gy);
  mps::divergence(s, u, v, div);
  for (std::size_t i = 0; i < n; ++i)
    if (L.interior(i, 2.2 * L.l0)) {
      EXPECT_NEAR(gx[i], 2.5, 1e-12);
      EXPECT_NEAR(gy[i], -1.5, 1e-12);
      EXPECT_NEAR(div[i], -0.8, 1e-12);
    }
}

INSTANTIATE_TEST_SUITE_P(BothWeights, OperatorsOnLattice, ::testing::Values(mps::Weight::bounded, mps::Weight::classic));

TEST(Operators, MinimumReferenceGradientIsRepulsiveAndEqualsPlainForConstantShift) {
  Lattice L;
  const mps::Kernel k = mps::make_kernel(2.1, L.l0);
  const auto list = mps::find_neighbors(L.p, L.d, k.re);
  const mps::Stencil s{L.p, L.d, list, k};
  const std::size_t n = L.p.size();
  // A single pressure peak: every neighbour of the peak is pushed away from it (gradient points at it).
  std::vector<double> phi(n, 0.0), gx(n), gy(n);
  const std::size_t peak = 20 * 40 + 20;
  phi[peak] = 1.0;
  mps::gradient(s, phi, gx, gy, mps::GradientVariant::min_reference);
  for (int j : list.of(peak)) {
    const auto jj = static_cast<std::size_t>(j);
    const double toward = gx[jj] * (L.p.x[peak] - L.p.x[jj]) + gy[jj] * (L.p.y[peak] - L.p.y[jj]);
    EXPECT_GT(toward, 0.0);
  }
  // The peak itself: with the min reference (0) all neighbours are at the reference: no force.
  EXPECT_NEAR(gx[peak], 0.0, 1e-14);
}

TEST(Operators, LoopsAndMatricesAgreeOnDisorderedParticles) {
  mps::Particles p;
  mps::fill_rectangle(p, {0, 0, 2, 2}, 0.05, mps::Kind::fluid);
  std::mt19937 rng(7);
  std::normal_distribution<double> jitter(0.0, 0.01);
  for (std::size_t i = 0; i < p.size(); ++i) {
    p.x[i] += jitter(rng);
    p.y[i] += jitter(rng);
  }
  const mps::Domain d{-0.5, 2.5, -0.5, 2.5};
  const std::size_t n = p.size();
  std::vector<double> f(n), g(n);
  for (std::size_t i = 0; i < n; ++i) {
    f[i] = std::sin(3 * p.x[i]) * std::cos(2 * p.y[i]);
    g[i] = p.x[i] * p.y[i];
  }
  for (double radius : {2.1, 4.1}) {
    const mps::Kernel k = mps::make_kernel(radius, 0.05);
    const auto list = mps::find_neighbors(p, d, k.re);
    const mps::Stencil s{p, d, list, k};
    std::vector<double> loop(n), mat(n), gx(n), gy(n), mx(n), my(n), div(n), mdiv(n);
    mps::laplacian(s, f, loop);
    std::vector<double> loop_g(n), pair_f(n), pair_g(n);  // the viscous term's two-field pass is two calls in one
    mps::laplacian(s, g, loop_g);
    mps::laplacian(s, f, g, pair_f, pair_g);
    EXPECT_EQ(pair_f, loop);
    EXPECT_EQ(pair_g, loop_g);
    const mps::CsrMatrix lm = mps::laplacian_matrix(s);
    lm.validate();
    lm.multiply(f, mat);
    EXPECT_TRUE(lm.is_symmetric(1e-14));  // the MPS Laplacian is symmetric as a matrix
    mps::gradient(s, f, gx, gy);
    const mps::GradientMatrices gm = mps::gradient_matrices(s);
    gm.x.validate();
    gm.x.multiply(f, mx);
    gm.y.multiply(f, my);
    mps::divergence(s, f, g, div);
    std::vector<double> tmp(n);
    gm.x.multiply(f, mdiv);
    gm.y.multiply(g, tmp);
    double scale = 0.0;
    for (std::size_t i = 0; i < n; ++i) scale = std::max({scale, std::abs(loop[i]), std::abs(gx[i]), std::abs(div[i])});
    for (std::size_t i = 0; i < n; ++i) {
      EXPECT_NEAR(loop[i], mat[i], 1e-12 * scale);
      EXPECT_NEAR(gx[i], mx[i], 1e-12 * scale);
      EXPECT_NEAR(gy[i], my[i], 1e-12 * scale);
      EXPECT_NEAR(div[i], mdiv[i] + tmp[i], 1e-12 * scale);
    }
  }
}

// The rows a caller asks for (the step: the fluid it moves, or the fluid and walls) get the very bits of a call over
// every row, with both Laplacian paths, every gradient variant and the number density's operators; the other rows'
// entries are left as they were, or 0 where the operator sizes its output.
TEST(Operators, SelectedRowsAreComputedBitwiseAndTheOthersLeftAlone) {
  mps::Particles p;
  mps::fill_rectangle(p, {0, 0, 2, 2}, 0.05, mps::Kind::fluid);
  std::mt19937 rng(11);
  std::normal_distribution<double> jitter(0.0, 0.01);
  const std::size_t n = p.size();
  std::vector<char> rows(n);
  std::bernoulli_distribution pick(0.4);
  for (std::size_t i = 0; i < n; ++i) {
    p.x[i] += jitter(rng);
    p.y[i] += jitter(rng);
    rows[i] = pick(rng) ? 1 : 0;
  }
  const mps::Domain d{-0.5, 2.5, -0.5, 2.5};
  std::vector<double> f(n), g(n);
  for (std::size_t i = 0; i < n; ++i) {
    f[i] = std::sin(3 * p.x[i]) * std::cos(2 * p.y[i]);
    g[i] = p.x[i] * p.y[i];
  }
  const double untouched = -12345.0;
  auto check = [&](const std::vector<double>& all, const std::vector<double>& some, const char* what) {
    for (std::size_t i = 0; i < n; ++i)
      if (rows[i]) EXPECT_EQ(some[i], all[i]) << what << ", row " << i;
      else EXPECT_EQ(some[i], untouched) << what << ", row " << i;
  };
  for (bool higher_order : {false, true}) {
    mps::Kernel k = mps::make_kernel(4.1, 0.05);
    k.higher_order_laplacian = higher_order;
    const auto list = mps::find_neighbors(p, d, k.re);
    const mps::Stencil s{p, d, list, k};
    std::vector<double> lf(n), lg(n), sf(n, untouched), sg(n, untouched);
    mps::laplacian<2>(s, {f, g}, {lf, lg});
    mps::laplacian<2>(s, {f, g}, {sf, sg}, rows);
    check(lf, sf, higher_order ? "higher-order Laplacian" : "Laplacian");
    check(lg, sg, higher_order ? "higher-order Laplacian" : "Laplacian");
  }
  const mps::Kernel k = mps::make_kernel(2.1, 0.05);
  const auto list = mps::find_neighbors(p, d, k.re);
  const mps::Stencil s{p, d, list, k};
  {
    // number_density, neighbour_asymmetry and number_density_and_rate size n themselves: 0 where not asked for.
    std::vector<double> nd, nd_some, as, as_some, n_all, n_some, rate(n), rate_some(n, untouched), div(n),
        div_some(n, untouched);
    mps::number_density<2>(s, nd);
    mps::number_density<2>(s, nd_some, rows);
    mps::neighbour_asymmetry<2>(s, as);
    mps::neighbour_asymmetry<2>(s, as_some, rows);
    mps::number_density_and_rate<2>(s, {f, g}, n_all, rate);
    mps::number_density_and_rate<2>(s, {f, g}, n_some, rate_some, rows);
    mps::divergence<2>(s, {f, g}, div);
    mps::divergence<2>(s, {f, g}, div_some, rows);
    for (std::size_t i = 0; i < n; ++i)
      if (!rows[i]) {
        EXPECT_EQ(nd_some[i], 0.0);
        EXPECT_EQ(as_some[i], 0.0);
        EXPECT_EQ(n_some[i], 0.0);
        nd_some[i] = as_some[i] = n_some[i] = untouched;
      }
    check(nd, nd_some, "number density");
    check(as, as_some, "neighbour asymmetry");
    check(n_all, n_some, "number density and rate: n");
    check(rate, rate_some, "number density and rate: rate");
    check(div, div_some, "divergence");
  }
  for (auto variant : {mps::GradientVariant::plain, mps::GradientVariant::min_reference,
                       mps::GradientVariant::corrected, mps::GradientVariant::corrected_min_reference,
                       mps::GradientVariant::conservative}) {
    std::vector<double> gx(n), gy(n), sx(n, untouched), sy(n, untouched);
    mps::gradient<2>(s, f, {gx, gy}, variant, {}, {0.0, -1.0});
    mps::gradient<2>(s, f, {sx, sy}, variant, {}, {0.0, -1.0}, {}, rows);
    check(gx, sx, std::string(mps::to_string(variant)).c_str());
    check(gy, sy, std::string(mps::to_string(variant)).c_str());
  }
}

TEST(Operators, ConservativeGradientExchangesMomentumPairByPair) {
  // Disordered particles, a field with no symmetry, a third of them not carrying it.
  mps::Particles p;
  mps::fill_rectangle(p, {0, 0, 1, 1}, 0.05, mps::Kind::fluid);
  std::mt19937 rng(11);
  std::normal_distribution<double> jitter(0.0, 0.01);
  for (std::size_t i = 0; i < p.size(); ++i) {
    p.x[i] += jitter(rng);
    p.y[i] += jitter(rng);
  }
  const mps::Domain d{-0.5, 1.5, -0.5, 1.5};
  const std::size_t n = p.size();
  const mps::Kernel k = mps::make_kernel(2.1, 0.05);
  const auto list = mps::find_neighbors(p, d, k.re);
  const mps::Stencil s{p, d, list, k};
  std::vector<double> phi(n), gx(n), gy(n);
  std::vector<char> all(n, 1), carriers(n, 1), sources(n, 0), targets(n, 0), rest(n, 0);
  for (std::size_t i = 0; i < n; ++i) {
    phi[i] = 1.0 + std::exp(p.x[i]) * std::cos(3 * p.y[i]);
    carriers[i] = i % 3 != 0;
    sources[i] = p.x[i] < 0.5;          // "the fluid"
    targets[i] = !sources[i];           // "the body"
    rest[i] = carriers[i] && sources[i];  // carriers without the body
  }
  // Over particles that all carry phi, the pair terms cancel: sum_i grad_i = 0 to round-off.
  mps::gradient(s, phi, gx, gy, mps::GradientVariant::conservative, all);
  double sx = 0.0, sy = 0.0, scale = 0.0;
  for (std::size_t i = 0; i < n; ++i) {
    sx += gx[i];
    sy += gy[i];
    scale = std::max(scale, std::hypot(gx[i], gy[i]));
  }
  EXPECT_NEAR(sx, 0.0, 1e-12 * scale * n);
  EXPECT_NEAR(sy, 0.0, 1e-12 * scale * n);
  // What the targets give the sources' gradients, taken from the gradient itself (with and without the targets
  // carrying phi), is what conservative_gradient_terms hands the targets: a force -V grad on the one side, +V on the
  // other.
  std::vector<double> hx(n), hy(n), ox(n), oy(n);
  mps::gradient(s, phi, gx, gy, mps::GradientVariant::conservative, carriers);
  mps::gradient(s, phi, hx, hy, mps::GradientVariant::conservative, rest);
  mps::conservative_gradient_terms(s, phi, sources, targets, carriers, ox, oy);
  double given_x = 0.0, given_y = 0.0, back_x = 0.0, back_y = 0.0;
  for (std::size_t i = 0; i < n; ++i) {
    if (sources[i]) {
      given_x += gx[i] - hx[i];
      given_y += gy[i] - hy[i];
    } else {
      back_x += ox[i];
      back_y += oy[i];
    }
  }
  EXPECT_GT(std::hypot(given_x, given_y), 1.0);  // the exchange is not trivially zero
  EXPECT_NEAR(given_x - back_x, 0.0, 1e-12 * scale * n);
  EXPECT_NEAR(given_y - back_y, 0.0, 1e-12 * scale * n);
  // And on a full lattice the conservative gradient of a linear field is exact.
  Lattice L;
  const auto llist = mps::find_neighbors(L.p, L.d, k.re * 2.0);
  const mps::Kernel lk = mps::make_kernel(2.1, L.l0);
  const mps::Stencil ls{L.p, L.d, llist, lk};
  std::vector<double> lphi(L.p.size()), lgx(L.p.size()), lgy(L.p.size());
  for (std::size_t i = 0; i < L.p.size(); ++i) lphi[i] = 2.5 * L.p.x[i] - 1.5 * L.p.y[i] + 7;
  mps::gradient(ls, lphi, lgx, lgy, mps::GradientVariant::conservative);
  for (std::size_t i = 0; i < L.p.size(); ++i)
    if (L.interior(i, 2.2 * L.l0)) {
      EXPECT_NEAR(lgx[i], 2.5, 1e-11);
      EXPECT_NEAR(lgy[i], -1.5, 1e-11);
    }
}

TEST(Operators, NumberDensityOfInteriorLatticeParticleIsN0) {
  Lattice L;
  const mps::Kernel k = mps::make_kernel(2.1, L.l0);
  const auto list = mps::find_neighbors(L.p, L.d, k.re);
  const auto n = mps::number_density({L.p, L.d, list, k});
  for (std::size_t i = 0; i < n.size(); ++i)
    if (L.interior(i, 2.2 * L.l0)) {
      EXPECT_NEAR(n[i], k.n0, 1e-12);
    }
}

}  // namespace

namespace {
// The corrective matrix makes the gradient exact for linear fields where the neighbourhood is cut off (a
// free-surface row), which the plain MPS gradient is not.
TEST(Operators, NeighbourAsymmetryIsZeroInsideAndTheFlatSurfaceValueOnTheTopRow) {
  Lattice L;
  const mps::Kernel k = mps::make_kernel(2.1, L.l0);
  const auto list = mps::find_neighbors(L.p, L.d, k.re);
  std::vector<double> a;
  mps::neighbour_asymmetry({L.p, L.d, list, k}, a);
  const double flat = mps::asymmetry_of_flat_surface(k, L.l0);
  // By hand, in units of l0 with w(r) = 2.1/(0.85 r + 0.315) - 1: the top row's neighbours below it within 2.1 are
  // (0,-1) at r = 1, (+-1,-1) at sqrt 2 and (0,-2) at 2 (its own row adds nothing along y), each pulling w(r) |y|/r:
  // w(1) + sqrt(2) w(sqrt 2) + w(2) = 1.3881515..., over n0 = 4 (w(1) + w(sqrt 2) + w(2)) = 4.9159819... of the full
  // kernel: 0.28237524. w(1) = 187/233, w(2) = 17/403 and w(sqrt 2) = 420/(170 sqrt 2 + 63) - 1 exactly.
  const double w1 = 187.0 / 233.0, w2 = 17.0 / 403.0, wd = 420.0 / (170.0 * std::sqrt(2.0) + 63.0) - 1.0;
  EXPECT_NEAR(k.n0, 4.0 * (w1 + wd + w2), 1e-12);
  EXPECT_NEAR(flat, (w1 + std::sqrt(2.0) * wd + w2) / (4.0 * (w1 + wd + w2)), 1e-12);
  int inside = 0, top = 0;
  for (std::size_t i = 0; i < L.p.size(); ++i) {
    if (L.interior(i, 2.2 * L.l0)) {
      EXPECT_NEAR(a[i], 0.0, 1e-12);
      ++inside;
    }
    // The top row away from the side edges sees the half kernel of a flat surface.
    if (L.p.y[i] > 4 - L.l0 && L.p.x[i] > 2.2 * L.l0 && L.p.x[i] < 4 - 2.2 * L.l0) {
      EXPECT_NEAR(a[i], flat, 1e-12);
      ++top;
    }
  }
  EXPECT_GT(inside, 1000);
  EXPECT_GE(top, 30);
}

TEST(Operators, CorrectedGradientIsExactForLinearFieldsAtATruncatedSurface) {
  mps::Particles p;
  mps::fill_rectangle(p, {0, 0, 2, 1}, 0.1, mps::Kind::fluid);
  const mps::Domain d{-1, 3, -1, 2};
  const mps::Kernel k = mps::make_kernel(2.1, 0.1);
  const auto list = mps::find_neighbors(p, d, k.re);
  const mps::Stencil s{p, d, list, k};
  const std::size_t n = p.size();
  std::vector<double> phi(n), gx(n), gy(n), px(n), py(n);
  for (std::size_t i = 0; i < n; ++i) phi[i] = 3.0 * p.x[i] - 7.0 * p.y[i];
  mps::gradient(s, phi, gx, gy, mps::GradientVariant::corrected);
  mps::gradient(s, phi, px, py, mps::GradientVariant::plain);
  int top_row = 0;
  for (std::size_t i = 0; i < n; ++i) {
    if (p.x[i] < 0.3 || p.x[i] > 1.7 || p.y[i] < 0.9) continue;  // the top row, away from the side edges
    EXPECT_NEAR(gx[i], 3.0, 1e-10);
    EXPECT_NEAR(gy[i], -7.0, 1e-10);
    EXPECT_GT(std::abs(py[i] + 7.0), 1.0);  // the plain gradient is off there by a lot
    ++top_row;
  }
  EXPECT_GT(top_row, 10);
}
}  // namespace

namespace {

// The Lattice's particles displaced by up to +-amplitude l0 in each direction (fixed seed).
void perturb(Lattice& L, double amplitude) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> jitter(-amplitude * L.l0, amplitude * L.l0);
  for (std::size_t i = 0; i < L.p.size(); ++i) {
    L.p.x[i] += jitter(rng);
    L.p.y[i] += jitter(rng);
  }
}

// Spread (standard deviation over mean) of the 2.1 l0 number density over the particles 4.2 l0 inside the block.
double density_spread(const Lattice& L) {
  const mps::Kernel k = mps::make_kernel(2.1, L.l0);
  const auto list = mps::find_neighbors(L.p, L.d, k.re);
  const std::vector<double> n = mps::number_density({L.p, L.d, list, k});
  double sum = 0.0, sum2 = 0.0;
  int count = 0;
  for (std::size_t i = 0; i < n.size(); ++i)
    if (L.interior(i, 4.2 * L.l0)) {
      sum += n[i];
      sum2 += n[i] * n[i];
      ++count;
    }
  const double mean = sum / count;
  return std::sqrt(sum2 / count - mean * mean) / mean;
}

// Moves the particles 2.1 l0 or more inside the block; the outer ones stay as its boundary.
double shift_interior(Lattice& L, double diffusion) {
  const mps::Kernel k = mps::make_kernel(2.1, L.l0);
  const auto list = mps::find_neighbors(L.p, L.d, k.re);
  std::vector<char> movable(L.p.size());
  for (std::size_t i = 0; i < movable.size(); ++i) movable[i] = L.interior(i, 2.1 * L.l0) ? 1 : 0;
  return mps::shift_particles({L.p, L.d, list, k}, diffusion, 0.2 * L.l0, movable, L.p);
}

}  // namespace

TEST(Shifting, LeavesAPerfectLatticeWhereItIs) {
  Lattice L;
  const std::vector<double> x = L.p.x, y = L.p.y;
  EXPECT_LT(shift_interior(L, 0.2 * L.l0 * L.l0), 1e-12 * L.l0);
  for (std::size_t i = 0; i < x.size(); ++i) {
    EXPECT_NEAR(L.p.x[i], x[i], 1e-12 * L.l0);
    EXPECT_NEAR(L.p.y[i], y[i], 1e-12 * L.l0);
  }
}

// What shifting is for: a disordered packing (here +-0.2 l0 of jitter) is drawn back towards an even one. Moved up
// the concentration gradient instead of down, the particles bunch further and the spread grows.
TEST(Shifting, EvensOutADisorderedLattice) {
  Lattice L;
  perturb(L, 0.2);
  const double before = density_spread(L);
  for (int step = 0; step < 10; ++step) shift_interior(L, 0.2 * L.l0 * L.l0);
  const double after = density_spread(L);
  EXPECT_GT(before, 0.02);
  EXPECT_LT(after, 0.3 * before) << "number density spread " << before << " -> " << after;
}

// The Taylor term carries the velocity along with the particle: a linear field is still the same linear field at
// the shifted positions, to round-off, on a disordered packing too. Without it every moved particle would keep its
// old velocity and the error would be grad u . dr.
TEST(Shifting, CarriesALinearVelocityFieldExactly) {
  Lattice L;
  perturb(L, 0.2);
  auto field_u = [](double x, double y) { return 0.7 + 1.3 * x - 0.4 * y; };
  auto field_v = [](double x, double y) { return -0.2 + 0.5 * x + 2.1 * y; };
  for (std::size_t i = 0; i < L.p.size(); ++i) {
    L.p.u[i] = field_u(L.p.x[i], L.p.y[i]);
    L.p.v[i] = field_v(L.p.x[i], L.p.y[i]);
  }
  const std::vector<double> x = L.p.x;
  const double largest = shift_interior(L, 0.2 * L.l0 * L.l0);
  EXPECT_GT(largest, 0.02 * L.l0);
  int moved = 0;
  for (std::size_t i = 0; i < L.p.size(); ++i) {
    EXPECT_NEAR(L.p.u[i], field_u(L.p.x[i], L.p.y[i]), 1e-12);
    EXPECT_NEAR(L.p.v[i], field_v(L.p.x[i], L.p.y[i]), 1e-12);
    moved += L.p.x[i] != x[i] ? 1 : 0;
    if (!L.interior(i, 2.1 * L.l0)) {
      EXPECT_EQ(L.p.x[i], x[i]) << "a particle not movable moved";
    }
  }
  EXPECT_GT(moved, 1000);
}

TEST(Shifting, RejectsNegativeCoefficients) {
  Lattice L;
  const mps::Kernel k = mps::make_kernel(2.1, L.l0);
  const auto list = mps::find_neighbors(L.p, L.d, k.re);
  std::vector<char> movable(L.p.size(), 1);
  EXPECT_THROW(mps::shift_particles({L.p, L.d, list, k}, -1.0, 0.2 * L.l0, movable, L.p), std::invalid_argument);
}

namespace {

struct Pair {
  mps::Particles p;
  mps::Domain d{-1, 1, -1, 1};
  std::vector<char> movable;
  mps::Particles after() {  // movable: all, unless set
    if (movable.empty()) movable.assign(p.size(), 1);
    const auto list = mps::find_neighbors(p, d, 0.5);
    std::vector<double> du, dv;
    mps::collision_velocity_changes(p, d, list, 0.1, 0.2, movable, du, dv);
    mps::Particles out = p;
    for (std::size_t i = 0; i < p.size(); ++i) {
      out.u[i] += du[i];
      out.v[i] += dv[i];
    }
    return out;
  }
};

TEST(Collisions, ApproachingFluidPairKeepsItsMomentumAndTurnsBackWithTheRestitution) {
  Pair s;
  s.p.add(0.0, 0.0, mps::Kind::fluid, 0, 1.0, 0.5);
  s.p.add(0.05, 0.0, mps::Kind::fluid, 0, -1.0, 0.5);
  const mps::Particles out = s.after();
  EXPECT_NEAR(out.u[0], -0.2, 1e-15);  // approach speed 2 -> separation 0.2 * 2, shared
  EXPECT_NEAR(out.u[1], 0.2, 1e-15);
  EXPECT_DOUBLE_EQ(out.u[0] + out.u[1], 0.0);
  EXPECT_DOUBLE_EQ(out.v[0], 0.5);  // the tangential velocity is untouched
}

// A fluid particle that may not move (an inflow's prescribed particle) is fixed like a wall: the other one takes all of
// the impulse and turns back with the restitution alone.
TEST(Collisions, AnUnmovableFluidParticleIsFixedLikeAWall) {
  Pair s;
  s.p.add(0.0, 0.0, mps::Kind::fluid, 0, 1.0, 0.5);
  s.p.add(0.05, 0.0, mps::Kind::fluid, 0, -1.0, 0.5);
  s.movable = {1, 0};
  const mps::Particles out = s.after();
  EXPECT_NEAR(out.u[0], 1.0 - 1.2 * 2.0, 1e-15);  // approach speed 2 -> separation 0.2 * 2 from the fixed one
  EXPECT_EQ(out.u[1], -1.0);
  EXPECT_EQ(out.v[0], 0.5);
}

TEST(Collisions, SeparatingOrDistantPairsAndDummiesAreLeftAlone) {
  Pair s;
  s.p.add(0.0, 0.0, mps::Kind::fluid, 0, -1.0, 0.0);
  s.p.add(0.05, 0.0, mps::Kind::fluid, 0, 1.0, 0.0);  // moving apart
  s.p.add(0.5, 0.0, mps::Kind::fluid, 0, 1.0, 0.0);
  s.p.add(0.7, 0.0, mps::Kind::fluid, 0, -1.0, 0.0);  // closing in, but 0.2 apart
  const mps::Particles out = s.after();
  for (std::size_t i = 0; i < 4; ++i) EXPECT_EQ(out.u[i], s.p.u[i]);
}

TEST(Collisions, AFluidParticleTurnsBackFromAWallAloneAndTheOrderDoesNotMatter) {
  Pair s;
  s.p.add(0.0, 0.0, mps::Kind::wall);
  s.p.add(0.0, 0.06, mps::Kind::fluid, 0, 0.3, -2.0);
  s.p.add(0.085, 0.06, mps::Kind::fluid, 0, -1.0, 0.0);  // 0.104 from the wall: out of its reach
  const mps::Particles out = s.after();
  EXPECT_EQ(out.v[0], 0.0);  // the wall does not move
  // Particle 1 meets the wall head-on (-2 -> +0.4) and particle 2 sideways (its x-approach 1.3 shared).
  EXPECT_NEAR(out.v[1], 0.4, 1e-14);
  EXPECT_NEAR(out.u[1], 0.3 - 0.5 * 1.2 * 1.3, 1e-14);
  Pair reversed;
  for (std::size_t i = 3; i-- > 0;) reversed.p.add(s.p.x[i], s.p.y[i], s.p.kind[i], 0, s.p.u[i], s.p.v[i]);
  const mps::Particles back = reversed.after();
  for (std::size_t i = 0; i < 3; ++i) {
    EXPECT_EQ(back.u[2 - i], out.u[i]);
    EXPECT_EQ(back.v[2 - i], out.v[i]);
  }
}

// The dynamic stabilisation's changes with reach 0.1 and dt 0.01 (movable: all, unless set), applied as the corrector
// does: to the velocity and, times dt, to the position.
mps::Particles stabilised(Pair& s) {
  if (s.movable.empty()) s.movable.assign(s.p.size(), 1);
  const auto list = mps::find_neighbors(s.p, s.d, 0.5);
  std::array<std::vector<double>, 2> change;
  mps::stabilisation_velocity_changes<2>(s.p, s.d, list, 0.1, 0.01, s.movable, change);
  mps::Particles out = s.p;
  for (std::size_t i = 0; i < s.p.size(); ++i) {
    out.u[i] += change[0][i];
    out.v[i] += change[1][i];
    out.x[i] += 0.01 * change[0][i];
    out.y[i] += 0.01 * change[1][i];
  }
  return out;
}

// A pair nearer than the reach is put back at the reach by the corrector's move, whether closing in, parting or at
// rest; the two changes are equal and opposite (momentum), along the line between them.
TEST(Stabilisation, AClosePairIsPutBackAtTheReachWithItsMomentumKept) {
  for (const double closing : {1.0, 0.0, -1.0}) {
    Pair s;
    s.p.add(0.0, 0.0, mps::Kind::fluid, 0, 0.5 * closing, 0.3);
    s.p.add(0.036, 0.048, mps::Kind::fluid, 0, -0.5 * closing, 0.3);  // 0.06 apart along (0.6, 0.8)
    const mps::Particles out = stabilised(s);
    EXPECT_NEAR(std::hypot(out.x[1] - out.x[0], out.y[1] - out.y[0]), 0.1, 1e-15) << closing;
    EXPECT_NEAR(out.u[0] - s.p.u[0], -0.5 * 4.0 * 0.6, 1e-13);  // (0.1 - 0.06)/0.01 = 4, shared
    EXPECT_NEAR(out.v[0] - s.p.v[0], -0.5 * 4.0 * 0.8, 1e-13);
    EXPECT_DOUBLE_EQ(out.u[0] + out.u[1], s.p.u[0] + s.p.u[1]);
    EXPECT_DOUBLE_EQ(out.v[0] + out.v[1], s.p.v[0] + s.p.v[1]);
  }
}

// A wall does not give way, nor does a fluid particle that may not move: the movable one takes the whole change. Pairs
// beyond the reach, and ghosts, are left alone, so a lattice at the spacing is untouched.
TEST(Stabilisation, AWallOrUnmovableParticleIsFixedAndPairsBeyondTheReachAreLeftAlone) {
  Pair s;
  s.p.add(0.0, 0.0, mps::Kind::wall);
  s.p.add(0.0, 0.07, mps::Kind::fluid, 0, 0.0, -1.0);
  s.p.add(0.5, 0.0, mps::Kind::fluid);
  s.p.add(0.55, 0.0, mps::Kind::fluid);  // 0.05 from an unmovable one
  s.p.add(-0.5, 0.0, mps::Kind::fluid);
  s.p.add(-0.39, 0.0, mps::Kind::fluid);  // beyond the reach
  s.p.add(-0.45, 0.0, mps::Kind::ghost);
  s.movable = {1, 1, 0, 1, 1, 1, 1};
  const mps::Particles out = stabilised(s);
  EXPECT_EQ(out.v[0], 0.0);
  EXPECT_NEAR(out.y[1], 0.1, 1e-15);  // put back at the reach from the wall, alone
  EXPECT_NEAR(out.v[1], -1.0 + 3.0, 1e-13);
  EXPECT_EQ(out.u[2], 0.0);
  EXPECT_NEAR(out.x[3], 0.6, 1e-15);
  for (std::size_t i = 4; i < 7; ++i) EXPECT_EQ(out.u[i], 0.0) << i;
}

}  // namespace

// The normal of a free surface: straight out of a block's sides, along the diagonal at its corners, none inside.
TEST(Shifting, SurfaceNormalsPointOutOfABlock) {
  Lattice L;
  const mps::Kernel k = mps::make_kernel(4.1, L.l0);
  const auto list = mps::find_neighbors(L.p, L.d, k.re);
  std::vector<char> want(L.p.size(), 1);
  std::vector<double> nx, ny;
  mps::surface_normals({L.p, L.d, list, k}, want, nx, ny);
  int top = 0, left = 0, inside = 0;
  for (std::size_t i = 0; i < L.p.size(); ++i) {
    const double x = L.p.x[i], y = L.p.y[i];
    if (y > 4 - L.l0 && x > 4.5 * L.l0 && x < 4 - 4.5 * L.l0) {
      EXPECT_NEAR(nx[i], 0.0, 1e-12);
      EXPECT_NEAR(ny[i], 1.0, 1e-12);
      ++top;
    } else if (x < L.l0 && y > 4.5 * L.l0 && y < 4 - 4.5 * L.l0) {
      EXPECT_NEAR(nx[i], -1.0, 1e-12);
      EXPECT_NEAR(ny[i], 0.0, 1e-12);
      ++left;
    } else if (L.interior(i, 4.2 * L.l0)) {
      EXPECT_EQ(nx[i], 0.0);
      EXPECT_EQ(ny[i], 0.0);
      ++inside;
    } else if (x > 4 - L.l0 && y < L.l0) {  // the lower right corner
      EXPECT_NEAR(nx[i], std::sqrt(0.5), 1e-12);
      EXPECT_NEAR(ny[i], -std::sqrt(0.5), 1e-12);
    }
  }
  EXPECT_GE(top, 30);
  EXPECT_GE(left, 30);
  EXPECT_GT(inside, 900);
}

// Near a free surface the shift keeps only its part along the surface: each outer particle moves at right angles to
// its normal, the inner ones exactly as without normals, and along the top row the gaps even out. The normal comes from
// the wider kernel: at the shift's own radius it would point along the shift and leave nothing to move.
TEST(Shifting, AlongAFreeSurfaceOnly) {
  Lattice L;
  perturb(L, 0.2);
  const mps::Kernel k = mps::make_kernel(2.1, L.l0), wide = mps::make_kernel(4.1, L.l0);
  std::vector<std::size_t> top_row;
  for (std::size_t i = 0; i < L.p.size(); ++i)
    if (L.p.y[i] > 4 - 1.3 * L.l0 && L.p.x[i] > 2 * L.l0 && L.p.x[i] < 4 - 2 * L.l0) top_row.push_back(i);
  auto gap_spread = [&] {
    std::vector<double> x;
    for (std::size_t i : top_row) x.push_back(L.p.x[i]);
    std::sort(x.begin(), x.end());
    double sum = 0.0, sum2 = 0.0;
    for (std::size_t m = 1; m < x.size(); ++m) {
      sum += x[m] - x[m - 1];
      sum2 += (x[m] - x[m - 1]) * (x[m] - x[m - 1]);
    }
    const double count = static_cast<double>(x.size() - 1), mean = sum / count;
    return std::sqrt(sum2 / count - mean * mean) / mean;
  };
  const double spread_before = gap_spread();
  std::vector<char> movable(L.p.size(), 1), near_surface(L.p.size());
  for (std::size_t i = 0; i < L.p.size(); ++i) near_surface[i] = L.interior(i, 2.1 * L.l0) ? 0 : 1;
  for (int step = 0; step < 10; ++step) {
    const auto list = mps::find_neighbors(L.p, L.d, k.re);
    std::vector<double> nx, ny;
    const auto wide_list = mps::find_neighbors(L.p, L.d, wide.re);
    mps::surface_normals({L.p, L.d, wide_list, wide}, near_surface, nx, ny);
    Lattice plain = L;  // the same packing shifted without normals
    const auto plain_list = mps::find_neighbors(plain.p, plain.d, k.re);
    mps::shift_particles({plain.p, plain.d, plain_list, k}, 0.2 * L.l0 * L.l0, 0.2 * L.l0, movable, plain.p);
    const std::vector<double> x = L.p.x, y = L.p.y;
    mps::shift_particles({L.p, L.d, list, k}, 0.2 * L.l0 * L.l0, 0.2 * L.l0, movable, L.p, nx, ny);
    int along = 0;
    for (std::size_t i = 0; i < L.p.size(); ++i) {
      const double dx = L.p.x[i] - x[i], dy = L.p.y[i] - y[i];
      if (nx[i] != 0.0 || ny[i] != 0.0) {
        EXPECT_NEAR(dx * nx[i] + dy * ny[i], 0.0, 1e-12 * L.l0) << "a surface particle moved off the surface";
        along += std::hypot(dx, dy) > 1e-4 * L.l0;
      } else {
        EXPECT_EQ(L.p.x[i], plain.p.x[i]);
        EXPECT_EQ(L.p.y[i], plain.p.y[i]);
      }
    }
    EXPECT_GT(along, 100) << "step " << step;
  }
  const double spread_after = gap_spread();
  EXPECT_GT(spread_before, 0.1);
  EXPECT_LT(spread_after, 0.6 * spread_before) << "top row gaps' spread " << spread_before << " -> " << spread_after;
}
