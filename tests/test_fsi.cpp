#include <gtest/gtest.h>

#include <cmath>
#include <string>

#include "plate.hpp"

namespace {

struct PlateRun {
  double largest_tip = 0, worst_imbalance = 0, largest_force = 0, work = 0, energy = 0;
  int steps = 0;
};

// The coarse dam break on the plate (l0 = 0.004) through the first impact.
PlateRun run_plate(double modulus, double end_time) {
  fsi::PlateParams p;
  p.youngs_modulus = modulus;
  p.end_time = end_time;
  fsi::PlateScene scene(p);
  PlateRun r;
  while (!scene.done()) {
    scene.step();
    const auto* s = scene.structure();
    const auto a = s->force_on_structure(), b = s->force_on_fluid();
    r.worst_imbalance = std::max(r.worst_imbalance, std::hypot(a[0] + b[0], a[1] + b[1]));
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

TEST(Fsi, DamBreakBendsThePlateWithActionEqualToReactionAndTheWorkBalanced) {
  const PlateRun soft = run_plate(6e6, 0.2), stiff = run_plate(2.38e7, 0.2);
  for (const auto& r : {soft, stiff}) {
    // The surge reaches the plate (t ~ 0.14 s) and pushes it downstream.
    EXPECT_GT(r.largest_force, 10.0);
    EXPECT_GT(r.largest_tip, 0.0);
    // What the fluid gets from the plate and the plate from the fluid cancel each step (the component also throws
    // if they do not); and no fluid got inside the plate (its guard would have stopped the run).
    EXPECT_LT(r.worst_imbalance, 1e-9 * r.largest_force);
    // The pressure's work on the plate is the plate's kinetic + elastic + gravity energy (it started at rest).
    EXPECT_NEAR(r.energy, r.work, 0.03 * r.work);
  }
  // A stiffer plate bends less: measured 7.25 mm (E = 6e6) against 1.66 mm (2.38e7) by t = 0.2 s. Energy against
  // work: 0.1073 / 0.1077 and 0.0943 / 0.0944 J/m.
  EXPECT_GT(soft.largest_tip, 2.0 * stiff.largest_tip);
}

}  // namespace
