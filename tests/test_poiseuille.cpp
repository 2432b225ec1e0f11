// Periodic channel flows against their exact start-up series (design §6, issue "Poiseuille"): short, coarse
// runs (20 particles across) of the scene the poiseuille app runs.
#include <gtest/gtest.h>

#include <cmath>

#include "channel.hpp"

namespace {

poiseuille::Params coarse(poiseuille::Mode mode) {
  poiseuille::Params p;
  p.mode = mode;
  p.across = 20;
  p.re = 40;
  return p;
}

void run_to(mps::Simulation& sim, double t) {
  while (sim.time() < t * (1 - 1e-9)) sim.step();
}

}  // namespace

TEST(ChannelExact, SeriesMeetTheirBoundaryValuesAndSteadyStates) {
  // The series themselves, checked against what they must satisfy, so the flow tests compare with the truth.
  poiseuille::Params p = coarse(poiseuille::Mode::body_force);
  const double U = p.U(), D = p.D, late = 10 * p.diffusion_time();
  EXPECT_NEAR(poiseuille::exact_velocity(p, 0.5 * D, late), 1.5 * U, 1e-12 * U);
  EXPECT_NEAR(poiseuille::exact_velocity(p, 0.3 * D, 1e-6 * p.diffusion_time()), 0.0, 1e-3 * U);
  EXPECT_NEAR(poiseuille::exact_velocity(p, 0.0, 0.1 * p.diffusion_time()), 0.0, 1e-15);
  p.mode = poiseuille::Mode::couette;
  EXPECT_NEAR(poiseuille::exact_velocity(p, 0.25 * D, late), 0.25 * U, 1e-12 * U);
  EXPECT_NEAR(poiseuille::exact_velocity(p, D, 0.01 * p.diffusion_time()), U, 1e-9 * U);
  EXPECT_NEAR(poiseuille::exact_velocity(p, 0.7 * D, 1e-6 * p.diffusion_time()), 0.0, 1e-2 * U);
}

TEST(BodyForceChannel, ProfileWithinTwoPercentOfTheSeriesAtThreeTimes) {
  const poiseuille::Params p = coarse(poiseuille::Mode::body_force);
  mps::Simulation sim = poiseuille::make_simulation(p);
  for (double f : {0.05, 0.1, 0.2}) {
    run_to(sim, f * p.diffusion_time());
    const poiseuille::Profile pr = poiseuille::measure_profile(p, sim);
    EXPECT_LT(pr.l2_error, 0.02) << "t = " << f << " D^2/nu";
    EXPECT_LT(pr.flow_rate_error, 0.02) << "t = " << f << " D^2/nu";
  }
}

TEST(CouetteChannel, StartUpProfileWithinTwoPercentOfTheSeries) {
  const poiseuille::Params p = coarse(poiseuille::Mode::couette);
  mps::Simulation sim = poiseuille::make_simulation(p);
  for (double f : {0.05, 0.2}) {
    run_to(sim, f * p.diffusion_time());
    EXPECT_LT(poiseuille::measure_profile(p, sim).l2_error, 0.02) << "t = " << f << " D^2/nu";
  }
}

TEST(BodyForceChannel, MirrorWallsAreWhatMakesTheProfileRight) {
  // The same channel with plain no-slip walls (wall and dummy particles at rest) misses the series by far
  // more than the mirror walls do: the check that the mirror treatment is in effect and needed.
  const poiseuille::Params p = coarse(poiseuille::Mode::body_force);
  const double l0 = p.l0();
  mps::SimulationConfig c = poiseuille::make_simulation(p).config();
  mps::Simulation plain(poiseuille::make_particles(p), {0.0, p.length_l0 * l0, -6 * l0, p.D + 6 * l0, true, false}, c);
  mps::Simulation mirror = poiseuille::make_simulation(p);
  run_to(plain, 0.1 * p.diffusion_time());
  run_to(mirror, 0.1 * p.diffusion_time());
  const double e_plain = poiseuille::measure_profile(p, plain).l2_error;
  const double e_mirror = poiseuille::measure_profile(p, mirror).l2_error;
  EXPECT_GT(e_plain, 0.05);
  EXPECT_LT(e_mirror, 0.2 * e_plain);
}

TEST(BodyForceChannel, SteadyFlowHeldForThreeDiffusionTimesKeepsItsProfile) {
  // Long run: no drift, no transverse instability (the failure reported for SPH in seed 004's references).
  poiseuille::Params p = coarse(poiseuille::Mode::body_force);
  p.across = 16;
  p.re = 4;
  mps::Simulation sim = poiseuille::make_simulation(p);
  run_to(sim, 1.0 * p.diffusion_time());
  const poiseuille::Profile developed = poiseuille::measure_profile(p, sim);
  run_to(sim, 3.0 * p.diffusion_time());
  const poiseuille::Profile late = poiseuille::measure_profile(p, sim);
  EXPECT_LT(developed.l2_error, 0.02);
  EXPECT_LT(late.l2_error, 0.02);
  EXPECT_LT(std::abs(late.l2_error - developed.l2_error), 0.005);
  EXPECT_LT(late.max_abs_v, 0.05 * p.U());
  const mps::Particles& s = sim.particles();
  for (std::size_t i = 0; i < s.size(); ++i)
    if (s.kind[i] == mps::Kind::fluid) {
      ASSERT_GT(s.y[i], 0.0) << "a fluid particle crossed the bottom wall line";
      ASSERT_LT(s.y[i], p.D) << "a fluid particle crossed the top wall line";
    }
}

TEST(BodyForceChannel, TimeStepFarPastTheViscousLimitIsStoppedByTheGuard) {
  poiseuille::Params p = coarse(poiseuille::Mode::body_force);
  p.dt_factor = 5;  // viscous number 1.0: explicit viscosity is unstable past ~0.25 to 0.5
  mps::Simulation sim = poiseuille::make_simulation(p);
  bool stopped = false;
  try {
    run_to(sim, 0.5 * p.diffusion_time());
  } catch (const mps::SimulationError& e) {
    stopped = true;
    EXPECT_NE(std::string(e.what()).find("reduce viscous_number"), std::string::npos) << e.what();
  }
  EXPECT_TRUE(stopped);
  for (double u : sim.particles().u) ASSERT_TRUE(std::isfinite(u)) << "the last good state must be finite";
}

TEST(ChannelParams, BadInputIsRejectedWithTheParameterNamed) {
  poiseuille::Params p;
  p.across = 3;
  EXPECT_THROW(p.validate(), std::invalid_argument);
  p = {};
  p.length_l0 = 10;
  EXPECT_THROW(p.validate(), std::invalid_argument);
  p = {};
  p.re = -1;
  EXPECT_THROW(p.validate(), std::invalid_argument);
  EXPECT_THROW(poiseuille::parse_mode("inlett"), std::invalid_argument);
}
