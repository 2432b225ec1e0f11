// Rotating boundaries (design §6, issue 5): mps::RigidMotion on hand-made particles, then short, coarse runs of
// the scenes the rotating app runs: Taylor-Couette against its exact profile, seed 000's screw channel in the
// moving- and fixed-boundary models, and the guard on an unstable time step.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <numbers>
#include <string>

#include "mps/boundary.hpp"
#include "rotor.hpp"

namespace {

using Line = rotating::LineSampler::Line;

void run_to(mps::Simulation& sim, double t) {
  while (sim.time() < t * (1 - 1e-9)) sim.step();
}

mps::Particles ring_of_walls() {
  mps::Particles p;
  p.add(0.5, 0.0, mps::Kind::fluid, 0);
  for (int k = 0; k < 8; ++k) {
    const double a = 2 * std::numbers::pi * k / 8;
    p.add(2 + std::cos(a), 1 + std::sin(a), k % 2 ? mps::Kind::dummy : mps::Kind::wall, 1);
  }
  return p;
}

}  // namespace

TEST(RigidMotion, RotationIsExactAfterManyStepsAndFollowsParticlesThroughReordering) {
  mps::Particles p = ring_of_walls();
  const mps::Particles start = p;
  const double w = 0.7;
  mps::RigidMotion motion(p, 1, 2.0, 1.0, mps::steady_path(w));
  EXPECT_EQ(motion.size(), 8u);
  // Many small steps, then a reordering: the positions are those of one rotation by w t.
  for (int n = 1; n <= 20000; ++n) motion(p, n * 0.05);
  p.permute(std::vector<int>{8, 3, 0, 5, 1, 7, 2, 6, 4});
  motion(p, 1000.0);
  const double a = w * 1000.0;
  for (std::size_t i = 0; i < p.size(); ++i) {
    const auto k = static_cast<std::size_t>(p.id[i]);
    if (start.group[k] != 1) {
      EXPECT_EQ(p.x[i], start.x[k]);  // the fluid particle is not the motion's business
      EXPECT_EQ(p.u[i], 0.0);
      continue;
    }
    const double rx = start.x[k] - 2.0, ry = start.y[k] - 1.0;
    EXPECT_NEAR(p.x[i], 2.0 + rx * std::cos(a) - ry * std::sin(a), 1e-12);
    EXPECT_NEAR(p.y[i], 1.0 + rx * std::sin(a) + ry * std::cos(a), 1e-12);
    EXPECT_NEAR(std::hypot(p.x[i] - 2.0, p.y[i] - 1.0), 1.0, 1e-14);
    EXPECT_NEAR(p.u[i], -w * (p.y[i] - 1.0), 1e-14);  // omega z x (r - c)
    EXPECT_NEAR(p.v[i], w * (p.x[i] - 2.0), 1e-14);
  }
}

TEST(RigidMotion, SeparateVelocityPathAndTranslation) {
  mps::Particles p = ring_of_walls();
  const mps::Particles start = p;
  // Seed 000's barrel over the opening: moves with the channel, at rest.
  mps::RigidMotion(p, 1, 0.0, 0.0, mps::steady_path(-1.0)).velocity_from(mps::steady_path(0.0))(p, 0.3);
  for (std::size_t i = 1; i < p.size(); ++i) {
    EXPECT_NEAR(std::hypot(p.x[i], p.y[i]), std::hypot(start.x[i], start.y[i]), 1e-14);
    EXPECT_NE(p.x[i], start.x[i]);
    EXPECT_EQ(p.u[i], 0.0);
    EXPECT_EQ(p.v[i], 0.0);
  }
  // Its fixed-boundary model: in place, carrying a rotation about the origin.
  p = start;
  mps::RigidMotion(p, 1, 0.0, 0.0, mps::steady_path(0.0)).velocity_from(mps::steady_path(2.0))(p, 0.3);
  for (std::size_t i = 1; i < p.size(); ++i) {
    EXPECT_EQ(p.x[i], start.x[i]);
    EXPECT_NEAR(p.u[i], -2.0 * p.y[i], 1e-14);
    EXPECT_NEAR(p.v[i], 2.0 * p.x[i], 1e-14);
  }
  // A translation: shifted by v t, moving at v.
  p = start;
  mps::RigidMotion(p, 1, 0.0, 0.0, mps::steady_path(0.0, 0.5, -0.25))(p, 2.0);
  for (std::size_t i = 1; i < p.size(); ++i) {
    EXPECT_NEAR(p.x[i], start.x[i] + 1.0, 1e-14);
    EXPECT_NEAR(p.y[i], start.y[i] - 0.5, 1e-14);
    EXPECT_EQ(p.u[i], 0.5);
    EXPECT_EQ(p.v[i], -0.25);
  }
  EXPECT_THROW(mps::RigidMotion(p, 7, 0.0, 0.0, mps::steady_path(1.0)), std::invalid_argument);  // empty group
}

TEST(RotatingCouette, SteadyProfileWithinTwoPercentOfExactAtTwentyAcross) {
  rotating::Params p;
  p.scene = rotating::Scene::couette;
  p.across = 20;
  // The exact profile, from its definition: the wall speeds at the two radii.
  EXPECT_NEAR(rotating::couette_exact(p, p.R1), p.omega * p.R1, 1e-14);
  EXPECT_NEAR(rotating::couette_exact(p, p.R2), 0.0, 1e-14);
  mps::Simulation sim = rotating::make_simulation(p);
  const std::size_t fluid = sim.particles().count(mps::Kind::fluid);
  // Half a diffusion time (R2 - R1)^2/nu: the slowest start-up mode has decayed below 1 % of omega R1.
  rotating::LineSampler sampler(p, Line::couette);
  while (sim.time() < 0.5 * p.diffusion_time() * (1 - 1e-9)) {
    sim.step();
    ASSERT_EQ(rotating::escaped_particles(p, sim), 0) << "t = " << sim.time();
    if (sim.time() > 0.45 * p.diffusion_time()) sampler.add(sim);
  }
  EXPECT_EQ(sim.particles().count(mps::Kind::fluid), fluid);
  const rotating::Curve c = sampler.result();
  ASSERT_EQ(c.value.size(), 20u);
  for (double v : c.value) ASSERT_FALSE(std::isnan(v));
  EXPECT_LT(rotating::couette_max_error(c), 0.02 * p.omega * p.R1);
}

TEST(RotatingCouette, InitialReferenceDensityTakesTheRingPackingAsTheWallsRestState) {
  // The concentric rings are denser than the square lattice by 2-4 %, by an amount that varies with the radius.
  // Against the lattice n0 the walls read that as compression they can never relieve; against their own initial
  // number density their PPE rows carry no source at rest (all alike: only the gauge's mean removal).
  rotating::Params p;
  p.scene = rotating::Scene::couette;
  p.across = 12;
  p.omega = 1e-12;  // at rest to round-off
  p.gamma = 0.5;
  auto wall_source_spread = [&](bool initial) {
    p.initial_reference = initial;
    mps::Simulation sim = rotating::make_simulation(p);
    sim.step();
    const mps::PpeSystem& ppe = sim.last_ppe();
    double lo = 1e300, hi = -1e300;
    for (std::size_t r = 0; r < ppe.rhs.size(); ++r)
      if (sim.particles().kind[static_cast<std::size_t>(ppe.particle[r])] == mps::Kind::wall) {
        lo = std::min(lo, ppe.rhs[r]);
        hi = std::max(hi, ppe.rhs[r]);
      }
    return hi - lo;
  };
  const double lattice = wall_source_spread(false);
  EXPECT_GT(lattice, 100.0);  // measured 887
  EXPECT_LT(wall_source_spread(true), 1e-9 * lattice);
}

namespace {

struct ChannelRun {
  rotating::Curve line1, arc2, barrel;
};

// Seed 000's channel, coarse (16 across), to steady state (half a diffusion time), curves averaged over the
// second half; every step checked for fluid outside the channel.
ChannelRun run_channel(rotating::Model model) {
  rotating::Params p;
  p.model = model;
  p.across = 16;
  mps::Simulation sim = rotating::make_simulation(p);
  const std::size_t fluid = sim.particles().count(mps::Kind::fluid);
  rotating::LineSampler l1(p, Line::line1), a2(p, Line::arc2), barrel(p, Line::barrel);
  while (sim.time() < 0.5 * (1 - 1e-9)) {
    sim.step();
    EXPECT_EQ(rotating::escaped_particles(p, sim), 0) << "t = " << sim.time();
    if (sim.time() > 0.25) {
      l1.add(sim);
      a2.add(sim);
      barrel.add(sim);
    }
  }
  EXPECT_EQ(sim.particles().count(mps::Kind::fluid), fluid);
  return {l1.result(), a2.result(), barrel.result()};
}

}  // namespace

TEST(RotatingChannel, MovingAndFixedModelsAgreeAtSteadyState) {
  const ChannelRun moving = run_channel(rotating::Model::moving);
  const ChannelRun fixed = run_channel(rotating::Model::fixed);
  // The curves exist: line 1 runs from the bottom at rest (relative) to the barrel's speed.
  for (const ChannelRun* r : {&moving, &fixed}) {
    ASSERT_EQ(r->line1.value.size(), 16u);
    EXPECT_LT(std::abs(r->line1.value.front()), 0.3);
    EXPECT_GT(r->line1.value.back(), 0.7);
  }
  EXPECT_LT(rotating::max_difference(moving.line1, fixed.line1), 0.03);
  EXPECT_LT(rotating::max_difference(moving.arc2, fixed.arc2), 0.03);
}

TEST(RotatingChannel, SteadyFlowIsSymmetricAtReOne) {
  // Stokes flow in the symmetric channel: u_r on arc 2 is odd in phi (the reflection reverses the barrel,
  // linearity reverses it back). Over |phi| <= 0.4: the bins next to the flights scatter more (over the whole
  // span the defect is 0.037 with the defaults, 0.0185 over |phi| <= 0.4).
  const ChannelRun fixed = run_channel(rotating::Model::fixed);
  EXPECT_GT(rotating::range(fixed.arc2, 0.4), 0.3);
  EXPECT_LT(rotating::odd_defect(fixed.arc2, 0.4), 0.03);
}

// The barrel pressure is odd by the same argument (a finite-difference solution of this steady flow at Re = 2,
// bench/rotating_reference.py, is odd within 0.028 of its range). With the density source at gamma = 0.05 and no
// shifting it was not: 0.112 of the range here, and 0.13 / 0.19-0.22 at 24 / 49 across. The defaults (gamma = 0.01,
// shifting A = 1) gave 0.057 here, 0.031 and 0.029 at 24 and 49 across (docs/rotating.md).
TEST(RotatingChannel, BarrelPressureIsOddAtReOne) {
  const ChannelRun fixed = run_channel(rotating::Model::fixed);
  const double prange = rotating::range(fixed.barrel, 0.4);
  EXPECT_GT(prange, 0.0);
  EXPECT_LT(rotating::odd_defect(fixed.barrel, 0.4), 0.1 * prange);
}

TEST(RotatingChannel, ViscousStepPastItsLimitIsStoppedByTheGuard) {
  rotating::Params p;
  p.across = 12;
  p.dt_factor = 8;  // viscous number 1.6, eight times the default 0.2 (at 1.0 the scene ran stably to t = 2 s)
  mps::Simulation sim = rotating::make_simulation(p);
  try {
    run_to(sim, 0.5);
    FAIL() << "an explicit viscous step 8x past its limit ran to t = 0.5 s";
  } catch (const mps::SimulationError& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("viscous"), std::string::npos) << what;
    EXPECT_NE(what.find("step"), std::string::npos) << what;
  }
}

// r span / l0 is a half-integer on the barrel's wall ring: rounded from two differently computed radii, the layout
// gave 48 particles and the sampler 49 bins at 24 across, the bin at phi = 0 empty and the others off their particles.
TEST(RotatingScene, BarrelSamplerHasOneBinPerBarrelParticle) {
  for (double across : {16.0, 24.0, 49.0}) {
    rotating::Params p;
    p.across = across;
    const mps::Simulation sim = rotating::make_simulation(p);
    rotating::LineSampler barrel(p, Line::barrel);
    barrel.add(sim);
    const rotating::Curve c = barrel.result();
    int over_opening = 0;
    for (std::size_t k = 0; k < c.axis.size(); ++k)
      if (std::abs(c.axis[k]) < 0.5 * p.span) {
        EXPECT_EQ(c.count[k], 1) << across << " across, bin at phi = " << c.axis[k];
        ++over_opening;
      }
    EXPECT_GE(over_opening, 2 * static_cast<int>(across)) << across << " across";
  }
}

TEST(RotatingScene, BadInputNamesTheParameter) {
  rotating::Params p;
  p.across = 2;
  EXPECT_THROW(rotating::make_particles(p), std::invalid_argument);
  p = {};
  p.gamma = 1.5;
  try {
    p.validate();
    FAIL();
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("gamma"), std::string::npos);
  }
  EXPECT_THROW(rotating::parse_model("sliding"), std::invalid_argument);
}
