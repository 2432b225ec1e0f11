#include <gtest/gtest.h>
#include <omp.h>

#include <cmath>
#include <numbers>
#include <stdexcept>
#include <string>
#include <vector>

#include "mps/boundaries/geometry.hpp"
#include "mps/solids/elastic.hpp"
#include "scenes.hpp"

namespace {

// A free square block of n x n particles, spacing dx, corner at the origin.
mps::ElasticBody block(int n, double dx) {
  mps::ElasticBody b;
  b.spacing = dx;
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < n; ++j) b.add((i + 0.5) * dx, (j + 0.5) * dx, dx * dx, false);
  return b;
}

// Moves every particle of a solid to x = A X + t.
void deform(mps::ElasticSolid& s, const std::array<double, 4>& a, double tx, double ty) {
  std::vector<double> x(s.size()), y(s.size());
  for (std::size_t i = 0; i < s.size(); ++i) {
    const double X = s.reference_x()[i], Y = s.reference_y()[i];
    x[i] = a[0] * X + a[1] * Y + tx;
    y[i] = a[2] * X + a[3] * Y + ty;
  }
  s.set_positions(x, y);
}

TEST(Elastic, QuadraticFitIsExactForQuadraticFieldsUpToTheBodysEdges) {
  const mps::ElasticBody b = block(8, 0.1);
  const auto fit = mps::quadratic_reference_fit(b.x, b.y, b.volume, b.size(), 0.3);
  std::vector<double> phi(b.size());
  auto f = [](double x, double y) { return 0.3 + 1.5 * x - 0.7 * y + 2.0 * x * x - 1.2 * x * y + 0.8 * y * y; };
  for (std::size_t i = 0; i < b.size(); ++i) phi[i] = f(b.x[i], b.y[i]);
  std::vector<double> gx(b.size()), gy(b.size()), hxx(b.size()), hxy(b.size()), hyy(b.size());
  fit.gradient.x.multiply(phi, gx);
  fit.gradient.y.multiply(phi, gy);
  fit.hxx.multiply(phi, hxx);
  fit.hxy.multiply(phi, hxy);
  fit.hyy.multiply(phi, hyy);
  for (std::size_t i = 0; i < b.size(); ++i) {  // corners and edges included
    EXPECT_NEAR(gx[i], 1.5 + 4.0 * b.x[i] - 1.2 * b.y[i], 1e-9);
    EXPECT_NEAR(gy[i], -0.7 - 1.2 * b.x[i] + 1.6 * b.y[i], 1e-9);
    EXPECT_NEAR(hxx[i], 4.0, 1e-7);
    EXPECT_NEAR(hxy[i], -1.2, 1e-7);
    EXPECT_NEAR(hyy[i], 1.6, 1e-7);
  }
}

TEST(Elastic, UniformStretchGivesTheExactUniformStress) {
  for (auto model : {mps::ElasticModel::linear, mps::ElasticModel::saint_venant_kirchhoff}) {
    mps::ElasticConfig c;
    c.material.model = model;
    mps::ElasticSolid s(block(10, 0.01), c);
    const std::array<double, 4> a{1.02, 0.01, -0.005, 0.97};
    deform(s, a, 0.003, -0.001);
    const auto exact = mps::first_piola_stress(a, c.material);
    const double scale = std::abs(exact.p[0]) + std::abs(exact.p[3]);
    for (std::size_t i = 0; i < s.moving(); ++i)
      for (std::size_t k = 0; k < 4; ++k) {
        ASSERT_NEAR(s.deformation_gradient()[k][i], a[k], 1e-12) << "particle " << i << " component " << k;
        ASSERT_NEAR(s.stress()[k][i], exact.p[k], 1e-9 * scale) << "particle " << i << " component " << k;
      }
    EXPECT_NEAR(s.energy().hourglass, 0.0, 1e-12 * s.energy().strain);  // an affine field is all strain
    // The strain energy is the exact energy density times the area.
    EXPECT_NEAR(s.energy().strain, exact.energy_density * 0.1 * 0.1, 1e-9 * s.energy().strain);
  }
}

TEST(Elastic, FiniteRigidRotationCarriesNoStressAndNoForce) {
  mps::ElasticConfig c;  // St. Venant-Kirchhoff
  mps::ElasticSolid s(block(10, 0.01), c);
  const double angle = 0.5;  // 29 degrees
  const std::array<double, 4> r{std::cos(angle), -std::sin(angle), std::sin(angle), std::cos(angle)};
  deform(s, r, 0.01, 0.02);
  const double mu = c.material.shear_modulus();
  for (std::size_t i = 0; i < s.moving(); ++i)
    for (std::size_t k = 0; k < 4; ++k) {
      ASSERT_NEAR(s.deformation_gradient()[k][i], r[k], 1e-12);
      ASSERT_NEAR(s.stress()[k][i], 0.0, 1e-10 * mu);
    }
  EXPECT_NEAR(s.energy().strain, 0.0, 1e-18);
  EXPECT_NEAR(s.energy().hourglass, 0.0, 1e-18);
  for (std::size_t i = 0; i < s.size(); ++i) ASSERT_NEAR(s.acceleration_x()[i], 0.0, 1e-6) << i;
  // The linear law is not objective: the same rotation gives it a stress of order mu (1 - cos) (why svk is the default).
  c.material.model = mps::ElasticModel::linear;
  mps::ElasticSolid lin(block(10, 0.01), c);
  deform(lin, r, 0.01, 0.02);
  EXPECT_GT(std::abs(lin.stress()[0][0]), 0.1 * mu);
}

// A free block set spinning, drifting and shaking, for the same time at two time steps: momentum and angular
// momentum are kept to round-off (pair forces, rotation-invariant energies, velocity Verlet); the energy error is
// Verlet's bounded O(dt^2) one.
struct FreeBodyRun {
  std::array<double, 3> start{}, end{};  // momentum x, y and angular momentum (unit masses)
  double energy = 0, worst_energy_error = 0, deformation_energy = 0;
};
FreeBodyRun free_body(double cfl, double duration) {
  mps::ElasticConfig c;
  c.cfl = cfl;
  mps::ElasticSolid s(block(12, 0.01), c);
  std::vector<double> u(s.size()), v(s.size());
  for (std::size_t i = 0; i < s.size(); ++i) {
    const double X = s.reference_x()[i] - 0.06, Y = s.reference_y()[i] - 0.06;
    u[i] = 0.3 - 2.0 * Y + 0.2 * std::sin(37.0 * static_cast<double>(i));
    v[i] = -0.1 + 2.0 * X + 0.2 * std::cos(11.0 * static_cast<double>(i));
  }
  s.set_velocity(u, v);
  auto momenta = [&] {
    std::array<double, 3> m{0, 0, 0};
    for (std::size_t i = 0; i < s.size(); ++i) {  // all particles carry the same mass
      m[0] += s.u()[i];
      m[1] += s.v()[i];
      m[2] += s.x()[i] * s.v()[i] - s.y()[i] * s.u()[i];
    }
    return m;
  };
  FreeBodyRun r;
  r.start = momenta();
  r.energy = s.energy().total();
  while (s.time() < duration) {
    s.step();
    r.worst_energy_error = std::max(r.worst_energy_error, std::abs(s.energy().total() - r.energy));
    r.deformation_energy = std::max(r.deformation_energy, s.energy().strain + s.energy().hourglass);
  }
  r.end = momenta();
  return r;
}

TEST(Elastic, FreeBodyConservesMomentumAngularMomentumAndEnergy) {
  const FreeBodyRun coarse = free_body(0.2, 0.01), fine = free_body(0.1, 0.01);
  for (const auto& r : {coarse, fine}) {
    EXPECT_NEAR(r.end[0], r.start[0], 1e-10 * std::abs(r.start[0]));
    EXPECT_NEAR(r.end[1], r.start[1], 1e-10 * std::abs(r.start[1]));
    EXPECT_NEAR(r.end[2], r.start[2], 1e-9 * std::abs(r.start[2]));
    EXPECT_GT(r.deformation_energy, 1e-2 * r.energy);  // the shaking did deform the body
  }
  // Halving dt quarters the energy error (measured: 4.8e-3 and 1.2e-3 of the energy, 0.24x).
  EXPECT_LT(fine.worst_energy_error, 0.3 * coarse.worst_energy_error);
  EXPECT_LT(fine.worst_energy_error, 2e-3 * fine.energy);
}

TEST(Elastic, PlateSwingsAtThePlaneStrainPeriodAndConservesEnergy) {
  // H/5, to two periods: the fastest spacing; bench/structure_study.py has the three spacings.
  const structure::Plate plate;
  mps::ElasticConfig c;
  c.material = plate.material(mps::ElasticModel::saint_venant_kirchhoff);
  mps::ElasticSolid s(structure::plate_body(plate, 0.004, c.radius), c);
  std::vector<double> u(s.size(), 0.0), v(s.size(), 0.0);
  for (std::size_t i = 0; i < s.moving(); ++i)
    v[i] = structure::plate_initial_velocity(plate, c.material, s.reference_x()[i]);
  s.set_velocity(u, v);
  std::vector<double> t, uy;
  const double e0 = s.energy().total();
  double drift = 0.0;
  while (s.time() < 2.2 * structure::PlateReference::period) {
    s.step();
    if (s.steps() % 20 == 0) {
      t.push_back(s.time());
      uy.push_back(s.displacement_at(plate.length, 0.0)[1]);
      drift = std::max(drift, std::abs(s.energy().total() - e0));
    }
  }
  const double period = structure::zero_crossing_period(t, uy);
  // Measured 0.27332 s (+7.09 %) at this spacing, energy within 6.5e-6 (docs/structures.md has H/10 and H/20). The
  // limit is that error with a margin: without hourglass control the clamp opens a hinge and the period is +50 % or more.
  EXPECT_NEAR(period, structure::PlateReference::period, 0.09 * structure::PlateReference::period);
  EXPECT_LT(drift, 1e-4 * e0);
}

TEST(Elastic, Csm3FlagFirstSwingFollowsTheReference) {
  // H/5 to t = 0.6 s (bench/structure_study.py runs three spacings to 4 s): the tip's first minimum.
  const structure::Flag flag;
  mps::ElasticConfig c;
  c.material = structure::Flag::material();
  c.gravity_y = -flag.gravity;
  mps::ElasticSolid s(structure::flag_body(flag, 0.004, c.radius), c);
  std::vector<double> t, uy;
  while (s.time() < 0.6) {
    s.step();
    if (s.steps() % 10 == 0) {
      t.push_back(s.time());
      uy.push_back(s.displacement_at(flag.tip_x, flag.cy)[1]);
    }
  }
  const auto ref = structure::read_csv_columns(std::string(STRUCTURE_DATA_DIR) + "/turek_hron_csm3_tip_displacement.csv", 3);
  std::size_t rk = 0, k = 0;
  for (std::size_t i = 0; i < ref[0].size() && ref[0][i] <= 0.6; ++i)
    if (ref[2][i] < ref[2][rk]) rk = i;
  for (std::size_t i = 0; i < uy.size(); ++i)
    if (uy[i] < uy[k]) k = i;
  // Measured: -143.0 mm at 0.480 s against -129.6 mm at 0.455 s (+10.3 %, +5.5 %); 2.9 % deep at H/10.
  EXPECT_NEAR(uy[k], ref[2][rk], 0.13 * std::abs(ref[2][rk]));
  EXPECT_NEAR(t[k], ref[0][rk], 0.08 * ref[0][rk]);
  EXPECT_LT(std::abs(s.energy().total()), 1e-6 * (s.energy().kinetic + s.energy().strain));  // released from rest: 0
}

TEST(Elastic, TooLargeATimeStepIsStoppedByTheGuardWithItsReason) {
  const structure::Plate plate;
  mps::ElasticConfig c;
  c.material = plate.material(mps::ElasticModel::saint_venant_kirchhoff);
  c.cfl = 1.2;
  mps::ElasticSolid s(structure::plate_body(plate, 0.004, c.radius), c);
  EXPECT_LT(s.stable_cfl(), c.cfl);
  std::vector<double> u(s.size(), 0.0), v(s.size(), 0.0);
  for (std::size_t i = 0; i < s.moving(); ++i)
    v[i] = structure::plate_initial_velocity(plate, c.material, s.reference_x()[i]);
  s.set_velocity(u, v);
  std::string what;
  int steps = 0;
  try {
    for (; steps < 10000; ++steps) s.step();
  } catch (const mps::SimulationError& e) {
    what = e.what();
  }
  EXPECT_NE(what.find("lower the CFL"), std::string::npos) << what;
  EXPECT_NE(what.find("stable up to CFL"), std::string::npos) << what;
  EXPECT_EQ(s.steps(), steps);  // the state is that of the last good step
  for (std::size_t i = 0; i < s.size(); ++i) ASSERT_TRUE(std::isfinite(s.x()[i]) && std::isfinite(s.u()[i]));
  // A host names its own option in the advice (fsi's --solid-cfl, not the fluid's --cfl).
  c.cfl_option = "--solid-cfl";
  mps::ElasticSolid named(structure::plate_body(plate, 0.004, c.radius), c);
  named.set_velocity(u, v);
  what.clear();
  try {
    for (int k = 0; k < 10000; ++k) named.step();
  } catch (const mps::SimulationError& e) {
    what = e.what();
  }
  EXPECT_NE(what.find("lower --solid-cfl"), std::string::npos) << what;
  // At the estimate's own CFL (less a margin) the same plate runs.
  c.cfl = 0.9 * s.stable_cfl();
  mps::ElasticSolid ok(structure::plate_body(plate, 0.004, c.radius), c);
  ok.set_velocity(u, v);
  for (int k = 0; k < 2000; ++k) ok.step();
  EXPECT_EQ(ok.steps(), 2000);
}

// The energies summed over particles do not depend on the thread count (a threaded reduction's did, so that the
// fsi and structure summaries differed in their last digits between 1 and 2 threads).
TEST(Elastic, EnergiesAreBitwiseTheSameOnOneAndTwoThreads) {
  const structure::Plate plate;
  mps::ElasticConfig c;
  c.material = plate.material(mps::ElasticModel::saint_venant_kirchhoff);
  auto energies = [&](int threads) {
    const int before = omp_get_max_threads();
    omp_set_num_threads(threads);
    mps::ElasticSolid s(structure::plate_body(plate, 0.002, c.radius), c);
    std::vector<double> u(s.size(), 0.0), v(s.size(), 0.0);
    for (std::size_t i = 0; i < s.moving(); ++i)
      v[i] = structure::plate_initial_velocity(plate, c.material, s.reference_x()[i]);
    s.set_velocity(u, v);
    std::vector<double> e;
    for (int k = 0; k < 100; ++k) {
      s.step();
      e.insert(e.end(), {s.energy().strain, s.energy().hourglass, s.energy().total()});
    }
    omp_set_num_threads(before);
    return e;
  };
  const std::vector<double> one = energies(1), two = energies(2);
  ASSERT_EQ(one.size(), two.size());
  for (std::size_t k = 0; k < one.size(); ++k) ASSERT_EQ(one[k], two[k]) << "value " << k;
}

TEST(Elastic, BadInputStopsWithItsReason) {
  mps::ElasticConfig c;
  c.material.poisson_ratio = 0.5;
  EXPECT_THROW(mps::ElasticSolid(block(5, 0.01), c), std::invalid_argument);
  c.material.poisson_ratio = 0.3;
  c.material.youngs_modulus = std::nan("");
  EXPECT_THROW(mps::ElasticSolid(block(5, 0.01), c), std::invalid_argument);
  c.material.youngs_modulus = 1e6;
  mps::ElasticBody line;  // one particle thick: no quadratic across it
  line.spacing = 0.01;
  for (int i = 0; i < 10; ++i) line.add(0.01 * i, 0.0, 1e-4, false);
  try {
    mps::ElasticSolid s(line, c);
    FAIL() << "a body one particle thick was accepted";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("too few or too one-sided"), std::string::npos) << e.what();
  }
  EXPECT_THROW(structure::plate_body(structure::Plate{}, 0.003, 3.0), std::invalid_argument);  // 0.003 does not divide 0.02
  EXPECT_THROW(mps::parse_elastic_model("neo-hookean"), std::invalid_argument);
}

TEST(Elastic, DisplacementProbeIsExactForALinearField) {
  mps::ElasticConfig c;
  mps::ElasticSolid s(block(10, 0.01), c);
  const std::array<double, 4> a{1.01, 0.02, -0.03, 0.99};
  deform(s, a, 0.004, 0.002);
  for (const auto& [px, py] : {std::pair{0.05, 0.05}, std::pair{0.1, 0.1}, std::pair{0.0, 0.07}}) {
    const auto d = s.displacement_at(px, py);  // at the block's corner and edge too
    EXPECT_NEAR(d[0], (a[0] - 1) * px + a[1] * py + 0.004, 1e-12);
    EXPECT_NEAR(d[1], a[2] * px + (a[3] - 1) * py + 0.002, 1e-12);
  }
}

TEST(Elastic, TransposeSwapsRowsAndColumns) {
  mps::CsrMatrix a;
  a.rows = 2;
  a.cols = 3;
  a.row_ptr = {0, 2, 3};
  a.col = {0, 2, 1};
  a.val = {1.0, 2.0, 3.0};
  std::vector<int> source;
  const mps::CsrMatrix t = mps::transpose(a, &source);
  t.validate();
  EXPECT_EQ(t.rows, 3);
  EXPECT_EQ(t.cols, 2);
  for (int i = 0; i < 2; ++i)
    for (int j = 0; j < 3; ++j) EXPECT_EQ(t.at(j, i), a.at(i, j));
  EXPECT_EQ(source, (std::vector<int>{0, 2, 1}));
}

TEST(Elastic, ClampReactionIsWhatTheBodyFeels) {
  // A plate released under gravity: its momentum changes by the weight's impulse plus the clamp's, step by step
  // (the internal forces sum to zero pair by pair).
  const structure::Plate plate;
  mps::ElasticConfig c;
  c.material = plate.material(mps::ElasticModel::saint_venant_kirchhoff);
  c.gravity_y = -9.81;
  mps::ElasticSolid s(structure::plate_body(plate, 0.004, c.radius), c);
  double impulse = 0.0, weight = 0.0;
  for (std::size_t i = 0; i < s.moving(); ++i) weight += c.material.density * 0.004 * 0.004 * c.gravity_y;
  for (int k = 0; k < 200; ++k) {
    const double before = s.clamp_reaction()[1];
    s.step();
    impulse += 0.5 * s.dt() * (before + s.clamp_reaction()[1]);  // the trapezoid rule is what Verlet integrates
  }
  double momentum = 0.0;
  for (std::size_t i = 0; i < s.moving(); ++i) momentum += c.material.density * 0.004 * 0.004 * s.v()[i];
  EXPECT_NEAR(momentum, weight * s.time() + impulse, 1e-9 * std::abs(weight * s.time()));
}

TEST(Elastic, ExternalForceActsLikeTheBodyForceItEqualsAndItsWorkIsCounted) {
  // A cantilever loaded by m g per particle as an external force against the same plate under gravity: the same
  // motion to round-off, and total energy - external work kept as gravity's potential keeps the total.
  const structure::Plate plate;
  mps::ElasticConfig c;
  c.material = plate.material(mps::ElasticModel::saint_venant_kirchhoff);
  mps::ElasticConfig gravity = c;
  gravity.gravity_y = -9.81;
  mps::ElasticSolid loaded(structure::plate_body(plate, 0.004, c.radius), c);
  mps::ElasticSolid falling(structure::plate_body(plate, 0.004, c.radius), gravity);
  const double m = c.material.density * 0.004 * 0.004;
  loaded.set_external_force(std::vector<double>(loaded.size(), 0.0), std::vector<double>(loaded.size(), -9.81 * m));
  double worst = 0.0;
  for (int k = 0; k < 3000; ++k) {
    loaded.step();
    falling.step();
    worst = std::max(worst, std::abs(loaded.energy().total() - loaded.external_work()));
  }
  for (std::size_t i = 0; i < loaded.size(); ++i) ASSERT_NEAR(loaded.y()[i], falling.y()[i], 1e-12) << i;
  EXPECT_NEAR(loaded.external_work(), -falling.energy().gravity, 1e-9 * loaded.external_work());
  EXPECT_LT(worst, 1e-4 * (loaded.energy().kinetic + loaded.energy().strain));
  EXPECT_GT(loaded.external_work(), 0.0);
}

// The box's lattice held at a face: every cell of the box once, moving, and `layers` rows of held points beyond the
// face alone, all on the lattice, rows along y outermost.
TEST(ElasticBodies, ClampedBoxIsTheBoxsLatticeAndItsClampRowsBeyondTheFace) {
  const mps::BodyLattice box{0.5, -1.0, 6, 4, 0.25};
  for (unsigned face : {unsigned{mps::x_low}, unsigned{mps::x_high}, unsigned{mps::y_low}, unsigned{mps::y_high}}) {
    const mps::ElasticBody body = mps::clamped_box_body(box, face, 3);
    const bool across_x = face == mps::x_low || face == mps::x_high;
    ASSERT_EQ(body.size(), 6u * 4u + 3u * (across_x ? 4u : 6u)) << face;
    std::size_t moving = 0;
    for (std::size_t k = 0; k < body.size(); ++k) {
      const double i = (body.x[k] - box.x0) / box.spacing - 0.5, j = (body.y[k] - box.y0) / box.spacing - 0.5;
      EXPECT_NEAR(i, std::round(i), 1e-12);
      EXPECT_NEAR(j, std::round(j), 1e-12);
      const bool inside = i > -0.5 && i < 5.5 && j > -0.5 && j < 3.5;
      EXPECT_EQ(body.clamped[k] != 0, !inside) << "point " << k << " of face " << face;
      const bool beyond = (face == mps::x_low && i < 0) || (face == mps::x_high && i > 5) ||
                          (face == mps::y_low && j < 0) || (face == mps::y_high && j > 3);
      EXPECT_EQ(inside, !beyond);
      moving += inside ? 1 : 0;
      EXPECT_DOUBLE_EQ(body.volume[k], 0.0625);
      if (k > 0) {
        EXPECT_TRUE(body.y[k] > body.y[k - 1] || (body.y[k] == body.y[k - 1] && body.x[k] > body.x[k - 1]));
      }
    }
    EXPECT_EQ(moving, 24u);
  }
  EXPECT_THROW(mps::clamped_box_body(box, mps::z_low, 3), std::invalid_argument);
  EXPECT_THROW(mps::clamped_box_body(box, mps::x_low, 0), std::invalid_argument);
  EXPECT_THROW(mps::clamped_box_body({0, 0, 0, 4, 0.25}, mps::x_low, 3), std::invalid_argument);
}

// Held in a cylinder (the CSM3 flag): every point outside it moves, every point inside it lies within the layers'
// depth of its surface along x and is held, and each row runs on the lattice to the box's far end.
TEST(ElasticBodies, CylinderHoldsTheRowsWhereTheyMeetItAndFreesThemOutside) {
  const double cx = 0.2, cy = 0.2, r = 0.05, h = 0.002;
  const mps::BodyLattice flag{0.25, 0.17, 175, 30, h};  // thick: its outer rows leave the cylinder before x0
  const mps::ElasticBody body = mps::cylinder_clamped_box_body(flag, cx, cy, r, 3);
  std::size_t held = 0, outside_the_box = 0;
  for (std::size_t k = 0; k < body.size(); ++k) {
    const double arc = cx + std::sqrt(r * r - (body.y[k] - cy) * (body.y[k] - cy));
    EXPECT_EQ(body.clamped[k] != 0, body.x[k] <= arc) << k;
    EXPECT_GT(body.x[k], arc - 3 * h) << k;
    if (k + 1 < body.size() && body.y[k + 1] == body.y[k]) {
      EXPECT_NEAR(body.x[k + 1] - body.x[k], h, 1e-12);
    }
    held += body.clamped[k] != 0 ? 1 : 0;
    outside_the_box += body.x[k] < flag.x0 && body.clamped[k] == 0 ? 1 : 0;
  }
  EXPECT_GE(held, 30u * 2u);  // two or three points of each row inside the 3 spacings
  EXPECT_LE(held, 30u * 3u);
  EXPECT_GT(outside_the_box, 0u);
  EXPECT_EQ(body.size() - held, 175u * 30u + outside_the_box);
  EXPECT_THROW(mps::cylinder_clamped_box_body({0.25, 0.3, 175, 10, h}, cx, cy, r, 3), std::invalid_argument);
  EXPECT_THROW(mps::cylinder_clamped_box_body(flag, cx, cy, 0.0, 3), std::invalid_argument);
}

// The first clamped-free mode: 0 with no slope at the clamp, 1 at the free end, where the moment and the shear (the
// second and third derivatives) vanish, by finite differences.
TEST(ElasticBodies, CantileverModeMeetsTheClampedAndTheFreeEndsConditions) {
  const double length = 0.2, d = 1e-3 * length;
  auto f = [&](double s) { return mps::cantilever_first_mode(s, length); };
  EXPECT_DOUBLE_EQ(f(length), 1.0);
  EXPECT_EQ(f(0.0), 0.0);
  EXPECT_EQ(f(-0.1), 0.0);
  EXPECT_LT(f(d) / d, 0.02);  // against a mean slope of 1 / length = 5
  const double second = (f(length) - 2 * f(length - d) + f(length - 2 * d)) / (d * d);
  const double third = (f(length) - 3 * f(length - d) + 3 * f(length - 2 * d) - f(length - 3 * d)) / (d * d * d);
  const double clamp_second = (f(2 * d) - 2 * f(d) + f(0.0)) / (d * d);
  EXPECT_LT(std::abs(second), 0.01 * clamp_second);
  EXPECT_LT(std::abs(third), 0.02 * clamp_second / length);
}

}  // namespace
