#include <gtest/gtest.h>

#include <cmath>
#include <stdexcept>
#include <string>

#include "mps/fsi.hpp"
#include "mps/geometry.hpp"
#include "scene.hpp"

namespace {

struct PlateRun {
  double largest_tip = 0, largest_force = 0, work = 0, energy = 0;
  int steps = 0;
};

// The coarse dam break on the plate (l0 = 0.004) through the first impact.
PlateRun run_plate(double modulus, double end_time, double relaxation = 0.1) {
  fsi::Params p = fsi::defaults(fsi::Case::plate);
  p.youngs_modulus = modulus;
  p.end_time = end_time;
  p.relaxation = relaxation;
  fsi::Scene scene(p);
  PlateRun r;
  while (!scene.done()) {
    scene.step();
    const auto* s = scene.structure();
    const auto a = s->force_on_structure();
    r.largest_force = std::max(r.largest_force, std::hypot(a[0], a[1]));
    r.largest_tip = std::max(r.largest_tip, scene.samples().back().tip_x);
    ++r.steps;
  }
  const auto& solid = scene.structure()->solid();
  r.work = solid.external_work();
  const auto& e = solid.energy();
  r.energy = e.kinetic + e.strain + e.hourglass + e.gravity;
  return r;
}

TEST(Fsi, DamBreakBendsThePlateAndThePressureWorkIsThePlatesEnergy) {
  const PlateRun soft = run_plate(6e6, 0.2), stiff = run_plate(2.38e7, 0.2);
  for (const auto& r : {soft, stiff}) {
    // The surge reaches the plate (t ~ 0.14 s) and pushes it downstream.
    EXPECT_GT(r.largest_force, 10.0);
    EXPECT_GT(r.largest_tip, 0.0);
    // No fluid got inside the plate: the component's guard would have stopped the run.
    // The pressure's work on the plate is the plate's kinetic + elastic + gravity energy (it started at rest).
    EXPECT_NEAR(r.energy, r.work, 1e-4 * r.work);
  }
  // A stiffer plate bends less: measured 18.1 mm (E = 6e6) against 6.09 mm (2.38e7) by t = 0.2 s, with the load
  // relaxed by 0.1 a step and wet walls; energy against work 0.76609 / 0.766095 and 0.207171 / 0.207173 J/m.
  EXPECT_GT(soft.largest_tip, 2.0 * stiff.largest_tip);
}

TEST(Fsi, UnrelaxedCouplingBlowsUpAndTheGuardSaysSo) {
  // The plate's load taken whole each step (relaxation 1): the partitioned coupling is unstable at this density
  // ratio (1.1) and a guard stops the run at the impact with its reason.
  std::string what;
  try {
    run_plate(6e6, 0.2, 1.0);
  } catch (const mps::SimulationError& e) {
    what = e.what();
  }
  EXPECT_TRUE(what.find("blow-up") != std::string::npos || what.find("unstable") != std::string::npos) << what;
}

TEST(Fsi, GateOpensWithoutWaterGettingInside) {
  // The rubber gate at l0 = 0.00125 for 0.03 s: the water pushes its free end out and up, no fluid particle ever gets
  // inside it (the component's guard would stop the run), and the pressure's work is the gate's energy.
  fsi::Params p = fsi::defaults(fsi::Case::gate);
  p.end_time = 0.03;
  fsi::Scene scene(p);
  while (!scene.done()) scene.step();
  const auto& last = scene.samples().back();
  EXPECT_GT(last.tip_x, 0.005);  // measured 9.27 mm out and 0.61 mm up; energy and work 0.0521665 J/m
  EXPECT_GT(last.tip_y, 0.0);
  const auto& solid = scene.structure()->solid();
  const auto& e = solid.energy();
  EXPECT_NEAR(e.kinetic + e.strain + e.hourglass + e.gravity, solid.external_work(), 1e-4 * solid.external_work());
}

TEST(Fsi, SubmergedBlockFeelsArchimedesBuoyancy) {
  // Water 0.4 m deep at rest in a tank 0.4 m wide, a square block 0.1 m across held in its middle: the pressure pairs
  // on the block add up to rho g V upwards (98.1 N/m) and nothing sideways.
  const double l0 = 0.01, side = 0.1, x0 = 0.15, y0 = 0.15;
  mps::Particles p;
  for (int j = 0; j < 40; ++j)
    for (int i = 0; i < 40; ++i) {
      const double x = (i + 0.5) * l0, y = (j + 0.5) * l0;
      const bool in_block = x > x0 && x < x0 + side && y > y0 && y < y0 + side;
      if (!in_block) {
        p.add(x, y, mps::Kind::fluid);
        continue;
      }
      const bool face = x < x0 + l0 || x > x0 + side - l0 || y < y0 + l0 || y > y0 + side - l0;
      p.add(x, y, face ? mps::Kind::wall : mps::Kind::dummy, 2);
    }
  mps::add_rectangle_walls(p, {0.0, 0.0, 0.4, 0.5}, l0, mps::left | mps::right | mps::bottom, 1, 4);
  mps::SimulationConfig c;
  c.l0 = l0;
  c.rho = 1000.0;
  c.nu = 1e-6;
  c.fy = -9.81;
  c.gamma = 0.01;
  c.dt_max = 1e-3;
  c.hydrostatic_split = false;
  mps::Simulation sim(p, mps::Domain{-0.1, 0.5, -0.1, 0.7}, c);
  auto& force = sim.add<mps::WallForce>(2);
  double fy = 0.0, fx = 0.0;
  const int steps = 50;
  for (int k = 0; k < steps; ++k) {
    sim.step();
    fx += force.force()[0] / steps;
    fy += force.force()[1] / steps;
  }
  const double archimedes = 1000.0 * 9.81 * side * side;
  EXPECT_NEAR(fy, archimedes, 0.01 * archimedes) << "mean vertical force over 50 steps (measured 98.27 N/m)";
  EXPECT_NEAR(fx, 0.0, 1e-4 * archimedes);  // measured -1e-4 N/m
}

}  // namespace
