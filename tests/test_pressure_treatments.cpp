// Khayyer & Gotoh's treatments of the projection (docs/pressure.md): the higher-order source (the number density's
// exact rate of change), the higher-order Laplacian, the error-compensating source, and their names.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <random>
#include <vector>

#include "hydrostatic_bound.hpp"
#include "mps/boundaries/geometry.hpp"
#include "mps/numerics/operators.hpp"
#include "mps/step/components.hpp"
#include "mps/step/config.hpp"
#include "mps/step/step.hpp"
#include "tank.hpp"

namespace {

// The lattice sums sum -w' r and sum f r^2 (l0 = 1) from an independent script (numpy, its own w' and w''): they
// normalise the source and the Laplacian, so a wrong derivative or a wrong sum shows here first.
TEST(PressureTreatments, LatticeSumsOfTheHigherOrderOperatorsMatchAnIndependentSum) {
  struct Case {
    mps::Weight weight;
    double re;
    int dim;
    double n_rate, n_higher_order;
  };
  for (const Case c : {Case{mps::Weight::classic, 2.1, 2, 18.5397, 55.6191},
                       Case{mps::Weight::classic, 4.1, 2, 85.6995, 257.0984},
                       Case{mps::Weight::classic, 2.1, 3, 46.4186, 92.8372},
                       Case{mps::Weight::bounded, 2.1, 2, 13.1651, 33.7288},
                       Case{mps::Weight::bounded, 4.1, 2, 54.9838, 137.9405},
                       Case{mps::Weight::bounded, 3.1, 3, 127.8061, 202.3813}}) {
    for (const double l0 : {1.0, 0.01}) {  // both sums are dimensionless
      const mps::Kernel k = mps::make_kernel(c.re, l0, c.weight, c.dim);
      EXPECT_NEAR(k.n_rate, c.n_rate, 1e-4) << c.re << " " << c.dim;
      EXPECT_NEAR(k.n_higher_order, c.n_higher_order, 1e-4) << c.re << " " << c.dim;
    }
  }
}

// w' and the higher-order weight against central differences of w, away from the l0/2 floor.
TEST(PressureTreatments, KernelDerivativesAreThoseOfTheWeight) {
  for (const mps::Weight weight : {mps::Weight::bounded, mps::Weight::classic})
    for (const int dim : {2, 3}) {
      const mps::Kernel k = mps::make_kernel(3.1, 0.1, weight, dim);
      for (const double r : {0.06, 0.1, 0.17, 0.25, 0.3}) {
        const double h = 1e-5;
        const double d1 = (k.w(r + h) - k.w(r - h)) / (2 * h);
        const double d2 = (k.w(r + h) - 2 * k.w(r) + k.w(r - h)) / (h * h);
        EXPECT_NEAR(k.dw(r), d1, 1e-6 * std::abs(d1));
        EXPECT_NEAR(k.higher_order_weight(r), d2 + (dim - 3) * d1 / r, 1e-4 * std::abs(d2));
      }
      EXPECT_EQ(k.dw(k.re), 0.0);
      EXPECT_EQ(k.higher_order_weight(k.re), 0.0);
      EXPECT_EQ(k.higher_order_weight(0.0), k.higher_order_weight(0.05));  // the l0/2 floor
    }
}

// A disordered cloud with walls: fluid jittered by 0.3 l0 over a lattice, moving with a random velocity field.
struct Cloud {
  mps::Particles p;
  mps::Domain d{-1, 2, -1, 2};
  double l0 = 0.1;
  Cloud() {
    mps::fill_rectangle(p, {0, 0, 1, 1}, l0, mps::Kind::fluid);
    mps::fill_rectangle(p, {0, -0.3, 1, 0}, l0, mps::Kind::wall);
    std::mt19937 rng(7);
    std::uniform_real_distribution<double> jitter(-0.15 * l0, 0.15 * l0), speed(-1, 1);
    for (std::size_t i = 0; i < p.size(); ++i) {
      if (p.kind[i] == mps::Kind::fluid) {
        p.x[i] += jitter(rng);
        p.y[i] += jitter(rng);
      }
      p.u[i] = speed(rng);
      p.v[i] = speed(rng);
    }
  }
};

// The higher-order source is the time derivative of the number density the source's PND term reads: moving every
// particle by h u changes n by h Dn/Dt + O(h^2) (a central difference leaves O(h^2)), truncated kernels included.
TEST(PressureTreatments, NumberDensityRateIsTheExactTimeDerivativeOfTheNumberDensity) {
  Cloud c;
  const mps::Kernel k = mps::make_kernel(4.1, c.l0);
  const auto list = mps::find_neighbors(c.p, c.d, k.re + 0.1 * c.l0);  // covers the moved pairs too
  std::vector<double> rate(c.p.size());
  mps::number_density_rate<2>({c.p, c.d, list, k}, {c.p.u, c.p.v}, rate);
  auto moved_density = [&](double h) {
    mps::Particles q = c.p;
    for (std::size_t i = 0; i < q.size(); ++i) {
      q.x[i] += h * q.u[i];
      q.y[i] += h * q.v[i];
    }
    return mps::number_density({q, c.d, list, k});
  };
  const double h = 1e-6;
  const std::vector<double> ahead = moved_density(h), behind = moved_density(-h);
  double largest = 0.0;
  for (std::size_t i = 0; i < rate.size(); ++i) {
    largest = std::max(largest, std::abs(rate[i]));
    EXPECT_NEAR(rate[i], (ahead[i] - behind[i]) / (2 * h), 1e-5 * (1 + std::abs(rate[i]))) << "particle " << i;
  }
  EXPECT_GT(largest, 100.0);  // the field is not trivially zero
}

// The one-pass number_density_and_rate (what the step calls) gives the two operators' numbers bitwise, on a list
// wider than the kernel (pairs beyond re skipped alike) and with a coincident pair (its rate term is 0 in both).
TEST(PressureTreatments, NumberDensityAndRateInOnePassEqualTheTwoOperatorsBitwise) {
  Cloud c;
  c.p.x[5] = c.p.x[4];  // a coincident pair
  c.p.y[5] = c.p.y[4];
  for (const double radius : {2.1, 4.1}) {
    const mps::Kernel k = mps::make_kernel(radius, c.l0);
    const auto list = mps::find_neighbors(c.p, c.d, 4.3 * c.l0);
    const mps::Stencil s{c.p, c.d, list, k};
    std::vector<double> rate(c.p.size()), fused_rate(c.p.size(), -1.0), fused_n;
    mps::number_density_rate<2>(s, {c.p.u, c.p.v}, rate);
    const std::vector<double> n = mps::number_density(s);
    mps::number_density_and_rate<2>(s, {c.p.u, c.p.v}, fused_n, fused_rate);
    ASSERT_EQ(fused_n.size(), n.size());
    for (std::size_t i = 0; i < n.size(); ++i) {
      EXPECT_EQ(std::memcmp(&fused_n[i], &n[i], sizeof(double)), 0) << "n at particle " << i;
      EXPECT_EQ(std::memcmp(&fused_rate[i], &rate[i], sizeof(double)), 0) << "rate at particle " << i;
    }
    EXPECT_GT(*std::max_element(n.begin(), n.end()), k.n0 * 0.5);  // the sums are not trivially zero
  }
}

// Rigid motion (a translation and a rotation) changes no distance: the rate is zero on any cloud, to round-off.
TEST(PressureTreatments, NumberDensityRateVanishesForRigidMotion) {
  Cloud c;
  for (std::size_t i = 0; i < c.p.size(); ++i) {
    c.p.u[i] = 0.7 - 2.0 * c.p.y[i];
    c.p.v[i] = -0.4 + 2.0 * c.p.x[i];
  }
  const mps::Kernel k = mps::make_kernel(4.1, c.l0);
  const auto list = mps::find_neighbors(c.p, c.d, k.re);
  std::vector<double> rate(c.p.size());
  mps::number_density_rate<2>({c.p, c.d, list, k}, {c.p.u, c.p.v}, rate);
  for (double r : rate) EXPECT_NEAR(r, 0.0, 1e-9);
}

// Normalised by the lattice's sum, -(d/n_rate) Dn/Dt is the divergence, exact for a linear field on the lattice, and
// the higher-order Laplacian is exact for quadratics and cubics there: 2-D and 3-D, both weights, 2.1 to 4.1 l0.
template <int D>
void check_higher_order_operators_on_lattice(mps::Weight weight, double radius) {
  const double l0 = 0.1, size = D == 2 ? 2.0 : 1.4;
  mps::BasicParticles<D> p;
  mps::BasicDomain<D> d;
  if constexpr (D == 2) {
    mps::fill_rectangle(p, {0, 0, size, size}, l0, mps::Kind::fluid);
    d = {-1, size + 1, -1, size + 1};
  } else {
    mps::fill_box(p, {0, 0, 0, size, size, size}, l0, mps::Kind::fluid);
    d = {-1, size + 1, -1, size + 1, -1, size + 1};
  }
  mps::Kernel k = mps::make_kernel(radius, l0, weight, D);
  const auto list = mps::find_neighbors(p, d, k.re);
  const std::size_t n = p.size();
  std::array<std::vector<double>, D> u;
  std::vector<double> phi(n), rate(n), lap(n);
  for (auto& c : u) c.resize(n);
  for (std::size_t i = 0; i < n; ++i) {
    const auto r = p.position(i);
    const double z = D == 3 ? r[D - 1] : 0.0;
    u[0][i] = 0.3 * r[0] + 2 * r[1] - z;  // divergence 0.3 - 1.1 (+ 0.5 in 3-D)
    u[1][i] = -r[0] - 1.1 * r[1] + z;
    if constexpr (D == 3) u[2][i] = r[0] + 0.5 * z;
    // 3x^2 - xy + 2y^2 (+ z^2) + x^3 - y^2 x: Laplacian 6 + 4 (+ 2) + 6x - 2x
    phi[i] = 3 * r[0] * r[0] - r[0] * r[1] + 2 * r[1] * r[1] + z * z + r[0] * r[0] * r[0] - r[1] * r[1] * r[0];
  }
  mps::ConstComponents<D> uc;
  for (std::size_t a = 0; a < D; ++a) uc[a] = u[a];
  mps::number_density_rate<D>({p, d, list, k}, uc, rate);
  k.higher_order_laplacian = true;
  mps::laplacian<D>({p, d, list, k}, phi, lap);
  const double divergence = D == 2 ? -0.8 : -0.3;
  int checked = 0;
  for (std::size_t i = 0; i < n; ++i) {
    bool inside = true;
    for (double c : p.position(i)) inside = inside && c > k.re + l0 && c < size - k.re - l0;
    if (!inside) continue;
    ++checked;
    EXPECT_NEAR(-D / k.n_rate * rate[i], divergence, 1e-10);
    const double x = p.position(i)[0];
    EXPECT_NEAR(lap[i], (D == 2 ? 10.0 : 12.0) + 4 * x, 1e-8 * (1 + std::abs(lap[i])));
  }
  EXPECT_GT(checked, 0);
}

TEST(PressureTreatments, HigherOrderDivergenceAndLaplacianAreExactOnTheLattice) {
  for (const mps::Weight weight : {mps::Weight::bounded, mps::Weight::classic})
    for (const double radius : {2.1, 3.1, 4.1}) {
      SCOPED_TRACE(std::string(mps::to_string(weight)) + " " + std::to_string(radius));
      check_higher_order_operators_on_lattice<2>(weight, radius);
      if (radius < 4) check_higher_order_operators_on_lattice<3>(weight, radius);
    }
}

// The higher-order Laplacian's matrix is symmetric with zero row sums on a disordered cloud: the PPE stays an M-matrix
// that CG, CHOLMOD and AMG-PCG take, and a constant pressure adds nothing.
TEST(PressureTreatments, HigherOrderLaplacianMatrixIsSymmetricWithZeroRowSums) {
  Cloud c;
  mps::Kernel k = mps::make_kernel(4.1, c.l0);
  k.higher_order_laplacian = true;
  const auto list = mps::find_neighbors(c.p, c.d, k.re);
  const mps::CsrMatrix a = mps::laplacian_matrix({c.p, c.d, list, k});
  auto entry = [&](int r, int col) {
    for (int q = a.row_ptr[static_cast<std::size_t>(r)]; q < a.row_ptr[static_cast<std::size_t>(r) + 1]; ++q)
      if (a.col[static_cast<std::size_t>(q)] == col) return a.val[static_cast<std::size_t>(q)];
    return 0.0;
  };
  for (int r = 0; r < a.rows; ++r) {
    double sum = 0.0, diag = 0.0;
    for (int q = a.row_ptr[static_cast<std::size_t>(r)]; q < a.row_ptr[static_cast<std::size_t>(r) + 1]; ++q) {
      const int col = a.col[static_cast<std::size_t>(q)];
      const double v = a.val[static_cast<std::size_t>(q)];
      sum += v;
      if (col == r) diag = v;
      else {
        EXPECT_GT(v, 0.0);
        EXPECT_EQ(v, entry(col, r));
      }
    }
    EXPECT_NEAR(sum, 0.0, 1e-9 * std::abs(diag));
  }
}

// The error-compensating source at the step's start: zero for a liquid at rest (delta = 0) even where it is compressed
// (the gamma term is what pushes a static error back), and for a lattice compressed by 2 % and still being compressed
// (u = -c x) it is -(rho/dt^2)(|e| delta + |delta| e) with e and delta from the lattice's own sums: negative, a
// pressure bump.
TEST(PressureTreatments, ErrorCompensatingSourceIsZeroAtRestAndPushesBackAGrowingCompression) {
  const double l0 = 0.01, squeeze = 0.98, c = 0.5;
  mps::Particles p;
  mps::fill_rectangle(p, {0, 0, 0.3 * squeeze, 0.3 * squeeze}, l0 * squeeze, mps::Kind::fluid);
  mps::SimulationConfig config;
  config.l0 = l0;
  config.dt_max = 1e-3;
  config.gamma = 0.01;
  config.error_compensating_source = true;
  config.solver = "eigen-cg";
  for (const bool moving : {false, true}) {
    mps::Particles q = p;
    const double centre = 0.15 * squeeze;
    for (std::size_t i = 0; i < q.size(); ++i) {
      q.u[i] = moving ? -c * (q.x[i] - centre) : 0.0;
      q.v[i] = moving ? -c * (q.y[i] - centre) : 0.0;
    }
    mps::Simulation sim(q, mps::Domain{-0.1, 0.4, -0.1, 0.4}, config);
    sim.advance_to(mps::Stage::neighbors);
    const auto& f = sim.fields();
    const mps::Kernel& k = sim.density_kernel();
    // The squeezed lattice's n and Dn/Dt at an interior particle, summed here over its offsets.
    double n = 0.0, rate = 0.0;
    for (int a = -5; a <= 5; ++a)
      for (int b = -5; b <= 5; ++b) {
        const double r = squeeze * l0 * std::hypot(a, b);
        if (r == 0.0) continue;
        n += k.w(r);
        rate += k.dw(r) * (-c * r * r) / r;
      }
    const double e = (n - k.n0) / k.n0, delta = f.dt * rate / k.n0;
    const double expected = moving ? -config.rho / (f.dt * f.dt) * (std::abs(e) * delta + std::abs(delta) * e) : 0.0;
    int checked = 0;
    const mps::Particles& now = sim.particles();  // reordered by cell
    for (std::size_t i = 0; i < now.size(); ++i) {
      const double x = now.x[i] - centre, y = now.y[i] - centre;
      if (std::max(std::abs(x), std::abs(y)) > 0.15 * squeeze - 5 * l0) continue;
      EXPECT_NEAR(f.ecs[i], expected, 1e-9 * (1 + std::abs(expected)));
      ++checked;
    }
    EXPECT_GT(checked, 0);
    if (moving) {
      EXPECT_GT(e, 0.0);
      EXPECT_LT(expected, -1e3);
    }
  }
}

TEST(PressureTreatments, NamesRoundTripAndUnknownOrRepeatedNamesAreRefused) {
  mps::SimulationConfig c;
  EXPECT_EQ(mps::pressure_treatment(c), "none");
  mps::set_pressure_treatment(c, "ecs+hs");
  EXPECT_TRUE(c.higher_order_source && c.error_compensating_source && !c.higher_order_laplacian);
  EXPECT_EQ(mps::pressure_treatment(c), "hs+ecs");
  EXPECT_EQ(c.pressure_gradient, mps::GradientVariant::min_reference);  // no "gc": the gradient is left alone
  mps::set_pressure_treatment(c, "gc+cfs+hs+hl+ecs");
  EXPECT_TRUE(c.continuous_free_surface);
  EXPECT_EQ(c.pressure_gradient, mps::GradientVariant::corrected);
  EXPECT_EQ(mps::pressure_treatment(c), "hs+hl+ecs+cfs+gc");
  mps::set_pressure_treatment(c, "none");
  EXPECT_EQ(mps::pressure_treatment(c), "gc");  // "none" turns the four flags off; the gradient is the config's own
  mps::set_pressure_treatment(c, "ds+hs");
  EXPECT_EQ(c.stabilisation_distance, mps::SimulationConfig::default_stabilisation_distance);
  EXPECT_EQ(mps::pressure_treatment(c), "hs+gc+ds");
  c.stabilisation_distance = 0.7;
  mps::set_pressure_treatment(c, "hs+ds");  // a distance already set is kept
  EXPECT_EQ(c.stabilisation_distance, 0.7);
  mps::set_pressure_treatment(c, "hs");
  EXPECT_EQ(c.stabilisation_distance, 0.0);
  for (const char* bad : {"hs+hx", "hs+hs", "", "hs+", "HS"}) {
    try {
      mps::set_pressure_treatment(c, bad);
      ADD_FAILURE() << "accepted '" << bad << "'";
    } catch (const std::invalid_argument& e) {
      EXPECT_NE(std::string(e.what()).find("valid: hs, hl, ecs, cfs, gc and ds"), std::string::npos) << e.what();
    }
  }
}

// Runs the tank to its end, every band's pressure checked against rho g depth; its result.
tank::Result run_tank_at_rest(tank::Tank& t) {
  while (!t.done()) t.step();
  const tank::Result r = t.result();
  const double bound = tank_bound::solve_error_bound(t.sim(), 1e-8);
  for (const tank::Band& band : r.bands)
    EXPECT_LT(std::abs(band.mean_pressure - band.exact_pressure), bound) << "band at y = " << band.y_center;
  return r;
}

// The tank at rest for 0.3 s with `treatment`.
tank::Params tank_at_rest(const char* treatment) {
  tank::Params p;
  p.gamma = 0.01;
  p.end_time = 0.3;
  p.pressure_treatment = treatment;
  return p;
}

// The tank at rest holds rho g (H - y) with every treatment on, as it does without: on the lattice the higher-order
// source of a liquid at rest is zero and so is the error-compensating term, and the higher-order Laplacian is exact for
// the linear hydrostatic pressure.
TEST(PressureTreatments, HydrostaticTankHoldsItsPressureWithEveryTreatment) {
  tank::Tank t(tank_at_rest("hs+hl+ecs"));
  const tank::Result r = run_tank_at_rest(t);
  EXPECT_LT(r.max_displacement_l0, 0.2);
  EXPECT_TRUE(t.sim().config().higher_order_laplacian && t.sim().pressure_kernel().higher_order_laplacian);
  EXPECT_FALSE(t.sim().laplacian_kernel().higher_order_laplacian);  // the viscosity keeps the MPS Laplacian
}

// The continuous free surface's empty support enters the PPE as one more neighbour at a given value: the diagonal
// gains c w, the right-hand side c w v, and nothing else changes, so the matrix stays symmetric; a group it reaches is
// anchored like one that touches a held particle.
TEST(PressureTreatments, OpenSupportAddsToTheDiagonalAndTheRightHandSideOnly) {
  Cloud c;
  const mps::Kernel k = mps::make_kernel(4.1, c.l0);
  const auto list = mps::find_neighbors(c.p, c.d, k.re);
  const std::size_t n = c.p.size();
  std::vector<char> surface(n, 0);
  std::vector<double> source(n), weight(n, 0.0), value(n, 0.0);
  for (std::size_t i = 0; i < n; ++i) {
    source[i] = std::sin(3.0 * c.p.x[i]) + c.p.y[i];
    if (c.p.kind[i] == mps::Kind::fluid && c.p.y[i] > 0.85) surface[i] = 1;  // anchors both systems
    if (c.p.kind[i] == mps::Kind::fluid && c.p.y[i] > 0.5) {
      weight[i] = 0.1 + c.p.y[i];
      value[i] = 100.0 * c.p.x[i] - 7.0;
    }
  }
  const mps::PpeSystem plain = mps::assemble_ppe<2>({c.p, c.d, list, k}, surface, source);
  const mps::PpeSystem open = mps::assemble_ppe<2>({c.p, c.d, list, k}, surface, source, {}, 0.0,
                                                   mps::ClosedGroups::gauge, {weight, value});
  ASSERT_EQ(open.matrix.row_ptr, plain.matrix.row_ptr);
  ASSERT_EQ(open.matrix.col, plain.matrix.col);
  const double scale = k.laplacian_scale(2);
  int opened = 0;
  for (int r = 0; r < open.matrix.rows; ++r) {
    const auto i = static_cast<std::size_t>(open.particle[static_cast<std::size_t>(r)]);
    opened += weight[i] > 0.0;
    for (int q = open.matrix.row_ptr[static_cast<std::size_t>(r)]; q < open.matrix.row_ptr[static_cast<std::size_t>(r) + 1]; ++q) {
      const auto qq = static_cast<std::size_t>(q);
      const double added = open.matrix.col[qq] == r ? scale * weight[i] : 0.0;
      EXPECT_NEAR(open.matrix.val[qq], plain.matrix.val[qq] + added, 1e-12 * std::abs(plain.matrix.val[qq]) + 1e-12);
    }
    const double rhs_added = scale * weight[i] * value[i];
    EXPECT_NEAR(open.rhs[static_cast<std::size_t>(r)], plain.rhs[static_cast<std::size_t>(r)] + rhs_added,
                1e-12 * (std::abs(plain.rhs[static_cast<std::size_t>(r)]) + std::abs(rhs_added)));
    if (weight[i] > 0.0) {
      EXPECT_TRUE(open.anchored[static_cast<std::size_t>(r)]);
    }
  }
  EXPECT_GT(opened, 20);

  // Without held particles the open support alone anchors the block: no gauge, a solution of the given values.
  const std::vector<char> none(n, 0);
  const mps::PpeSystem alone = mps::assemble_ppe<2>({c.p, c.d, list, k}, none, source, {}, 0.0,
                                                    mps::ClosedGroups::gauge, {weight, value});
  EXPECT_TRUE(alone.floating.empty());
}

// With every fluid particle an unknown and the empty support held through the surface's value, a liquid at rest in a
// walled tank keeps its hydrostatic pressure (the classic held surface's exactness, contact lines included), and no
// fluid particle is left out of the PPE.
TEST(PressureTreatments, ContinuousFreeSurfaceKeepsTheHydrostaticTankExact) {
  tank::Tank t(tank_at_rest("hs+cfs"));
  const tank::Result r = run_tank_at_rest(t);
  EXPECT_LT(r.max_displacement_l0, 1e-4);
  const mps::PpeSystem& ppe = t.sim().last_ppe();
  const mps::Particles& q = t.sim().particles();
  int surface = 0;
  for (std::size_t i = 0; i < q.size(); ++i)
    if (q.kind[i] == mps::Kind::fluid) {
      EXPECT_GE(ppe.unknown[i], 0) << "fluid particle " << i << " is not an unknown";
      surface += t.sim().fields().surface[i];
    }
  EXPECT_GT(surface, 10);  // the surface test still flags the top row
  EXPECT_EQ(mps::pressure_treatment(t.sim().config()), "hs+cfs");
}

// Where no surface particle is in reach, the continuous free surface puts the surface where a flat cut of the lattice
// leaves as much of the support empty: below a flat top of a lattice block each row's empty weight, summed over its
// actual neighbours, must give its true depth plus half a spacing, for both weights and the higher-order Laplacian.
TEST(PressureTreatments, SurfaceDistanceFromTheEmptyWeightIsTheDepthBelowAFlatTop) {
  for (mps::Weight weight : {mps::Weight::bounded, mps::Weight::classic})
    for (bool higher_order : {false, true}) {
      const double l0 = 0.1;
      mps::Kernel k = mps::make_kernel(4.1, l0, weight);
      k.higher_order_laplacian = higher_order;
      mps::Particles p;
      mps::fill_rectangle(p, {0, 0, 3, 1.5}, l0, mps::Kind::fluid);
      const mps::Domain d{-1, 4, -1, 3};
      const auto list = mps::find_neighbors(p, d, k.re);
      double top = 0.0;
      for (double y : p.y) top = std::max(top, y);
      std::vector<double> table;
      int checked = 0;
      for (std::size_t i = 0; i < p.size(); ++i) {
        if (std::abs(p.x[i] - 1.55) > 1e-9 || p.y[i] < 0.75) continue;  // far from the sides and the bottom
        double present = 0.0;
        for (int jj : list.of(i)) {
          const auto j = static_cast<std::size_t>(jj);
          present += k.laplacian_weight(std::hypot(p.x[j] - p.x[i], p.y[j] - p.y[i]));
        }
        const double empty = k.laplacian_weight_sum() - present;
        if (empty <= 1e-12 * k.laplacian_weight_sum()) continue;
        const double depth = top + 0.5 * l0 - p.y[i];
        EXPECT_NEAR(mps::ContinuousFreeSurface::surface_distance(k, empty, table), depth, 1e-9 * l0)
            << "row at depth " << depth << ", weight " << static_cast<int>(weight) << ", higher order " << higher_order;
        ++checked;
      }
      EXPECT_EQ(checked, 4);  // the rows whose 4.1 l0 support reaches past the top
    }
}

}  // namespace
