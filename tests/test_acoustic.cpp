// The acoustic module (MPS-WP, seed 001): exact solution, operators, and the validation cases on coarse
// particle sets (l0 = 0.5 m, boxes of 20-60 m) so that the whole file runs in seconds.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <functional>
#include <numbers>
#include <ostream>
#include <random>
#include <string>

#include "mps/acoustics/acoustic.hpp"
#include "mps/boundaries/geometry.hpp"
#include "mps/step/step.hpp"

namespace mps {
// Parameterised test names and failure messages show the gradient's name instead of its bytes.
inline void PrintTo(AcousticGradient gradient, std::ostream* os) { *os << to_string(gradient); }
}  // namespace mps

namespace {

constexpr double kC0 = 340.0, kRho0 = 1.2;

mps::AcousticConfig coarse(double half_size, mps::AcousticBoundary boundary,
                           mps::AcousticGradient gradient = mps::AcousticGradient::mps) {
  mps::AcousticConfig c;
  c.box = {-half_size, -half_size, half_size, half_size};
  c.l0 = 0.5;
  c.cfl = 0.136;
  c.boundary = boundary;
  c.gradient = gradient;
  return c;
}

void run_until(mps::AcousticSolver& s, double t) {
  while (s.time() < t - 0.5 * s.dt()) s.step();
}

// The interior particles' entries of a per-particle field (the virtual particles follow them).
std::vector<double> interior(const std::vector<double>& v, const mps::AcousticSolver& s) {
  return {v.begin(), v.begin() + static_cast<std::ptrdiff_t>(s.interior())};
}

mps::AcousticField exact_now(const mps::AcousticSolver& s, std::optional<mps::Rect> walls = std::nullopt) {
  const auto& p = s.particles();
  return mps::exact_acoustic_field(std::span(p.x.data(), s.interior()), std::span(p.y.data(), s.interior()), s.time(),
                                   s.pulses(), s.config().c0, s.config().rho0, s.config().u0x, s.config().u0y, walls);
}

// ---- exact solution -----------------------------------------------------------------------------------

TEST(AcousticExact, QuadratureReproducesTheInitialGaussian) {
  const double b = 3.0;
  for (double r : {0.0, 0.7, 2.0, 3.0, 5.5, 9.0, 15.0}) {
    const mps::PulseProfile f = mps::gaussian_pulse_exact(r, 0.0, b, kC0);
    EXPECT_NEAR(f.pressure, std::exp(-std::numbers::ln2 * r * r / (b * b)), 1e-9) << "r = " << r;
    EXPECT_NEAR(f.radial_velocity, 0.0, 1e-9) << "r = " << r;
  }
}

TEST(AcousticExact, TableInterpolatesTheQuadratureWithinItsTolerance) {
  const double b = 3.0, age = 0.05;
  const mps::PulseTable table(b, kC0, age);
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> radius(0.0, table.r_max());
  double worst = 0.0;
  for (int k = 0; k < 60; ++k) {
    const double r = radius(rng);
    const mps::PulseProfile direct = mps::gaussian_pulse_exact(r, age, b, kC0), table_value = table.at(r);
    worst = std::max({worst, std::abs(direct.pressure - table_value.pressure),
                      std::abs(direct.radial_velocity - table_value.radial_velocity)});
  }
  EXPECT_LT(worst, 1e-6);
  EXPECT_EQ(table.at(table.r_max() + 1.0).pressure, 0.0);
}

// A table limited to the distances needed holds bitwise the values of the full one there, and refuses to guess beyond.
TEST(AcousticExact, ATableLimitedToTheNeededDistancesMatchesTheFullOneAndRefusesBeyond) {
  const double b = 3.0, age = 0.2;  // wavefront at 68 m
  const mps::PulseTable full(b, kC0, age), limited(b, kC0, age, 1e-10, 20.0);
  for (double r : {0.0, 1.3, 7.7, 14.2, 19.99, 20.0}) {
    EXPECT_EQ(limited.at(r).pressure, full.at(r).pressure) << "r = " << r;
    EXPECT_EQ(limited.at(r).radial_velocity, full.at(r).radial_velocity) << "r = " << r;
  }
  EXPECT_THROW((void)limited.at(30.0), std::out_of_range);
  EXPECT_EQ(limited.at(full.r_max() + 1.0).pressure, 0.0);
}

// The pressure and velocity integrals are independent formulas; together they must conserve the energy
// pi b^2 eps^2 / (2 ln2) / (2 rho0 c0^2) of the initial pulse.
TEST(AcousticExact, PressureAndVelocityTogetherConserveEnergy) {
  const double b = 3.0, h = 0.25, half = 40.0, eps = 2.0;
  std::vector<double> x, y;
  for (double px = -half + h / 2; px < half; px += h)
    for (double py = -half + h / 2; py < half; py += h) {
      x.push_back(px);
      y.push_back(py);
    }
  const std::vector<mps::GaussianPulse> pulse{{0.0, 0.0, eps, b, 0.0}};
  const double e0 = std::numbers::pi * b * b * eps * eps / (2 * std::numbers::ln2) / (2 * kRho0 * kC0 * kC0);
  for (double t : {0.0, 0.02, 0.05}) {
    const auto f = mps::exact_acoustic_field(x, y, t, pulse, kC0, kRho0, 0.0, 0.0);
    EXPECT_NEAR(mps::acoustic_energy(f.p, f.u, f.v, h * h, kC0, kRho0) / e0, 1.0, 1e-4) << "t = " << t;
  }
}

TEST(AcousticExact, RejectsBadArguments) {
  EXPECT_THROW(mps::gaussian_pulse_exact(1.0, 0.1, 0.0, kC0), std::invalid_argument);
  EXPECT_THROW(mps::gaussian_pulse_exact(1.0, -0.1, 3.0, kC0), std::invalid_argument);
  const std::vector<double> x{0.0}, y{0.0};
  const std::vector<mps::GaussianPulse> pulse{{}};
  EXPECT_THROW(mps::exact_acoustic_field(x, y, 0.1, pulse, kC0, kRho0, 10.0, 0.0, mps::Rect{-5, -5, 5, 5}),
               std::invalid_argument);
}

// ---- operators -----------------------------------------------------------------------------------------

TEST(AcousticOperators, LeastSquaresGradientIsExactForCubics) {
  // Rows for an inner block whose neighbourhoods are complete: three layers of particles around it.
  mps::Particles p;
  const double l0 = 0.1;
  const mps::Rect inner{0.3, 0.3, 1.7, 1.7};
  mps::fill_rectangle(p, inner, l0, mps::Kind::fluid);
  const std::size_t rows = p.size();
  mps::add_rectangle_walls(p, inner, l0, mps::left | mps::right | mps::bottom | mps::top, 0, 3);
  const mps::Domain d{-1, 3, -1, 3};
  const mps::Kernel k = mps::make_kernel(2.1, l0, mps::Weight::classic);
  const auto list = mps::find_neighbors(p, d, k.re);
  const auto g = mps::least_squares_gradient_matrices({p, d, list, k}, rows);
  ASSERT_EQ(g.x.rows, static_cast<int>(rows));
  std::vector<double> phi(p.size()), gx(rows), gy(rows);
  auto f = [](double x, double y) { return x * x * x - 2 * x * x * y + 0.5 * y * y * y + x * y - 3 * x + 1; };
  for (std::size_t i = 0; i < p.size(); ++i) phi[i] = f(p.x[i], p.y[i]);
  g.x.multiply(phi, gx);
  g.y.multiply(phi, gy);
  for (std::size_t i = 0; i < rows; ++i) {
    const double x = p.x[i], y = p.y[i];
    EXPECT_NEAR(gx[i], 3 * x * x - 4 * x * y + y - 3, 1e-9);
    EXPECT_NEAR(gy[i], -2 * x * x + 1.5 * y * y + x, 1e-9);
  }
}

TEST(AcousticOperators, LeastSquaresGradientRefusesAOneSidedNeighbourhood) {
  mps::Particles p;
  mps::fill_rectangle(p, {0, 0, 1.0, 0.1}, 0.1, mps::Kind::fluid);  // one row: no y-direction information
  const mps::Domain d{-1, 2, -1, 1};
  const mps::Kernel k = mps::make_kernel(2.1, 0.1);
  const auto list = mps::find_neighbors(p, d, k.re);
  EXPECT_THROW(mps::least_squares_gradient_matrices({p, d, list, k}, p.size()), std::invalid_argument);
}

// ---- validation -----------------------------------------------------------------------------------------

class AcousticFreeField : public ::testing::TestWithParam<mps::AcousticGradient> {};

// b = 6 m on l0 = 0.5 m, 40 ms (13.6 m of travel): the front is still 15 m (2.5 b) inside the 60 m box, so the
// boundary plays no part and the error is the operators' and RK4's alone.
TEST_P(AcousticFreeField, PulseMatchesTheExactSolutionBeforeReachingTheBoundary) {
  mps::AcousticSolver s(coarse(30.0, mps::AcousticBoundary::mur, GetParam()));
  s.add_pulse({0.0, 0.0, 1.0, 6.0, 0.0});
  run_until(s, 0.04);
  const auto exact = exact_now(s);
  const double error = mps::relative_rms_error(interior(s.pressure(), s), exact.p);
  const double limit = GetParam() == mps::AcousticGradient::mps ? 0.02 : 0.002;
  std::printf("free field (%s gradient): relative RMS error %.3f %% at t = %.3f s\n",
              std::string(mps::to_string(GetParam())).c_str(), 100 * error, s.time());
  EXPECT_LT(error, limit) << "relative RMS error of dp at t = " << s.time() << " s";
  EXPECT_LT(mps::relative_rms_error(interior(s.velocity_x(), s), exact.u), 2 * limit) << "x velocity";
  EXPECT_NEAR(s.energy() / s.injected_energy(), 1.0, 1e-4);
}

INSTANTIATE_TEST_SUITE_P(Gradients, AcousticFreeField,
                         ::testing::Values(mps::AcousticGradient::mps, mps::AcousticGradient::least_squares),
                         [](const auto& param_info) { return std::string(mps::to_string(param_info.param)); });

// An off-centre pulse (b = 8 m) in a 64 m box, 0.15 s (51 m of travel): it has reflected off the two nearest
// walls (28 and 30 m away) and the corner between them. The walls are 3.5 b away at the start, so the initial
// Gaussian and its image sum agree (exp(-ln2 3.5^2) ~ 2e-4).
class AcousticHardWalls : public ::testing::TestWithParam<mps::AcousticGradient> {};

TEST_P(AcousticHardWalls, ReflectionMatchesTheImageSolution) {
  mps::AcousticSolver s(coarse(32.0, mps::AcousticBoundary::hard, GetParam()));
  s.add_pulse({4.0, 2.0, 1.0, 8.0, 0.0});
  run_until(s, 0.15);
  const auto images = exact_now(s, s.config().box);
  const auto free_field = exact_now(s);
  const auto p = interior(s.pressure(), s);
  const double error = mps::relative_rms_error(p, images.p);
  std::printf("hard walls (%s gradient): relative RMS error against the image solution %.3f %% at t = %.3f s\n",
              std::string(mps::to_string(GetParam())).c_str(), 100 * error, s.time());
  EXPECT_LT(error, GetParam() == mps::AcousticGradient::mps ? 0.03 : 0.003);
  // The walls matter here: the free-field solution is far off.
  EXPECT_GT(mps::relative_rms_error(free_field.p, images.p), 0.3);
  // Mirrored particles conserve the semi-discrete energy; RK4 loses only O((c k dt)^6) per step.
  EXPECT_NEAR(s.energy() / s.injected_energy(), 1.0, 1e-4);
}

INSTANTIATE_TEST_SUITE_P(Gradients, AcousticHardWalls,
                         ::testing::Values(mps::AcousticGradient::mps, mps::AcousticGradient::least_squares),
                         [](const auto& param_info) { return std::string(mps::to_string(param_info.param)); });

// Energy measure: E = l0^2 sum (dp^2/(2 rho0 c0^2) + rho0 |du|^2 / 2) over the interior, as a fraction of the
// injected pulse energy, 0.1 s after the start: the front (34 m) has passed the farthest corner (28.3 m).
TEST(AcousticMur, LeavesLittleOfThePulseEnergyInTheBox) {
  const double t = 0.1;
  mps::AcousticSolver mur(coarse(20.0, mps::AcousticBoundary::mur));
  mur.add_pulse({0.0, 0.0, 1.0, 3.0, 0.0});
  run_until(mur, t);
  const double left = mur.energy() / mur.injected_energy();
  EXPECT_LT(left, 0.05);
  // What a perfect absorber leaves: the exact free field (its 2-D wake) inside the box.
  const auto exact = exact_now(mur);
  const double ideal = mps::acoustic_energy(exact.p, exact.u, exact.v, 0.25, kC0, kRho0) / mur.injected_energy();
  std::printf("Mur: %.3f %% of the pulse energy left at t = %.3f s (exact free field in the box: %.3f %%)\n",
              100 * left, mur.time(), 100 * ideal);
  EXPECT_LT(ideal, left + 1e-3);
  // The measure tells a reflecting box apart: hard walls keep the energy.
  mps::AcousticSolver hard(coarse(20.0, mps::AcousticBoundary::hard));
  hard.add_pulse({0.0, 0.0, 1.0, 3.0, 0.0});
  run_until(hard, t);
  EXPECT_GT(hard.energy() / hard.injected_energy(), 0.99);
}

// u0 = 100 m/s for 40 ms moves the pulse 4 m (8 spacings); the centroid of dp^2 must follow within one spacing.
TEST(AcousticMeanFlow, ShiftsThePulseCentreByU0t) {
  auto c = coarse(32.0, mps::AcousticBoundary::mur);
  c.u0x = 100.0;
  mps::AcousticSolver s(c);
  const double x0 = -2.0, y0 = 1.0;
  s.add_pulse({x0, y0, 1.0, 6.0, 0.0});
  run_until(s, 0.04);
  const auto p = s.pressure();
  double w = 0, wx = 0, wy = 0;
  for (std::size_t i = 0; i < s.interior(); ++i) {
    const double q = p[i] * p[i];
    w += q;
    wx += q * s.particles().x[i];
    wy += q * s.particles().y[i];
  }
  const double expected = x0 + c.u0x * s.time();
  std::printf("mean flow: centroid of dp^2 at x = %.4f m, x0 + u0 t = %.4f m (shift error %.4f m = %.3f l0)\n", wx / w,
              expected, wx / w - expected, (wx / w - expected) / c.l0);
  EXPECT_NEAR(wx / w, expected, c.l0);
  EXPECT_NEAR(wy / w, y0, c.l0);
  EXPECT_LT(mps::relative_rms_error(interior(p, s), exact_now(s).p), 0.02);
}

// ---- stability -----------------------------------------------------------------------------------------

TEST(AcousticStability, CflBeyondTheRk4LimitIsStoppedByTheGuard) {
  auto c = coarse(10.0, mps::AcousticBoundary::hard);
  const double limit = mps::AcousticSolver(c).stable_cfl_estimate();
  ASSERT_GT(limit, 2.0);
  ASSERT_LT(limit, 4.0);
  c.cfl = 1.1 * limit;
  mps::AcousticSolver s(c);
  s.add_pulse({1.0, 0.0, 1.0, 2.0, 0.0});
  std::string message;
  int steps_before = -1;
  try {
    for (int k = 0; k < 2000; ++k) {
      steps_before = s.steps();
      s.step();
    }
  } catch (const mps::SimulationError& e) {
    message = e.what();
  }
  ASSERT_FALSE(message.empty()) << "CFL " << c.cfl << " ran 2000 steps without tripping the guard";
  for (const char* word : {"step", "t = ", "CFL", "energy"}) EXPECT_NE(message.find(word), std::string::npos) << message;
  // The state is the last good one: the step count did not advance and the energy is within the bound.
  EXPECT_EQ(s.steps(), steps_before);
  EXPECT_TRUE(std::isfinite(s.energy()));
  EXPECT_LE(s.energy(), s.energy_bound());
}

TEST(AcousticStability, JustBelowTheLimitStaysStableForLong) {
  auto c = coarse(10.0, mps::AcousticBoundary::hard);
  c.cfl = 0.97 * mps::AcousticSolver(c).stable_cfl_estimate();
  mps::AcousticSolver s(c);
  s.add_pulse({1.0, 0.0, 1.0, 2.0, 0.0});
  const double e0 = s.energy();
  // ~ 100 crossings of the box. RK4 is stable on the imaginary axis up to |lambda dt| = 2 sqrt(2) and never
  // amplifies there (it damps the shortest waves instead): the energy may only fall.
  double previous = e0;
  for (int k = 0; k < 4000; ++k) {
    s.step();
    ASSERT_LE(s.energy(), previous * (1 + 1e-12)) << "energy grew at step " << s.steps();
    previous = s.energy();
  }
  EXPECT_GT(s.energy(), 0.0);
}

// Mur's formula applied at every RK4 stage keeps the interior's stability limit (applied once per step with
// the virtual particles frozen through the stages, it goes unstable from CFL ~0.85: docs/acoustics.md).
TEST(AcousticStability, MurAtEveryStageIsStableNearTheInteriorLimit) {
  auto c = coarse(10.0, mps::AcousticBoundary::mur);
  c.cfl = 0.95 * mps::AcousticSolver(c).stable_cfl_estimate();
  mps::AcousticSolver s(c);
  s.add_pulse({1.0, 0.0, 1.0, 2.0, 0.0});
  for (int k = 0; k < 3000; ++k) {
    s.step();
    ASSERT_LE(s.energy(), 1.01 * s.injected_energy()) << "energy grew at step " << s.steps();
  }
  // Most of it has left; what stays is what a first-order absorber reflects of this poorly resolved pulse
  // (b = 4 l0) at this CFL, and waves whose MPS group velocity is near zero (k l0 ~ pi).
  EXPECT_LT(s.energy(), 0.5 * s.injected_energy());
}

// ---- input checking ------------------------------------------------------------------------------------

TEST(AcousticConfig, RejectsBadParametersWithAMessageNamingThem) {
  const std::vector<std::pair<std::function<void(mps::AcousticConfig&)>, std::string>> cases = {
      {[](auto& c) { c.l0 = 0.0; }, "l0"},
      {[](auto& c) { c.l0 = -0.25; }, "l0"},
      {[](auto& c) { c.l0 = 0.3; }, "multiple of l0"},
      {[](auto& c) { c.cfl = 0.0; }, "CFL"},
      {[](auto& c) { c.cfl = -1.0; }, "CFL"},
      {[](auto& c) { c.c0 = 0.0; }, "c0"},
      {[](auto& c) { c.rho0 = -1.0; }, "rho0"},
      {[](auto& c) { c.u0x = 400.0; }, "subsonic"},
      {[](auto& c) { c.radius = 1.0; }, "radius"},
      {[](auto& c) { c.guard_energy_factor = 1.0; }, "guard_energy_factor"},
      {[](auto& c) { c.box = {0, 0, 1, 1}; }, "spacings wide"},
  };
  for (const auto& [spoil, word] : cases) {
    auto c = coarse(10.0, mps::AcousticBoundary::mur);
    spoil(c);
    try {
      mps::AcousticSolver s(c);
      ADD_FAILURE() << "accepted a config with bad " << word;
    } catch (const std::invalid_argument& e) {
      EXPECT_NE(std::string(e.what()).find(word), std::string::npos) << e.what();
    }
  }
  mps::AcousticSolver s(coarse(10.0, mps::AcousticBoundary::mur));
  try {
    s.add_pulse({0.0, 0.0, 1.0, 0.0, 0.0});
    ADD_FAILURE() << "accepted b = 0";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("half-width b"), std::string::npos) << e.what();
  }
  EXPECT_THROW(mps::parse_acoustic_boundary("absorbing"), std::invalid_argument);
  EXPECT_THROW(mps::parse_acoustic_gradient("sph"), std::invalid_argument);
  EXPECT_EQ(mps::parse_acoustic_boundary("mur"), mps::AcousticBoundary::mur);
  EXPECT_EQ(mps::parse_acoustic_boundary("mur-step"), mps::AcousticBoundary::mur_step);
  EXPECT_EQ(mps::parse_acoustic_gradient("ls3"), mps::AcousticGradient::least_squares);
}

}  // namespace
