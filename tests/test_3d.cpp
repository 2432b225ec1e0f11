// The dimension-generic core in 3-D: the cubic lattice's reference values against its own particles, the operators
// where they must be exact, the PPE's coefficients, and a tank of water at rest.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <memory>
#include <random>
#include <vector>

#include "hydrostatic_bound.hpp"
#include "mps/boundaries/boundary.hpp"
#include "mps/boundaries/geometry.hpp"
#include "mps/io/io.hpp"
#include "mps/numerics/operators.hpp"
#include "mps/numerics/ppe.hpp"
#include "mps/step/components.hpp"
#include "mps/step/step.hpp"
#include "channel.hpp"

namespace {

constexpr double kL0 = 0.1;

// A cube of n^3 lattice particles and its neighbour list at the kernel's radius.
struct Lattice {
  mps::Particles3 p;
  mps::Domain3 domain;
  mps::NeighborList near;
  mps::Kernel k;

  Lattice(int n, double radius, mps::Weight weight = mps::Weight::bounded)
      : domain{-1, n * kL0 + 1, -1, n * kL0 + 1, -1, n * kL0 + 1},
        k(mps::make_kernel(radius, kL0, weight, 3)) {
    mps::fill_box(p, {0, 0, 0, n * kL0, n * kL0, n * kL0}, kL0, mps::Kind::fluid);
    near = mps::find_neighbors(p, domain, k.re);
  }
  [[nodiscard]] mps::Stencil3 stencil() const { return {p, domain, near, k}; }
  // Particles whose whole kernel lies on the lattice.
  [[nodiscard]] bool interior(std::size_t i, double n) const {
    const double margin = k.re + 0.5 * kL0;
    for (double c : p.position(i))
      if (c < margin || c > n * kL0 - margin) return false;
    return true;
  }
};

}  // namespace

// n0, lambda and the neighbour count of make_kernel(..., 3) are those of an interior particle of a real cubic lattice,
// found by the grid search and summed by the operators (a second path to the same sums).
TEST(ThreeD, ReferenceValuesAreThoseOfAnInteriorParticleOfTheCubicLattice) {
  for (const double radius : {2.1, 3.1, 4.1})
    for (const mps::Weight weight : {mps::Weight::bounded, mps::Weight::classic}) {
      const int n = 12;
      const Lattice l(n, radius, weight);
      const std::vector<double> density = mps::number_density(l.stencil());
      int checked = 0;
      for (std::size_t i = 0; i < l.p.size(); ++i) {
        if (!l.interior(i, n)) continue;
        ++checked;
        double sum_wr2 = 0.0;
        for (int j : l.near.of(i)) {
          const double r = mps::norm<3>(l.domain.displacement(l.p.position(i), l.p.position(static_cast<std::size_t>(j))));
          sum_wr2 += l.k.w(r) * r * r;
        }
        ASSERT_NEAR(density[i], l.k.n0, 1e-12 * l.k.n0) << "radius " << radius;
        ASSERT_NEAR(sum_wr2 / density[i], l.k.lambda, 1e-12 * l.k.lambda) << "radius " << radius;
        ASSERT_EQ(static_cast<int>(l.near.of(i).size()), l.k.lattice_neighbors) << "radius " << radius;
      }
      EXPECT_GT(checked, 0) << "radius " << radius;
    }
}

// On a cubic lattice sum w r_a r_b / r^2 = (n0 / 3) delta_ab and odd moments cancel: the plain gradient (3/n0) sum
// (phi_j - phi_i) r_ij w / r^2 is exact for a linear field, and the corrected one for a quadratic, at interior
// particles; the Laplacian (6/(lambda n0)) sum (phi_j - phi_i) w is exact for a quadratic since sum w r^2 = lambda n0;
// the divergence of a linear velocity is its trace.
TEST(ThreeD, OperatorsAreExactOnTheCubicLatticeWhereTheyMustBe) {
  const int n = 12;
  const Lattice l(n, 3.1);
  const std::size_t size = l.p.size();
  std::vector<double> linear(size), quadratic(size), gx(size), gy(size), gz(size), lap(size), div(size);
  std::vector<double> u(size), v(size), w(size);
  for (std::size_t i = 0; i < size; ++i) {
    const auto [x, y, z] = l.p.position(i);
    linear[i] = 2.0 * x - 3.0 * y + 0.5 * z + 1.0;
    quadratic[i] = x * x + y * y + z * z + x * y - 2.0 * y * z + x;
    u[i] = 1.0 * x + 2.0 * y;
    v[i] = -0.5 * y + z;
    w[i] = 3.0 * x + 0.25 * z;
  }
  mps::gradient<3>(l.stencil(), linear, {gx, gy, gz});
  mps::laplacian<3>(l.stencil(), quadratic, lap);
  mps::divergence<3>(l.stencil(), {u, v, w}, div);
  std::vector<double> qx(size), qy(size), qz(size);
  mps::gradient<3>(l.stencil(), quadratic, {qx, qy, qz}, mps::GradientVariant::corrected);
  int checked = 0;
  for (std::size_t i = 0; i < size; ++i) {
    if (!l.interior(i, n)) continue;
    ++checked;
    const auto [x, y, z] = l.p.position(i);
    EXPECT_NEAR(gx[i], 2.0, 1e-12);
    EXPECT_NEAR(gy[i], -3.0, 1e-12);
    EXPECT_NEAR(gz[i], 0.5, 1e-12);
    EXPECT_NEAR(lap[i], 6.0, 1e-10);  // tr of the Hessian: 2 + 2 + 2
    EXPECT_NEAR(div[i], 1.0 - 0.5 + 0.25, 1e-12);
    EXPECT_NEAR(qx[i], 2.0 * x + y + 1.0, 1e-12);
    EXPECT_NEAR(qy[i], 2.0 * y + x - 2.0 * z, 1e-12);
    EXPECT_NEAR(qz[i], 2.0 * z - 2.0 * y, 1e-12);
  }
  EXPECT_GT(checked, 0);
}

// The corrected gradient is exact for a linear field wherever its 3 x 3 matrix is invertible: on a jittered lattice and
// at the cube's corners, where the plain one is not.
TEST(ThreeD, CorrectedGradientIsExactForALinearFieldOnAJitteredLatticeUpToItsCorners) {
  const int n = 8;
  Lattice l(n, 3.1);
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> jitter(-0.1 * kL0, 0.1 * kL0);
  for (double& x : l.p.x) x += jitter(rng);
  for (double& y : l.p.y) y += jitter(rng);
  for (double& z : l.p.z) z += jitter(rng);
  l.near = mps::find_neighbors(l.p, l.domain, l.k.re);
  const std::size_t size = l.p.size();
  std::vector<double> phi(size), gx(size), gy(size), gz(size);
  for (std::size_t i = 0; i < size; ++i) phi[i] = -1.5 * l.p.x[i] + 0.75 * l.p.y[i] + 4.0 * l.p.z[i];
  mps::gradient<3>(l.stencil(), phi, {gx, gy, gz}, mps::GradientVariant::corrected);
  for (std::size_t i = 0; i < size; ++i) {
    ASSERT_NEAR(gx[i], -1.5, 1e-10) << i;
    ASSERT_NEAR(gy[i], 0.75, 1e-10) << i;
    ASSERT_NEAR(gz[i], 4.0, 1e-10) << i;
  }
}

// The PPE in 3-D: its matrix applied to a quadratic is minus the quadratic's Laplacian in the rows whose support is all
// unknowns, the factor 2d/(lambda n0) with d = 3 (the 2-D factor would be off by 2/3).
TEST(ThreeD, PpeRowsApplyMinusTheExactLaplacianOfAQuadratic) {
  const int n = 14;
  const Lattice l(n, 3.1);
  const std::size_t size = l.p.size();
  std::vector<char> surface(size, 0);
  std::vector<double> phi(size), source(size, 0.0);
  for (std::size_t i = 0; i < size; ++i) {
    const auto [x, y, z] = l.p.position(i);
    phi[i] = 3.0 * x * x - x * y + 2.0 * y * y + 0.5 * z * z - y * z + x;
    surface[i] = !l.interior(i, n);  // held, so every unknown's row reaches only lattice particles
  }
  const mps::PpeSystem ppe = mps::assemble_ppe(l.stencil(), surface, source, phi);
  ASSERT_GT(ppe.size(), 0u);
  for (std::size_t r = 0; r < ppe.size(); ++r) {
    double a_phi = 0.0;
    for (int k = ppe.matrix.row_ptr[r]; k < ppe.matrix.row_ptr[r + 1]; ++k)
      a_phi += ppe.matrix.val[static_cast<std::size_t>(k)] *
               phi[static_cast<std::size_t>(ppe.particle[static_cast<std::size_t>(ppe.matrix.col[static_cast<std::size_t>(k)])])];
    // A phi - b = -(Laplacian of phi) = -(6 + 4 + 1), b carrying the held neighbours' values.
    EXPECT_NEAR(a_phi - ppe.rhs[r], -11.0, 1e-9 * 11.0) << "row " << r;
  }
}

// Water at rest in a 3-D tank for 1 s: every fluid particle's pressure within what the solver's tolerance allows of
// rho g (H - z) (the split makes the lattice's solution exact, tank_bound::solve_error_bound), and none moved 0.2 l0.
TEST(ThreeD, TankAtRestHoldsRhoGDepthToTheSolversToleranceForOneSecond) {
  const double l0 = 0.02, width = 0.2, depth = 0.2;
  mps::Particles3 p;
  mps::fill_box(p, {0, 0, 0, width, width, depth}, l0, mps::Kind::fluid);
  mps::add_box_walls(p, {0, 0, 0, width, width, 1.2 * depth}, l0,
                     mps::x_low | mps::x_high | mps::y_low | mps::y_high | mps::z_low, 1, 3);
  const mps::Particles3 start = p;
  mps::SimulationConfig c;
  c.l0 = l0;
  c.fz = -9.81;
  c.dt_max = 4e-3;
  c.gamma = 0.01;  // at 0.99 a short wave grows ~4 % a step from round-off with these radii (docs/method.md)
  c.radius_density = c.radius_laplacian = 3.1;
  c.solver = "eigen-cg:precond=ic,tol=1e-8";
  mps::Simulation3 sim(p, {-0.1, width + 0.1, -0.1, width + 0.1, -0.1, 2 * depth}, c);
  while (sim.time() < 1.0 - 1e-9) sim.step();
  const double bound = tank_bound::solve_error_bound(sim, 1e-8);
  const mps::Particles3& end = sim.particles();
  double largest_error = 0.0, largest_move = 0.0;
  for (std::size_t i = 0; i < end.size(); ++i) {
    if (end.kind[i] != mps::Kind::fluid) continue;
    const std::size_t s = static_cast<std::size_t>(end.id[i]);
    largest_error = std::max(largest_error, std::abs(end.p[i] - 1000.0 * 9.81 * (depth - end.z[i])));
    largest_move = std::max(largest_move, mps::norm<3>({end.x[i] - start.x[s], end.y[i] - start.y[s],
                                                        end.z[i] - start.z[s]}));
  }
  std::printf("3-D tank: largest pressure error %.3g Pa (bound %.3g Pa), largest move %.3g l0\n", largest_error, bound,
              largest_move / l0);
  EXPECT_LT(largest_error, bound);
  EXPECT_LT(largest_move, 0.2 * l0);
}

// 3-D frames and particle files give every bit back; the 2-D readers refuse them, naming why.
TEST(ThreeD, FramesAndParticleFilesRoundTripBitwiseAndTwoDReadersRefuseThem) {
  mps::Particles3 p;
  mps::fill_box(p, {0, 0, 0, 0.3, 0.2, 0.1}, 0.05, mps::Kind::fluid, 2);
  mps::add_box_walls(p, {0, 0, 0, 0.3, 0.2, 0.1}, 0.05, mps::z_low, 1, 1);
  for (std::size_t i = 0; i < p.size(); ++i) {
    p.w[i] = 1.0 / 3.0 + static_cast<double>(i);
    p.p[i] = -2.5e-3 * static_cast<double>(i);
  }
  const std::string dir = testing::TempDir();
  for (const bool frame : {true, false}) {
    const std::string path = dir + (frame ? "sparsemps_3d.vtp" : "sparsemps_3d.csv");
    if (frame) mps::write_vtp(path, p, 0.25);
    else mps::write_particles_csv(path, p, {"a 3-D set"});
    double time = 0.0;
    const mps::Particles3 back = frame ? mps::read_vtp<3>(path, &time) : mps::read_particles_csv<3>(path);
    ASSERT_EQ(back.size(), p.size());
    EXPECT_EQ(back.x, p.x);
    EXPECT_EQ(back.y, p.y);
    EXPECT_EQ(back.z, p.z);
    EXPECT_EQ(back.w, p.w);
    EXPECT_EQ(back.p, p.p);
    EXPECT_EQ(back.kind, p.kind);
    EXPECT_EQ(back.group, p.group);
    if (frame) {
      EXPECT_EQ(time, 0.25);
    }
    std::string refusal;
    try {
      (void)(frame ? mps::read_vtp(path) : mps::read_particles_csv(path));
    } catch (const std::runtime_error& e) {
      refusal = e.what();
    }
    EXPECT_NE(refusal.find("3-D"), std::string::npos) << refusal;
  }
  EXPECT_NEAR(mps::median_spacing(p), 0.05, 1e-15);
}

namespace {

// MirrorExtension::quadratic on a jittered lattice behind a tilted plane in D dimensions: every particle within
// `band` behind the plane is a dummy of group 1, the rest of that side ghosts, the velocity a quadratic that is U on
// the plane. Returns the largest difference between a dummy's continued velocity and the quadratic at the dummy.
template <int D>
double quadratic_extension_error(mps::MirrorExtension extension) {
  const double l0 = 0.1, side = 2.0, band = 0.35, radius = 2.1 * l0;
  mps::BasicParticles<D> p;
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> jitter(-0.1 * l0, 0.1 * l0);
  const int n = static_cast<int>(side / l0);
  for (int k = 0; k < (D == 3 ? n : 1); ++k)
    for (int j = 0; j < n; ++j)
      for (int i = 0; i < n; ++i) {
        mps::Vec<D> r;
        r[0] = (i + 0.5) * l0 + jitter(rng);
        r[1] = (j + 0.5) * l0 + jitter(rng);
        if constexpr (D == 3) r[2] = (k + 0.5) * l0 + jitter(rng);
        p.add(r, mps::Kind::fluid);
      }
  mps::MirrorPlane<D> plane;
  plane.group = 1;
  plane.extension = extension;
  const double tilt = 1.0 / std::sqrt(D == 3 ? 1.0 + 0.09 + 0.04 : 1.0 + 0.09);
  for (std::size_t a = 0; a < D; ++a) {
    plane.point[a] = 0.5 * side;
    plane.velocity[a] = 0.1 * static_cast<double>(a + 1);
  }
  plane.normal[0] = 0.3 * tilt;
  plane.normal[1] = tilt;
  if constexpr (D == 3) plane.normal[2] = -0.2 * tilt;
  plane.velocity[1] = -plane.velocity[0] * plane.normal[0] / plane.normal[1];  // tangential: a sliding wall
  if constexpr (D == 3) plane.velocity[1] -= plane.velocity[2] * plane.normal[2] / plane.normal[1];
  // u_a = U_a + s (alpha_a + beta_a . r), s the depth into the fluid: any quadratic that is U on the plane.
  const auto exact = [&](const mps::Vec<D>& r, std::size_t a) {
    double s = 0.0, lin = 0.5 - 0.25 * static_cast<double>(a);
    for (std::size_t b = 0; b < D; ++b) {
      s += (r[b] - plane.point[b]) * plane.normal[b];
      lin += (0.7 * static_cast<double>(a + 1) - 0.4 * static_cast<double>(b)) * r[b];
    }
    return plane.velocity[a] + s * lin;
  };
  const auto vel = p.velocities();
  for (std::size_t i = 0; i < p.size(); ++i) {
    const mps::Vec<D> r = p.position(i);
    double s = 0.0;
    for (std::size_t b = 0; b < D; ++b) s += (r[b] - plane.point[b]) * plane.normal[b];
    if (s < 0.0) {
      p.kind[i] = s > -band ? mps::Kind::dummy : mps::Kind::ghost;
      p.group[i] = 1;
    }
    for (std::size_t a = 0; a < D; ++a) (*vel[a])[i] = p.kind[i] == mps::Kind::fluid ? exact(r, a) : 0.0;
  }
  mps::BasicDomain<D> domain;
  domain.xmin = domain.ymin = -1.0;
  domain.xmax = domain.ymax = side + 1.0;
  if constexpr (D == 3) {
    domain.zmin = -1.0;
    domain.zmax = side + 1.0;
  }
  mps::BasicCellGrid<D> grid(domain, radius);
  grid.bin(p);
  mps::apply_mirror_velocity(plane, grid, radius, p);
  double largest = 0.0;
  int dummies = 0;
  for (std::size_t i = 0; i < p.size(); ++i) {
    if (p.kind[i] != mps::Kind::dummy) continue;
    // Where the mirror image lies beside the lattice's own edges its fluid may not determine the fit.
    const mps::Vec<D> r = p.position(i);
    double s = 0.0;
    bool inside = true;
    for (std::size_t b = 0; b < D; ++b) s += (r[b] - plane.point[b]) * plane.normal[b];
    for (std::size_t b = 0; b < D; ++b) {
      const double m = r[b] - 2.0 * s * plane.normal[b];
      inside = inside && m > radius && m < side - radius;
    }
    if (!inside) continue;
    ++dummies;
    for (std::size_t a = 0; a < D; ++a) largest = std::max(largest, std::abs((*vel[a])[i] - exact(p.position(i), a)));
  }
  EXPECT_GT(dummies, 0);
  return largest;
}

}  // namespace

// The quadratic extension continues every quadratic velocity that is the wall's velocity on the plane exactly, in 2-D
// and 3-D, on a jittered lattice and a tilted plane; the odd extension (the default) does not, as the field curves.
TEST(ThreeD, QuadraticMirrorExtensionContinuesAQuadraticThatIsUOnThePlaneExactly) {
  EXPECT_LT(quadratic_extension_error<2>(mps::MirrorExtension::quadratic), 1e-12);
  EXPECT_LT(quadratic_extension_error<3>(mps::MirrorExtension::quadratic), 1e-12);
  EXPECT_GT(quadratic_extension_error<2>(mps::MirrorExtension::odd), 1e-3);
  EXPECT_GT(quadratic_extension_error<3>(mps::MirrorExtension::odd), 1e-3);
}

namespace {

// u(y, z, t) of a square duct of side a under a body force F from rest, no slip on its four walls: the sine series
// sum over odd m, n of 16 F a^2 / (nu pi^4 m n (m^2 + n^2)) (1 - exp(-nu pi^2 (m^2 + n^2) t / a^2))
// sin(m pi y / a) sin(n pi z / a).
double duct_velocity(double y, double z, double t, double a, double force, double nu) {
  const double pi = std::acos(-1.0);
  double u = 0.0;
  for (int m = 1; m < 200; m += 2)
    for (int n = 1; n < 200; n += 2) {
      const double k2 = m * m + n * n;
      u += 16.0 * force * a * a / (nu * std::pow(pi, 4) * m * n * k2) * (1.0 - std::exp(-nu * pi * pi * k2 * t / (a * a))) *
           std::sin(m * pi * y / a) * std::sin(n * pi * z / a);
    }
  return u;
}

struct DuctRun {
  double largest_error = 0, peak = 0;  // over the fluid, against the series at the run's end [m/s]
};

// A periodic square duct (side 0.1 m, `across` particles across, 14 spacings long) driven by a body force along x,
// each wall's particles taking the fluid's velocity continued across the wall by the quadratic fit
// (MirrorPlaneNoSlip3, MirrorExtension::quadratic; the edges' dummies at rest), run to t.
DuctRun run_duct(int across, double t_end) {
  const double a = 0.1, l0 = a / across, length = 14 * l0, nu = 1e-3, force = 1e-2;
  mps::Particles3 p;
  mps::fill_box(p, {0, 0, 0, length, a, a}, l0, mps::Kind::fluid);
  mps::add_box_walls(p, {0, 0, 0, length, a, a}, l0, mps::y_low | mps::y_high | mps::z_low | mps::z_high, 1, 3, 5);
  for (std::size_t i = 0; i < p.size(); ++i) {  // groups 1-4: the walls' slabs; 5: the edges between them
    if (p.kind[i] == mps::Kind::fluid) continue;
    const bool y_in = p.y[i] > 0 && p.y[i] < a, z_in = p.z[i] > 0 && p.z[i] < a;
    if (z_in) p.group[i] = p.y[i] < 0 ? 1 : 2;
    if (y_in) p.group[i] = p.z[i] < 0 ? 3 : 4;
  }
  mps::SimulationConfig c;
  c.l0 = l0;
  c.nu = nu;
  c.fx = force;
  c.radius_density = c.radius_laplacian = 3.1;
  c.dt_max = 1.0;  // the viscous limit binds
  c.clamp_negative_pressure = false;
  c.solver = "eigen-cg:precond=ic,tol=1e-10";
  mps::Simulation3 sim(p, {0, length, -0.05, a + 0.05, -0.05, a + 0.05, true}, c);
  sim.add<mps::SurfaceRegion3>([](const mps::Vec<3>&) { return false; });  // a closed duct
  const auto quadratic = mps::MirrorExtension::quadratic;
  sim.add<mps::MirrorPlaneNoSlip3>(mps::MirrorPlane<3>{{0, 0, 0}, {0, 1, 0}, {}, 1, quadratic});
  sim.add<mps::MirrorPlaneNoSlip3>(mps::MirrorPlane<3>{{0, a, 0}, {0, -1, 0}, {}, 2, quadratic});
  sim.add<mps::MirrorPlaneNoSlip3>(mps::MirrorPlane<3>{{0, 0, 0}, {0, 0, 1}, {}, 3, quadratic});
  sim.add<mps::MirrorPlaneNoSlip3>(mps::MirrorPlane<3>{{0, 0, a}, {0, 0, -1}, {}, 4, quadratic});
  while (sim.time() < t_end - 1e-12) sim.step();
  DuctRun r;
  const mps::Particles3& q = sim.particles();
  for (std::size_t i = 0; i < q.size(); ++i) {
    if (q.kind[i] != mps::Kind::fluid) continue;
    const double exact = duct_velocity(q.y[i], q.z[i], sim.time(), a, force, nu);
    r.largest_error = std::max(r.largest_error, std::abs(q.u[i] - exact));
    r.peak = std::max(r.peak, exact);
  }
  return r;
}

}  // namespace

// The square duct at 10 across, developed (t = 3 s, six times the slowest mode's a^2 / (2 pi^2 nu) = 0.51 s): every
// fluid particle's velocity within 2 % of the series' peak. The error falls about as l0^2 (measured 1.47 % at 10
// across, 0.74 % at 16, 0.45 % at 20; with the odd extension 2.24 %, 1.14 %, 1.27 %: docs/method.md). Early in the
// start-up the explicit step lags, which is why the developed state is compared.
TEST(ThreeD, SquareDuctDevelopsTheSeriesSolutionsProfile) {
  const DuctRun r = run_duct(10, 3.0);
  std::printf("duct, 10 across, t = 3 s: largest error %.3g m/s of a peak %.3g m/s (%.2f %%)\n", r.largest_error,
              r.peak, 100 * r.largest_error / r.peak);
  EXPECT_LT(r.largest_error, 0.02 * r.peak);
}

// The target, 1 %, at 14 across (measured 0.71 %; 1.47 % at 10 and 0.45 % at 20 across: second order). 20
// across took 95 s and 14 across 34 s on one thread: the cost grows as across^4 with the viscous time step.
TEST(ThreeD, SquareDuctAt14AcrossIsWithinOnePercent) {
  const DuctRun r = run_duct(14, 3.0);
  std::printf("duct, 14 across, t = 3 s: largest error %.3g m/s of a peak %.3g m/s (%.2f %%)\n", r.largest_error,
              r.peak, 100 * r.largest_error / r.peak);
  EXPECT_LT(r.largest_error, 0.01 * r.peak);
}

// RigidMotion3 turns a wall group about an axis through a point and shifts it. Checked against what does not depend
// on its formula: about the z axis it moves x and y as the 2-D RigidMotion does and leaves z; about a tilted axis the
// body stays rigid (every distance kept), each particle keeps its height along the axis and its distance from it, a
// whole turn brings it back, and its velocity is the time derivative of its position (central differences).
TEST(ThreeD, RigidMotionTurnsAndShiftsAWallGroupRigidlyWithItsVelocity) {
  const double l0 = 0.1;
  mps::Particles3 body;
  mps::add_box_walls(body, {0.0, 0.0, 0.0, 0.4, 0.3, 0.2}, l0, mps::x_low | mps::x_high | mps::z_low, 1, 1, 7);
  ASSERT_GT(body.size(), 50U);
  const mps::Vec<3> centre{0.2, 0.1, -0.05};
  const double omega = 2.3;
  const mps::Vec<3> v{0.3, -0.1, 0.2};

  // About z: x and y as the 2-D motion moves them.
  mps::Particles flat;
  for (std::size_t i = 0; i < body.size(); ++i) flat.add(body.x[i], body.y[i], body.kind[i], body.group[i]);
  mps::RigidMotion3 about_z(body, 7, centre, {0.0, 0.0, 2.0}, mps::steady_path3(omega, {v[0], v[1], 0.0}));
  mps::RigidMotion planar(flat, 7, centre[0], centre[1], mps::steady_path(omega, v[0], v[1]));
  mps::Particles3 moved = body;
  about_z(moved, 0.37);
  planar(flat, 0.37);
  for (std::size_t i = 0; i < body.size(); ++i) {
    EXPECT_NEAR(moved.x[i], flat.x[i], 1e-14);
    EXPECT_NEAR(moved.y[i], flat.y[i], 1e-14);
    EXPECT_EQ(moved.z[i], body.z[i]);
    EXPECT_NEAR(moved.u[i], flat.u[i], 1e-13);
    EXPECT_NEAR(moved.v[i], flat.v[i], 1e-13);
    EXPECT_EQ(moved.w[i], 0.0);
  }

  // About a tilted axis.
  const mps::Vec<3> axis{1.0, -2.0, 0.5};
  const double length = std::sqrt(1.0 + 4.0 + 0.25);
  const mps::Vec<3> a{axis[0] / length, axis[1] / length, axis[2] / length};
  mps::RigidMotion3 tilted(body, 7, centre, axis, mps::steady_path3(omega, v));
  auto at = [&](double t) {
    mps::Particles3 p = body;
    tilted(p, t);
    return p;
  };
  const double t = 0.81;
  const mps::Particles3 now = at(t);
  auto relative = [&](const mps::Particles3& p, std::size_t i, double time) {
    return mps::Vec<3>{p.x[i] - centre[0] - v[0] * time, p.y[i] - centre[1] - v[1] * time,
                       p.z[i] - centre[2] - v[2] * time};
  };
  double worst_distance = 0, worst_height = 0, worst_radius = 0, worst_turn = 0, worst_velocity = 0;
  const double h = 1e-5;
  const mps::Particles3 before = at(t - h), after = at(t + h);
  const mps::Particles3 turned_once = at(2.0 * std::acos(-1.0) / omega);
  for (std::size_t i = 0; i < body.size(); ++i) {
    for (std::size_t j = i + 1; j < body.size(); j += 7) {
      const double d0 = mps::norm<3>(mps::Vec<3>{body.x[j] - body.x[i], body.y[j] - body.y[i], body.z[j] - body.z[i]});
      const double d1 = mps::norm<3>(mps::Vec<3>{now.x[j] - now.x[i], now.y[j] - now.y[i], now.z[j] - now.z[i]});
      worst_distance = std::max(worst_distance, std::abs(d1 - d0));
    }
    const mps::Vec<3> r0 = relative(body, i, 0.0), r1 = relative(now, i, t);
    const double h0 = mps::dot<3>(a, r0), h1 = mps::dot<3>(a, r1);
    worst_height = std::max(worst_height, std::abs(h1 - h0));
    worst_radius = std::max(worst_radius, std::abs(std::sqrt(mps::norm2<3>(r1) - h1 * h1) -
                                                   std::sqrt(mps::norm2<3>(r0) - h0 * h0)));
    const mps::Vec<3> back = relative(turned_once, i, 2.0 * std::acos(-1.0) / omega);
    worst_turn = std::max(worst_turn, mps::norm<3>(mps::Vec<3>{back[0] - r0[0], back[1] - r0[1], back[2] - r0[2]}));
    const mps::Vec<3> fd{(after.x[i] - before.x[i]) / (2 * h), (after.y[i] - before.y[i]) / (2 * h),
                         (after.z[i] - before.z[i]) / (2 * h)};
    worst_velocity = std::max(
        worst_velocity, mps::norm<3>(mps::Vec<3>{fd[0] - now.u[i], fd[1] - now.v[i], fd[2] - now.w[i]}));
  }
  EXPECT_LT(worst_distance, 1e-14);
  EXPECT_LT(worst_height, 1e-14);
  EXPECT_LT(worst_radius, 1e-14);
  EXPECT_LT(worst_turn, 1e-14);
  EXPECT_LT(worst_velocity, 1e-8);  // central differences: O(h^2 omega^3 r)

  // Refused by name.
  EXPECT_THROW(mps::RigidMotion3(body, 7, centre, {0.0, 0.0, 0.0}, mps::steady_path3(1.0)), std::invalid_argument);
  EXPECT_THROW(mps::RigidMotion3(body, 7, {0.0, std::nan(""), 0.0}, axis, mps::steady_path3(1.0)),
               std::invalid_argument);
  EXPECT_THROW(mps::RigidMotion3(body, 8, centre, axis, mps::steady_path3(1.0)), std::invalid_argument);
}

namespace {

// The inlet channel of apps/poiseuille (Lan, Zhao & Wan 2022: a pushing plate, an open outlet with an outflow
// buffer, mirror no-slip walls with conveyors beside the plate's stroke) as a 3-D slab between two plates, periodic
// along z, so that its developed flow is the plane parabola. Re = U D / nu = 40, `across` particles across D, 6 D long,
// the profile sampled at 4 D, rows averaged over z and over the last convective time D / U of 4.
struct SlabRun {
  double peak_error = 0, flow_rate_error = 0, worst_row_error = 0;  // against 1.5 U, U D and the parabola (of 1.5 U)
  double largest_fluid_change = 0;  // |fluid now - fluid at the start| over the run, in particles
  int columns = 0;                  // columns the plate added
  long removed = 0;                 // fluid particles the outlet removed
  int samples = 0;
};

SlabRun run_inlet_slab(int across, int depth_l0) {
  const double D = 0.2, re = 40, nu = 1e-6, U = re * nu / D, l0 = D / across, L = 6 * D, Z = depth_l0 * l0;
  const int plate_group = 3, bottom_conveyor = 4, top_conveyor = 5;
  mps::Particles3 p;
  mps::fill_box(p, {0, 0, 0, L, D, Z}, l0, mps::Kind::fluid);
  for (double& u : p.u) u = U;  // the plate starts impulsively; the fluid answers at once with plug flow at U
  const mps::Box walled{-5 * l0, 0, 0, L + 5 * l0, D, Z};
  mps::add_box_walls(p, walled, l0, mps::y_low, 1, 4, 1);
  mps::add_box_walls(p, walled, l0, mps::y_high, 1, 4, 2);
  for (std::size_t i = 0; i < p.size(); ++i)
    if (p.x[i] < 3 * l0 && (p.group[i] == 1 || p.group[i] == 2)) p.group[i] = p.group[i] == 1 ? bottom_conveyor : top_conveyor;
  mps::add_box_walls(p, {0, 0, 0, L, D, Z}, l0, mps::x_low, 1, 4, plate_group);
  // The ghost pool behind the plate: three columns' worth, three to a row's height, none coinciding.
  for (int k = 0; k < 3 * across; ++k)
    for (int m = 0; m < depth_l0; ++m) p.add({-5.5 * l0, (k + 0.5) * D / (3 * across), (m + 0.5) * l0}, mps::Kind::ghost);
  poiseuille::Params scene;  // the 2-D app's compressibility for this channel (Params::sound_speed)
  scene.re = re;
  scene.across = across;
  scene.length_D = 6;
  mps::SimulationConfig c;
  c.l0 = l0;
  c.nu = nu;
  c.dt_max = 10 * std::max(c.cfl * l0 / (1.5 * U), c.viscous_number * l0 * l0 / nu);
  c.sound_speed = scene.sound_speed();
  c.clamp_negative_pressure = false;
  const mps::Particles3 initial = p;
  mps::Simulation3 sim(p, {-6 * l0, L + 6 * l0, -6 * l0, D + 6 * l0, 0, Z, false, false, true}, c);
  auto plate = std::make_shared<mps::PushingPlate3>(initial, plate_group, U, l0, L);
  sim.add<mps::BoundaryMotion3>([plate](mps::Particles3& s, double t, std::size_t owned) { (*plate)(s, t, owned); });
  sim.add<mps::SurfaceRegion3>([](const mps::Vec<3>& r) { return r[0] < 0.0; });
  sim.add<mps::OpenOutlet3>(mps::OutflowBuffer3{{L, 0, 0}, {1, 0, 0}, 5 * l0});
  sim.add<mps::MirrorPlaneNoSlip3>(mps::MirrorPlane<3>{{0, 0, 0}, {0, 1, 0}, {}, 1});
  sim.add<mps::MirrorPlaneNoSlip3>(mps::MirrorPlane<3>{{0, D, 0}, {0, -1, 0}, {}, 2});
  sim.add<mps::MirrorPlaneNoSlip3>(mps::MirrorPlane<3>{{0, 0, 0}, {0, 1, 0}, {U, 0, 0}, bottom_conveyor});
  sim.add<mps::MirrorPlaneNoSlip3>(mps::MirrorPlane<3>{{0, D, 0}, {0, -1, 0}, {U, 0, 0}, top_conveyor});
  const auto fluid_at_start = static_cast<double>(sim.particles().count(mps::Kind::fluid));
  const double t_end = 4 * D / U, station = 4 * D;
  std::vector<double> sum(static_cast<std::size_t>(across), 0.0);
  std::vector<int> count(sum.size(), 0);
  SlabRun r;
  while (sim.time() < t_end * (1 - 1e-9)) {
    sim.step();
    const mps::Particles3& s = sim.particles();
    r.largest_fluid_change =
        std::max(r.largest_fluid_change, std::abs(static_cast<double>(s.count(mps::Kind::fluid)) - fluid_at_start));
    if (sim.time() <= t_end - D / U) continue;
    for (std::size_t i = 0; i < s.size(); ++i) {
      if (s.kind[i] != mps::Kind::fluid || std::abs(s.x[i] - station) > 0.5 * l0 || s.y[i] <= 0 || s.y[i] >= D) continue;
      const auto row = static_cast<std::size_t>(s.y[i] / l0);
      sum[row] += s.u[i];
      ++count[row];
      ++r.samples;
    }
  }
  double flow = 0, peak = 0;
  for (std::size_t k = 0; k < sum.size(); ++k) {
    const double y = (static_cast<double>(k) + 0.5) * l0, u = count[k] ? sum[k] / count[k] : 0.0;
    flow += u * l0;
    peak = std::max(peak, u);
    r.worst_row_error = std::max(r.worst_row_error, std::abs(u - 6 * U * y / D * (1 - y / D)) / (1.5 * U));
  }
  r.peak_error = std::abs(peak - 1.5 * U) / (1.5 * U);
  r.flow_rate_error = std::abs(flow - U * D) / (U * D);
  r.columns = plate->columns_added();
  r.removed = plate->particles_removed();
  return r;
}

}  // namespace

// The 3-D inlet and outlet (PushingPlate3, OpenOutlet3, MirrorPlaneNoSlip3 with conveyors) on the 2-D app's channel
// as a z-periodic slab: the developed flow at 4 D carries the plate's U D with the parabola's profile, and inflow and
// outflow balance. The bounds are the 2-D channel's at this spacing: `poiseuille --mode inlet --re 40 --across 10
// --channel-length 6 --station 4 --end-time 4` measures a peak error of 5.41 % and a flow-rate error of 2.80 % (at 20
// across, InletChannel.DevelopedPeakAndFlowRateMatchTheParabolaAndMassIsConserved holds 3 % and 2 %); measured here
// 5.03 % and 1.62 %, 40 columns in and 5,252 particles out. About two minutes on one thread.
TEST(ThreeD, InletSlabDevelopsThePlaneParabolaAndBalancesInflowAndOutflow) {
  const int across = 10, depth = 13;  // a periodic axis spans at least three 4.1 l0 searches
  const SlabRun r = run_inlet_slab(across, depth);
  std::printf("inlet slab, %d across: peak %.2f %%, flow rate %.2f %%, worst row %.2f %% of 1.5 U; %d columns in, "
              "%ld out, fluid within %.0f of its start\n",
              across, 100 * r.peak_error, 100 * r.flow_rate_error, 100 * r.worst_row_error, r.columns, r.removed,
              r.largest_fluid_change);
  EXPECT_GT(r.samples, 1000);
  EXPECT_NEAR(r.columns, 40, 1);  // the plate has pushed 4 D = 40 l0
  EXPECT_GT(r.removed, 38L * across * depth);  // and about as much has left through the outlet
  EXPECT_LE(r.largest_fluid_change, 2.0 * across * depth);  // at most two columns' worth in flight
  EXPECT_LT(r.peak_error, 0.06);
  EXPECT_LT(r.flow_rate_error, 0.03);
}

// The wall backstop: fluid stepping past the tank's floor or side, or into an obstacle from above or from the side, is
// put on that face with its velocity into the solid removed and its other components kept; fluid through the floor
// under the obstacle leaves it by its nearest side, not its bottom; fluid above the open top is left alone. The particles are lone (no neighbours, free surface, no body force), so one step moves each by u dt.
TEST(ThreeD, WallBackstopPutsFluidThatCrossedAFaceBackOnItWithoutTheVelocityIntoTheSolid) {
  mps::Particles3 start;
  const double dt = 1e-3;
  struct Case {
    mps::Vec<3> r, u, r_after, u_after;
  };
  const std::vector<Case> cases = {
      {{0.1, 0.5, 0.0005}, {0.3, 0.0, -1.0}, {0.1 + 0.3 * dt, 0.5, 0.0}, {0.3, 0.0, 0.0}},          // through the floor
      {{0.9995, 0.2, 0.5}, {1.0, 0.2, 0.0}, {1.0, 0.2 + 0.2 * dt, 0.5}, {0.0, 0.2, 0.0}},           // through x_high
      {{0.1, 0.1, 1.2}, {0.0, -1.0, 0.0}, {0.1, 0.1 - dt, 1.2}, {0.0, -1.0, 0.0}},                  // above the top: free
      {{0.55, 0.55, 0.2005}, {0.0, 0.0, -1.0}, {0.55, 0.55, 0.2}, {0.0, 0.0, 0.0}},                 // onto the box's top
      {{0.2995, 0.4, 0.1}, {1.0, 0.0, 0.5}, {0.3, 0.4, 0.1 + 0.5 * dt}, {0.0, 0.0, 0.5}},           // into its x_low side
      {{0.66, 0.35, 0.0005}, {0.0, 0.0, -1.0}, {0.7, 0.35, 0.0}, {0.0, 0.0, 0.0}}};                 // under it: out by x_high
  for (const Case& k : cases) start.add(k.r, mps::Kind::fluid, 0, k.u);
  mps::SimulationConfig c;
  c.l0 = 0.05;
  c.dt_max = dt;
  mps::Simulation3 sim(start, mps::Domain3{-0.5, 1.5, -0.5, 1.5, -0.5, 1.5}, c);
  using Box = mps::WallBackstop3::AxisBox;
  const auto& backstop = sim.add<mps::WallBackstop3>(Box{{0, 0, 0}, {1, 1, 1}}, std::vector<Box>{{{0.3, 0.3, 0}, {0.7, 0.7, 0.2}}});
  sim.step();
  ASSERT_EQ(sim.last_step().dt, dt);
  const mps::Particles3& p = sim.particles();
  for (std::size_t i = 0; i < p.size(); ++i) {
    const Case& k = cases[static_cast<std::size_t>(p.id[i])];
    for (std::size_t a = 0; a < 3; ++a) {
      EXPECT_NEAR(p.position(i)[a], k.r_after[a], 1e-12) << "particle " << p.id[i] << " axis " << a;
      EXPECT_NEAR((*p.velocities()[a])[i], k.u_after[a], 1e-12) << "particle " << p.id[i] << " axis " << a;
    }
  }
  EXPECT_EQ(backstop.returned(), 5);
}

namespace {

// One layer of fluid lying on a floor (a periodic square of wall and dummy rows below it), `gap` spacings above the
// wall row, run to the free-surface stage with the asymmetry test and the given interior density: the layer's number
// density over n0 and whether the test (or the density test) made it free surface; every particle of the layer alike.
struct LayerOnFloor {
  double n_over_n0;
  bool surface;
};
LayerOnFloor layer_on_floor(double gap, double interior_density) {
  const double l0 = 0.1;
  const int across = 16;  // three search radii of the 4.1 l0 kernel, and more
  mps::Particles3 start;
  for (int i = 0; i < across; ++i)
    for (int j = 0; j < across; ++j) {
      const double x = (i + 0.5) * l0, y = (j + 0.5) * l0;
      for (int k = 0; k < 5; ++k)
        start.add({x, y, -(k + 0.5) * l0}, k == 0 ? mps::Kind::wall : mps::Kind::dummy, 0, {0, 0, 0});
      start.add({x, y, (gap - 0.5) * l0}, mps::Kind::fluid, 0, {0, 0, 0});
    }
  mps::SimulationConfig c;
  c.l0 = l0;
  c.dt_max = 1e-4;
  mps::Domain3 d{0, across * l0, 0, across * l0, -1, 1};
  d.periodic_x = d.periodic_y = true;
  mps::Simulation3 sim(start, d, c);
  sim.add<mps::AsymmetrySurface3>(0.9, interior_density);
  sim.advance_to(mps::Stage::free_surface);
  const auto& f = sim.fields();
  const auto& n = f.n_at_surface_radius();
  const mps::Particles3& p = sim.particles();
  std::vector<LayerOnFloor> fluid;
  for (std::size_t i = 0; i < p.size(); ++i)
    if (p.kind[i] == mps::Kind::fluid) fluid.push_back({n[i] / sim.surface_kernel().n0, f.surface[i] != 0});
  for (const LayerOnFloor& q : fluid) {
    EXPECT_NEAR(q.n_over_n0, fluid.front().n_over_n0, 1e-12);
    EXPECT_EQ(q.surface, fluid.front().surface);
  }
  return fluid.front();
}

}  // namespace

// The asymmetry test's interior density spares fluid pressed onto a wall, and only that: a layer lying 0.5 l0 above
// the floor's wall row (n = 1.05 n0) is free surface by the asymmetry test alone, and not with the limit at n0; a layer
// at 0.58 l0 (n = 0.98 n0, above the density test's 0.97, one-sided) is free surface with the limit too. In the 3-D
// dam break, fluid pressed onto the floor held at P = 0 sank into a crushed layer (docs/dambreak3d.md).
TEST(ThreeD, AsymmetryTestsInteriorDensitySparesFluidPressedOntoAWallOnly) {
  const LayerOnFloor pressed = layer_on_floor(0.5, 0.0), pressed_limited = layer_on_floor(0.5, 1.0);
  EXPECT_GT(pressed.n_over_n0, 1.0);
  EXPECT_TRUE(pressed.surface);
  EXPECT_FALSE(pressed_limited.surface);
  const LayerOnFloor lying = layer_on_floor(0.58, 1.0);
  EXPECT_GT(lying.n_over_n0, 0.97);
  EXPECT_LT(lying.n_over_n0, 1.0);
  EXPECT_TRUE(lying.surface);
  EXPECT_THROW(mps::AsymmetrySurface3(0.9, -1.0), std::invalid_argument);
  EXPECT_THROW(mps::AsymmetrySurface3(0.9, std::nan("")), std::invalid_argument);
}
