#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <random>
#include <string>
#include <tuple>

#include "mps/boundaries/geometry.hpp"
#include "mps/numerics/ppe.hpp"

namespace {

// A PPE from a real particle arrangement: fluid in a walled box (open top unless `closed`), positions jittered
// so that no lattice symmetry hides an asymmetry in the assembly.
struct Box {
  double l0 = 0.05;
  mps::Particles p;
  mps::Domain d{-0.5, 1.5, -0.5, 1.5};
  mps::Kernel lap = mps::make_kernel(4.1, 0.05), small = mps::make_kernel(2.1, 0.05);
  mps::NeighborList near, close;
  std::vector<double> n;
  std::vector<char> surface;
  std::vector<double> source;

  explicit Box(bool closed) {
    mps::fill_rectangle(p, {0, 0, 1, closed ? 1.0 : 0.8}, l0, mps::Kind::fluid);
    mps::add_rectangle_walls(p, {0, 0, 1, 1}, l0,
                             closed ? (mps::left | mps::right | mps::bottom | mps::top) : (mps::left | mps::right | mps::bottom),
                             1, 4);
    std::mt19937 rng(11);
    std::uniform_real_distribution<double> jitter(-0.05 * l0, 0.05 * l0);
    for (std::size_t i = 0; i < p.size(); ++i)
      if (p.kind[i] == mps::Kind::fluid) {
        p.x[i] += jitter(rng);
        p.y[i] += jitter(rng);
      }
    near = mps::find_neighbors(p, d, lap.re);
    close = mps::find_neighbors(p, d, small.re);
    n = mps::number_density({p, d, close, small});
    surface = mps::detect_free_surface(p, n, small.n0, 0.97, &close, small.lattice_neighbors, 0.85);
    source.resize(p.size());
    for (std::size_t i = 0; i < p.size(); ++i) source[i] = std::sin(3 * p.x[i]) + p.y[i];
  }
  mps::PpeSystem assemble() const { return mps::assemble_ppe({p, d, near, lap}, surface, source); }
};

Eigen::MatrixXd dense(const mps::CsrMatrix& a) {
  Eigen::MatrixXd m = Eigen::MatrixXd::Zero(a.rows, a.cols);
  for (int i = 0; i < a.rows; ++i)
    for (int k = a.row_ptr[static_cast<std::size_t>(i)]; k < a.row_ptr[static_cast<std::size_t>(i) + 1]; ++k)
      m(i, a.col[static_cast<std::size_t>(k)]) = a.val[static_cast<std::size_t>(k)];
  return m;
}

TEST(Ppe, FreeSurfaceTankMatrixIsSymmetricPositiveDefiniteWithZeroRowSumsAwayFromTheSurface) {
  const Box box(false);
  const mps::PpeSystem sys = box.assemble();
  sys.matrix.validate();
  ASSERT_GT(sys.size(), 300u);
  EXPECT_TRUE(sys.floating.empty());  // the free surface anchors the pressure level
  EXPECT_TRUE(sys.matrix.is_symmetric(1e-14));
  // Rows whose Laplacian stencil holds no free-surface particle sum to zero (a Neumann interior).
  int interior_rows = 0;
  for (std::size_t r = 0; r < sys.size(); ++r) {
    const auto i = static_cast<std::size_t>(sys.particle[r]);
    bool touches_surface = false;
    for (int j : box.near.of(i)) touches_surface = touches_surface || box.surface[static_cast<std::size_t>(j)];
    if (touches_surface) continue;
    double sum = 0.0, scale = 0.0;
    for (int k = sys.matrix.row_ptr[r]; k < sys.matrix.row_ptr[r + 1]; ++k) {
      sum += sys.matrix.val[static_cast<std::size_t>(k)];
      scale = std::max(scale, std::abs(sys.matrix.val[static_cast<std::size_t>(k)]));
    }
    EXPECT_NEAR(sum, 0.0, 1e-12 * scale);
    ++interior_rows;
  }
  EXPECT_GT(interior_rows, 100);
  // A = -(discrete Laplacian) is positive definite, i.e. the Laplacian block is negative definite.
  const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig(dense(sys.matrix));
  EXPECT_GT(eig.eigenvalues().minCoeff(), 1e-8 * eig.eigenvalues().maxCoeff());
}

// The PPE's coefficients against the exact Laplacian. On a perfect lattice the MPS Laplacian of a quadratic
// phi = a + g.r + r^T H r / 2 is exact: the odd moment sum w r_ij cancels by symmetry, sum w x^2 = sum w y^2 =
// lambda n0 / 2 (lambda's definition, sum w r^2 = lambda n0) and sum w x y = 0, so (2d/(lambda n0)) sum w (phi_j -
// phi_i) = tr H. The matrix is A = -lap over the unknowns (ppe.hpp), so (A phi)_r = -tr H on a row whose kernel holds
// unknowns only; a row that reaches Dirichlet particles (held at phi, source 0) has the rest in b:
// (A phi - b)_r = -tr H. A band wider than re around the lattice is Dirichlet, so every unknown's kernel lies on it.
class PpeOnLattice : public ::testing::TestWithParam<std::tuple<mps::Weight, double>> {};

TEST_P(PpeOnLattice, MatrixTimesAQuadraticIsMinusItsExactLaplacian) {
  const auto [weight, radius] = GetParam();
  const double l0 = 0.1, side = 4.0;
  mps::Particles p;
  mps::fill_rectangle(p, {0, 0, side, side}, l0, mps::Kind::fluid);  // 40 x 40, particles at (k + 1/2) l0
  const mps::Domain d{-1, side + 1, -1, side + 1};
  const mps::Kernel k = mps::make_kernel(radius, l0, weight);
  const mps::NeighborList list = mps::find_neighbors(p, d, k.re);
  const double band = k.re + l0;
  const std::size_t n = p.size();
  std::vector<char> surface(n);
  std::vector<double> phi(n);
  const std::vector<double> source(n, 0.0);
  const double trace = 6.0 + 4.0;  // tr H of 3x^2 - xy + 2y^2
  for (std::size_t i = 0; i < n; ++i) {
    const double x = p.x[i], y = p.y[i];
    surface[i] = x < band || x > side - band || y < band || y > side - band;
    phi[i] = 3 * x * x - x * y + 2 * y * y + x - 0.5 * y + 1.0;
  }
  const mps::PpeSystem sys = mps::assemble_ppe({p, d, list, k}, surface, source, phi);
  ASSERT_TRUE(sys.floating.empty());
  std::vector<double> x(sys.size()), ax(sys.size());
  for (std::size_t r = 0; r < sys.size(); ++r) x[r] = phi[static_cast<std::size_t>(sys.particle[r])];
  sys.matrix.multiply(x, ax);
  int interior = 0, reaching = 0;
  for (std::size_t r = 0; r < sys.size(); ++r) {
    const auto i = static_cast<std::size_t>(sys.particle[r]);
    bool unknowns_only = true;
    for (int j : list.of(i)) unknowns_only = unknowns_only && sys.unknown[static_cast<std::size_t>(j)] >= 0;
    if (unknowns_only) {
      EXPECT_NEAR(ax[r], -trace, 1e-9 * trace) << "interior row at (" << p.x[i] << ", " << p.y[i] << ")";
      ++interior;
    } else {
      ++reaching;
    }
    EXPECT_NEAR(ax[r] - sys.rhs[r], -trace, 1e-9 * trace) << "row at (" << p.x[i] << ", " << p.y[i] << ")";
  }
  EXPECT_GE(interior, 100);
  EXPECT_GE(reaching, 100);
}

INSTANTIATE_TEST_SUITE_P(
    BothWeightsTwoRadii, PpeOnLattice,
    ::testing::Combine(::testing::Values(mps::Weight::bounded, mps::Weight::classic), ::testing::Values(3.1, 4.1)),
    [](const ::testing::TestParamInfo<std::tuple<mps::Weight, double>>& param_info) {
      return std::string(mps::to_string(std::get<0>(param_info.param))) + "_re" +
             (std::get<1>(param_info.param) < 4.0 ? "3_1" : "4_1");
    });

TEST(Ppe, UnknownsAreExactlyTheWetFluidAndWallParticles) {
  const Box box(false);
  const mps::PpeSystem sys = box.assemble();
  for (std::size_t i = 0; i < box.p.size(); ++i) {
    const bool should = (box.p.kind[i] == mps::Kind::fluid || box.p.kind[i] == mps::Kind::wall) && !box.surface[i];
    // (a candidate with no fluid/wall neighbour at all would be left out; this box has none)
    EXPECT_EQ(sys.unknown[i] >= 0, should) << "particle " << i << " kind " << mps::to_string(box.p.kind[i]);
  }
  for (std::size_t r = 0; r < sys.size(); ++r) EXPECT_EQ(sys.unknown[static_cast<std::size_t>(sys.particle[r])], static_cast<int>(r));
}

// Every fluid and wall particle a row: the solved rows are the unknowns' system exactly (same entries, in the same
// order), and each held row stands alone, its solution the particle's Dirichlet value; scatter leaves held particles
// at 0 as it leaves particles without a row, and gather starts held rows at their value.
TEST(Ppe, EveryParticleRowsHoldTheUnknownsSystemAndStandAloneRowsForTheRest) {
  const Box box(false);
  std::vector<double> dirichlet(box.p.size());
  for (std::size_t i = 0; i < dirichlet.size(); ++i) dirichlet[i] = 0.01 * box.p.y[i] - 0.002;
  const mps::Stencil s{box.p, box.d, box.near, box.lap};
  const mps::PpeSystem ref = mps::assemble_ppe(s, box.surface, box.source, dirichlet);
  const mps::PpeSystem sys = mps::assemble_ppe(s, box.surface, box.source, dirichlet, 0.0, mps::ClosedGroups::gauge,
                                               {}, mps::PpeRows::every_particle);
  sys.matrix.validate();
  EXPECT_TRUE(sys.matrix.is_symmetric(0.0));
  std::size_t in_sum = 0;
  for (std::size_t i = 0; i < box.p.size(); ++i) {
    const bool fluid_or_wall = box.p.kind[i] == mps::Kind::fluid || box.p.kind[i] == mps::Kind::wall;
    in_sum += fluid_or_wall ? 1 : 0;
    EXPECT_EQ(sys.unknown[i] >= 0, fluid_or_wall) << "particle " << i;
  }
  ASSERT_EQ(sys.size(), in_sum);
  ASSERT_GT(sys.held_rows, 20u);  // the surface and the dry walls above it
  EXPECT_EQ(sys.solved_rows(), ref.size());
  EXPECT_TRUE(sys.floating.empty());
  // The solved rows, mapped to the reference's numbering, carry the same entries and right-hand side.
  for (std::size_t r = 0; r < sys.size(); ++r) {
    const auto i = static_cast<std::size_t>(sys.particle[r]);
    const int k0 = sys.matrix.row_ptr[r], k1 = sys.matrix.row_ptr[r + 1];
    if (sys.held[r]) {
      ASSERT_EQ(k1 - k0, 1) << "held row " << r;
      EXPECT_EQ(sys.matrix.col[static_cast<std::size_t>(k0)], static_cast<int>(r));
      const double diagonal = sys.matrix.val[static_cast<std::size_t>(k0)];
      EXPECT_GT(diagonal, 0.0);
      EXPECT_DOUBLE_EQ(sys.rhs[r] / diagonal, dirichlet[i]);
      EXPECT_EQ(ref.unknown[i], -1);
      continue;
    }
    const auto rr = static_cast<std::size_t>(ref.unknown[i]);
    ASSERT_EQ(k1 - k0, ref.matrix.row_ptr[rr + 1] - ref.matrix.row_ptr[rr]) << "row of particle " << i;
    auto particle_of_entry = [](const mps::PpeSystem& system, int k) {
      return system.particle[static_cast<std::size_t>(system.matrix.col[static_cast<std::size_t>(k)])];
    };
    for (int k = k0, kr = ref.matrix.row_ptr[rr]; k < k1; ++k, ++kr) {
      EXPECT_EQ(particle_of_entry(sys, k), particle_of_entry(ref, kr));
      EXPECT_EQ(sys.matrix.val[static_cast<std::size_t>(k)], ref.matrix.val[static_cast<std::size_t>(kr)]);
    }
    EXPECT_EQ(sys.rhs[r], ref.rhs[rr]);
  }
  // gather starts a held row at its value; scatter writes the solved rows only.
  mps::Particles q = box.p;
  for (double& v : q.p) v = 7.0;
  const std::vector<double> x = sys.gather(q);
  std::vector<double> solution(sys.size());
  for (std::size_t r = 0; r < sys.size(); ++r) {
    if (sys.held[r]) EXPECT_DOUBLE_EQ(x[r], dirichlet[static_cast<std::size_t>(sys.particle[r])]);
    else EXPECT_EQ(x[r], 7.0);
    solution[r] = 1.0 + static_cast<double>(r);
  }
  sys.scatter(solution, q);
  for (std::size_t r = 0; r < sys.size(); ++r)
    EXPECT_EQ(q.p[static_cast<std::size_t>(sys.particle[r])], sys.held[r] ? 0.0 : solution[r]);
}

TEST(Ppe, ClosedBoxGetsTheZeroMeanGaugeAndSolvesTheConsistentSingularSystem) {
  const Box box(true);
  const mps::PpeSystem sys = box.assemble();
  ASSERT_EQ(sys.floating.size(), 1u);
  EXPECT_EQ(sys.floating[0].size, static_cast<int>(sys.size()));
  EXPECT_TRUE(sys.matrix.is_symmetric(1e-14));
  // The right-hand side was projected onto the range of the singular operator (zero mean).
  double mean_b = 0.0;
  for (double b : sys.rhs) mean_b += b;
  EXPECT_NEAR(mean_b / static_cast<double>(sys.size()), 0.0, 1e-12);
  EXPECT_GT(std::abs(sys.floating[0].removed_rhs_mean), 1e-3);  // the raw source was inconsistent

  const Eigen::MatrixXd a = dense(sys.matrix);
  const Eigen::VectorXd b = Eigen::Map<const Eigen::VectorXd>(sys.rhs.data(), static_cast<Eigen::Index>(sys.size()));
  const Eigen::VectorXd x = a.llt().solve(b);  // the pinned matrix is SPD: Cholesky succeeds
  mps::Particles p = box.p;
  sys.scatter(std::span<const double>(x.data(), static_cast<std::size_t>(x.size())), p);
  // Level: zero mean over the unknowns. Equation: the unpinned singular operator L0 (A with the pinned
  // diagonal halved back) satisfies L0 P = b for the scattered pressure.
  Eigen::MatrixXd l0 = a;
  l0(sys.floating[0].pinned, sys.floating[0].pinned) /= 2.0;
  Eigen::VectorXd pressure(static_cast<Eigen::Index>(sys.size()));
  double mean = 0.0;
  for (std::size_t r = 0; r < sys.size(); ++r) {
    pressure(static_cast<Eigen::Index>(r)) = p.p[static_cast<std::size_t>(sys.particle[r])];
    mean += pressure(static_cast<Eigen::Index>(r));
  }
  EXPECT_NEAR(mean / static_cast<double>(sys.size()), 0.0, 1e-10);
  EXPECT_LT((l0 * pressure - b).norm(), 1e-9 * b.norm());
}

// ClosedGroups::leave (for mps/parallel/distributed.hpp, which gauges a group spanning ranks itself): the same system as the
// gauged one but for the pinned diagonal and the removed mean; `anchored` marks exactly the rows with a free-surface
// neighbour in the tank and none in the sealed box.
TEST(Ppe, LeavingClosedGroupsUndoesOnlyTheGaugeAndAnchoredMarksTheSurfaceRows) {
  const Box closed(true);
  const mps::PpeSystem gauged = closed.assemble();
  const mps::PpeSystem left =
      mps::assemble_ppe({closed.p, closed.d, closed.near, closed.lap}, closed.surface, closed.source, {}, 0.0,
                        mps::ClosedGroups::leave);
  ASSERT_EQ(gauged.floating.size(), 1u);
  EXPECT_TRUE(left.floating.empty());
  EXPECT_TRUE(std::all_of(left.group.begin(), left.group.end(), [](int g) { return g == -1; }));
  EXPECT_TRUE(std::all_of(left.anchored.begin(), left.anchored.end(), [](char a) { return a == 0; }));
  ASSERT_EQ(left.matrix.col, gauged.matrix.col);
  const int pin = gauged.floating[0].pinned;
  for (int r = 0; r < left.matrix.rows; ++r)
    for (int k = left.matrix.row_ptr[static_cast<std::size_t>(r)]; k < left.matrix.row_ptr[static_cast<std::size_t>(r) + 1]; ++k) {
      const auto kk = static_cast<std::size_t>(k);
      const double factor = r == pin && left.matrix.col[kk] == pin ? 2.0 : 1.0;
      EXPECT_EQ(factor * left.matrix.val[kk], gauged.matrix.val[kk]);
    }
  for (std::size_t r = 0; r < left.size(); ++r)
    EXPECT_NEAR(left.rhs[r] - gauged.floating[0].removed_rhs_mean, gauged.rhs[r], 1e-12 * std::abs(left.rhs[r]) + 1e-12);

  const Box open(false);
  const mps::PpeSystem tank = open.assemble();
  int anchored = 0;
  for (std::size_t r = 0; r < tank.size(); ++r) {
    const auto i = static_cast<std::size_t>(tank.particle[r]);
    bool surface_neighbour = false;
    for (int j : open.near.of(i))
      surface_neighbour = surface_neighbour || (open.surface[static_cast<std::size_t>(j)] &&
                                                open.p.kind[static_cast<std::size_t>(j)] == mps::Kind::fluid);
    EXPECT_EQ(tank.anchored[r] != 0, surface_neighbour) << "unknown " << r;
    anchored += tank.anchored[r];
  }
  EXPECT_GT(anchored, 20);
}

// The compressibility term: A = -lap + shift I. A uniform density error in a closed box, which
// the incompressible PPE can only answer with a gauge (its mean is removed), now gets the uniform pressure
// -source/shift of a compressible liquid, and the matrix needs no pinning.
TEST(Ppe, CompressibilityShiftsTheDiagonalAndGivesAUniformErrorAUniformPressure) {
  Box box(true);
  const mps::PpeSystem plain = box.assemble();
  std::fill(box.source.begin(), box.source.end(), -3.0);
  const double shift = 40.0;
  const mps::PpeSystem sys = mps::assemble_ppe({box.p, box.d, box.near, box.lap}, box.surface, box.source, {}, shift);
  EXPECT_TRUE(sys.floating.empty());
  ASSERT_EQ(sys.size(), plain.size());
  ASSERT_EQ(sys.matrix.col, plain.matrix.col);
  for (std::size_t r = 0; r < sys.size(); ++r)
    for (int k = sys.matrix.row_ptr[r]; k < sys.matrix.row_ptr[r + 1]; ++k) {
      const auto kk = static_cast<std::size_t>(k);
      const bool diag = sys.matrix.col[kk] == static_cast<int>(r);
      // the unshifted assembly doubled one diagonal entry for its gauge
      const double unpinned = plain.matrix.val[kk] / (diag && static_cast<int>(r) == plain.floating[0].pinned ? 2.0 : 1.0);
      EXPECT_NEAR(sys.matrix.val[kk], unpinned + (diag ? shift : 0.0), 1e-9 * std::abs(unpinned)) << r;
    }
  const Eigen::MatrixXd a = dense(sys.matrix);
  const Eigen::VectorXd b = Eigen::Map<const Eigen::VectorXd>(sys.rhs.data(), static_cast<Eigen::Index>(sys.size()));
  const Eigen::VectorXd x = a.llt().solve(b);
  for (Eigen::Index r = 0; r < x.size(); ++r) EXPECT_NEAR(x(r), 3.0 / shift, 1e-9) << r;
  EXPECT_THROW(mps::assemble_ppe({box.p, box.d, box.near, box.lap}, box.surface, box.source, {}, -1.0),
               std::invalid_argument);
}

TEST(Ppe, MixedSourceBlendsDivergenceAndDensityError) {
  const std::vector<double> n{10.0, 10.5, 9.0}, div{0.0, 2.0, -1.0};
  const double rho = 1000, dt = 0.01, n0 = 10.0;
  const auto s0 = mps::mixed_source(n, n0, div, rho, dt, 0.0);
  const auto s1 = mps::mixed_source(n, n0, div, rho, dt, 1.0);
  const auto sh = mps::mixed_source(n, n0, div, rho, dt, 0.25);
  for (std::size_t i = 0; i < n.size(); ++i) {
    EXPECT_DOUBLE_EQ(s0[i], rho / dt * div[i]);
    EXPECT_DOUBLE_EQ(s1[i], -rho / (dt * dt) * (n[i] - n0) / n0);
    EXPECT_NEAR(sh[i], 0.75 * s0[i] + 0.25 * s1[i], 1e-9 * (std::abs(s0[i]) + std::abs(s1[i]) + 1));
  }
  EXPECT_THROW((void)mps::mixed_source(n, n0, div, rho, dt, 1.5), std::invalid_argument);
  EXPECT_THROW((void)mps::mixed_source(n, n0, div, rho, dt, -0.1), std::invalid_argument);
  EXPECT_THROW((void)mps::mixed_source(n, n0, div, rho, 0.0, 0.5), std::invalid_argument);
}

TEST(Ppe, DummiesTakeTheNearestWetWallPressureCarriedHydrostatically) {
  mps::Particles p;
  mps::fill_rectangle(p, {0, 0, 1, 1}, 0.1, mps::Kind::fluid);
  mps::add_rectangle_walls(p, {0, 0, 1, 1}, 0.1, mps::bottom, 1, 2);
  const mps::Domain d{-1, 2, -1, 2};
  const mps::Kernel k = mps::make_kernel(4.1, 0.1);
  const auto list = mps::find_neighbors(p, d, k.re);
  std::vector<char> surface(p.size(), 0);
  for (std::size_t i = 0; i < p.size(); ++i) p.p[i] = p.kind[i] == mps::Kind::wall ? 100.0 + p.x[i] : 0.0;
  const double rho = 1000, g = 9.81;
  const auto carriers = mps::set_dummy_pressure({p, d, list, k}, p, surface, rho, 0.0, -g);
  for (std::size_t i = 0; i < p.size(); ++i) {
    EXPECT_TRUE(carriers[i]) << i;
    if (p.kind[i] != mps::Kind::dummy) continue;
    const double below_wall = -0.05 - p.y[i];  // the wall row sits at y = -0.05, straight above
    EXPECT_NEAR(p.p[i], 100.0 + p.x[i] + rho * g * below_wall, 1e-9);
  }
  // The pairs are read from the walls' rows: a list without the dummies' rows (as the step searches) gives the same.
  std::vector<char> rows(p.size());
  for (std::size_t i = 0; i < p.size(); ++i) rows[i] = p.kind[i] != mps::Kind::dummy;
  mps::CellGrid grid(d, k.re);
  grid.bin(p);
  mps::NeighborList without_dummies;
  grid.neighbors(p, k.re, without_dummies, rows);
  mps::Particles q = p;
  for (std::size_t i = 0; i < q.size(); ++i)
    if (q.kind[i] == mps::Kind::dummy) q.p[i] = -1.0;  // every dummy's pressure is set again
  EXPECT_EQ(mps::set_dummy_pressure({q, d, without_dummies, k}, q, surface, rho, 0.0, -g), carriers);
  EXPECT_EQ(q.p, p.p);
  // A dry wall (flagged free surface) passes on no pressure: its dummies hold none.
  for (std::size_t i = 0; i < p.size(); ++i) surface[i] = p.kind[i] == mps::Kind::wall;
  const auto dry = mps::set_dummy_pressure({p, d, list, k}, p, surface, rho, 0.0, -g);
  for (std::size_t i = 0; i < p.size(); ++i)
    if (p.kind[i] != mps::Kind::fluid) {
      EXPECT_FALSE(dry[i]);
      if (p.kind[i] == mps::Kind::dummy) {
        EXPECT_EQ(p.p[i], 0.0);
      }
    }
}

}  // namespace
