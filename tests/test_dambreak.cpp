#include <gtest/gtest.h>

#include <omp.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>

#include "column.hpp"
#include "mps/boundaries/geometry.hpp"

namespace {

TEST(DamBreak, FrontAndLevelOfTheStandingColumnAreItsWidthAndHeight) {
  const dambreak::Params p = dambreak::defaults(dambreak::Column::classic);
  mps::Particles s = dambreak::make_particles(p);
  EXPECT_NEAR(dambreak::surge_front(s, p.l0), p.width, 1e-12);
  EXPECT_NEAR(mps::water_level<2>(s, {0.5 * p.width, 0.0}, p.l0), p.height, 1e-12);
  EXPECT_EQ(mps::water_level<2>(s, {2.0 * p.width, 0.0}, p.l0), 0.0);  // dry floor
  s.add(3 * p.width, 0.5 * p.height, mps::Kind::fluid);            // lone drops ahead are spray, not the front
  s.add(2 * p.width, 0.5 * p.height, mps::Kind::fluid);
  s.add(p.width + 2.2 * p.l0, 0.0, mps::Kind::fluid);  // 2.7 l0 from the column's nearest particle: alone too
  EXPECT_NEAR(dambreak::surge_front(s, p.l0), p.width, 1e-12);
  s.add(p.width + p.l0, 0.5 * p.height, mps::Kind::fluid);  // 1.5 l0 from the column's edge: the new front
  EXPECT_NEAR(dambreak::surge_front(s, p.l0), p.width + 1.5 * p.l0, 1e-12);
}

// Samples of a front that is exactly the data, or 2 % ahead of it: the error is 0 or 0.02 at the worst point.
TEST(DamBreak, FrontErrorInterpolatesTheRunAtTheExperimentsTimes) {
  const dambreak::Params p = dambreak::defaults(dambreak::Column::classic);
  const dambreak::Table data{{0.5, 1.1}, {1.0, 1.4}, {2.0, 2.3}, {3.0, 3.5}};
  const double scale = dambreak::front_time_scale(p);
  auto exact = [&](double T) {  // the data joined by straight lines
    for (std::size_t k = 1; k < data.size(); ++k)
      if (T <= data[k][0]) {
        const double w = (T - data[k - 1][0]) / (data[k][0] - data[k - 1][0]);
        return (1 - w) * data[k - 1][1] + w * data[k][1];
      }
    return data.back()[1];
  };
  for (double ahead : {0.0, 0.02}) {
    std::vector<dambreak::Sample> run;
    for (int k = 0; k <= 300; ++k) {
      const double T = 0.5 + k * 0.01;
      run.push_back({T / scale, (1 + ahead) * exact(T) * p.width, {}, {}});
    }
    EXPECT_NEAR(dambreak::max_front_error(run, p, data, 2.5), ahead, 1e-12);
    run.resize(100);  // the run ends at T = 1.49: later points are left out
    EXPECT_NEAR(dambreak::max_front_error(run, p, data, 2.5), ahead, 1e-12);
  }
  EXPECT_TRUE(std::isnan(dambreak::max_front_error({}, p, data, 2.5)));
}

// A run that is an experiment's curve delayed by 0.25 in T: the fitted offset is that delay and leaves no error, and a
// straight front's fitted speed is its slope.
TEST(DamBreak, FrontOffsetAndDevelopedSpeedRecoverAKnownDelayAndSlope) {
  const dambreak::Params p = dambreak::defaults(dambreak::Column::classic);
  const dambreak::Table data{{0.8, 1.2}, {1.2, 1.45}, {1.6, 1.9}, {2.3, 2.7}, {2.95, 3.7}, {3.6, 4.5}};
  const double scale = dambreak::front_time_scale(p);
  auto curve = [&](double T) {  // the data joined by straight lines, held before the first point
    if (T <= data.front()[0]) return data.front()[1];
    for (std::size_t k = 1; k < data.size(); ++k)
      if (T <= data[k][0]) {
        const double w = (T - data[k - 1][0]) / (data[k][0] - data[k - 1][0]);
        return (1 - w) * data[k - 1][1] + w * data[k][1];
      }
    return data.back()[1];
  };
  std::vector<dambreak::Sample> run;
  for (int k = 0; k <= 400; ++k) {
    const double T = k * 0.01;
    run.push_back({T / scale, curve(T + 0.25) * p.width, {}, {}});  // 0.25 ahead of the data
  }
  const dambreak::FrontOffset offset = dambreak::fit_front_offset(run, p, data, 3.5);
  EXPECT_NEAR(offset.dT, 0.25, 1e-9);
  EXPECT_NEAR(offset.error, 0.0, 1e-12);
  EXPECT_GT(dambreak::max_front_error(run, p, data, 3.5), 0.05);  // undelayed, the lead shows
  const dambreak::FrontLine line = dambreak::fit_front_line({1.0, 1.5, 2.0, 3.0, 3.5, 4.0}, {9, 2.0, 2.7, 4.1, 4.8, 9},
                                                            1.5, 3.5);
  EXPECT_NEAR(line.speed, 1.4, 1e-12);
  EXPECT_NEAR(line.intercept, -0.1, 1e-12);
  EXPECT_EQ(line.points, 4);
}

TEST(DamBreak, ImpactFindsTheArrivalThePeakAndNoNoiseInASmoothSignal) {
  std::vector<double> t, pressure;
  for (int k = 0; k <= 4000; ++k) {
    t.push_back(k * 0.001);
    const double s = t.back() - 2.0;  // a smooth pulse rising at t = 2
    pressure.push_back(s > 0 ? 0.7 * std::sin(std::min(s, 0.5) * M_PI) : 0.0);
  }
  const dambreak::Impact smooth = dambreak::impact(t, pressure, 0.25, 0.5, 0.01);
  EXPECT_NEAR(smooth.arrival, 2.0 + std::asin(0.25 / 0.7) / M_PI, 1e-3);
  EXPECT_NEAR(smooth.peak, 0.7, 1e-3);
  EXPECT_LT(smooth.noise, 1e-3);
  for (std::size_t k = 0; k < pressure.size(); ++k) pressure[k] += (k % 2 ? 0.1 : -0.1);  // add a saw of +-0.1
  const dambreak::Impact noisy = dambreak::impact(t, pressure, 0.25, 0.5, 0.01);
  EXPECT_GT(noisy.noise, 0.1);
  EXPECT_TRUE(std::isnan(dambreak::impact(t, std::vector<double>(t.size(), 0.1)).arrival));
}

// A plateau of 0.5 from t = 3 on and a second bump to 0.9 centred at 5.9: the second impact's arrival is where the
// (here unsmoothed) signal first exceeds the plateau by 0.1, its peak the bump's top; a saw of +-0.1 is 0.1 RMS.
TEST(DamBreak, ImpactFindsThePlateauTheSecondImpactAndTheNoiseRms) {
  std::vector<double> t, pressure;
  for (int k = 0; k <= 7000; ++k) {
    t.push_back(k * 0.001);
    const double bump = std::max(0.0, 0.4 * (1 - std::abs(t.back() - 5.9) / 0.2));
    pressure.push_back(t.back() < 2.5 ? 0.0 : t.back() < 3.0 ? 0.9 : 0.5 + bump);
  }
  const dambreak::Impact smooth = dambreak::impact(t, pressure, 0.25, 0.5, 0.001);
  EXPECT_NEAR(smooth.plateau, 0.5, 1e-12);
  EXPECT_NEAR(smooth.second_arrival, 5.9 - 0.2 * 0.75, 2e-3);  // bump = 0.1 a quarter of the way up
  EXPECT_NEAR(smooth.second_peak, 0.9, 2e-3);
  EXPECT_NEAR(smooth.noise_rms, 0.0, 1e-12);
  std::vector<double> saw(t.size());  // a level 0.5 with a saw of +-0.1: its 0.1 smoothing leaves 0.1 - 0.1/101 RMS
  for (std::size_t k = 0; k < saw.size(); ++k) saw[k] = 0.5 + (k % 2 ? 0.1 : -0.1);
  EXPECT_NEAR(dambreak::impact(t, saw).noise_rms, 0.1 * (1 - 1.0 / 101), 1e-3);
  pressure.resize(4000);  // ends before t = 5: no second impact to find
  EXPECT_TRUE(std::isnan(dambreak::impact(t, pressure).second_arrival));
}

// Sampled at a record's times, a signal is the mean over each sample's interval (midpoint to midpoint): a line gives
// its interval's middle, a saw of +-0.1 at every step averages away, and samples whose interval reaches past the
// signal's end (0.8's reaches 1.0) or holds no step (three samples closer than the step) are left out.
TEST(DamBreak, SampledAtARecordsTimesAveragesOverEachSamplesInterval) {
  std::vector<double> t, line, saw;
  for (int k = 0; k < 1000; ++k) {  // steps at 0.0005, 0.0015, ..., 0.9995: none on an interval's end
    t.push_back((k + 0.5) * 0.001);
    line.push_back(2.0 * t.back());
    saw.push_back(0.5 + (k % 2 ? 0.1 : -0.1));
  }
  const std::vector<double> at{0.0, 0.2, 0.4, 0.4001, 0.4002, 0.6, 0.8, 1.2};
  const auto [kept_t, kept_line] = dambreak::sampled_at(t, line, at);
  ASSERT_EQ(kept_t, (std::vector<double>{0.0, 0.2, 0.4, 0.4002, 0.6}));
  // intervals [0, 0.1), [0.1, 0.3), [0.3, 0.40005), [0.40015, 0.5001), [0.5001, 0.7): twice their middles
  const std::vector<double> expected{0.1, 0.4, 0.7, 0.9, 1.2};
  for (std::size_t s = 0; s < kept_t.size(); ++s) EXPECT_NEAR(kept_line[s], expected[s], 1e-9) << "at " << kept_t[s];
  for (double v : dambreak::sampled_at(t, saw, at).second) EXPECT_NEAR(v, 0.5, 1e-12);  // 100 or 200 steps each
  EXPECT_TRUE(dambreak::sampled_at({}, {}, at).first.empty());
}

TEST(DamBreak, RefusesAColumnThatDoesNotFitAndExperimentalDataThatIsNotNumbers) {
  dambreak::Params p = dambreak::defaults(dambreak::Column::classic);
  p.width = p.tank_length;
  EXPECT_THROW(dambreak::Scene{p}, std::invalid_argument);
  EXPECT_THROW(dambreak::column_from_name("tall"), std::invalid_argument);
  EXPECT_THROW(dambreak::read_table("/nonexistent/mm_data_1.txt"), std::runtime_error);
}

// A particle file holding a built-in column's particles runs as that column; the same particles moved elsewhere are a
// new scene whose tank and water are measured from the walls and the fluid, to the lattice, and moved back to the
// origin. A spacing that is not the file's, fluid outside the walls and a file without walls are refused.
TEST(DamBreak, AParticleFileIsRecognisedAsItsColumnOrMeasuredAsANewTank) {
  const dambreak::Params classic = dambreak::defaults(dambreak::Column::classic);
  dambreak::Params options;
  options.gamma = 0.2;
  const mps::Particles built = dambreak::make_particles(classic);
  const dambreak::FileScene same = dambreak::from_particles(built, 0.0, options);
  EXPECT_EQ(same.params.column, dambreak::Column::classic);
  EXPECT_EQ(same.params.l0, 0.00365);  // the median spacing to 12 digits
  EXPECT_EQ(same.params.tank_height, classic.tank_height);
  EXPECT_EQ(same.params.pressure_probes, classic.pressure_probes);
  EXPECT_EQ(same.params.gamma, 0.2);
  EXPECT_EQ(dambreak::from_particles(built, classic.l0, options).params.l0, classic.l0);
  mps::Particles reversed = built;  // a frame holds the particles in the step's order
  std::vector<int> order(built.size());
  for (std::size_t i = 0; i < order.size(); ++i) order[i] = static_cast<int>(order.size() - 1 - i);
  reversed.permute(order);
  EXPECT_EQ(dambreak::from_particles(reversed, classic.l0, options).params.column, dambreak::Column::classic);
  mps::Particles moving = built;
  moving.u[7] = 1e-3;
  EXPECT_EQ(dambreak::from_particles(moving, classic.l0, options).params.column, dambreak::Column::file);

  mps::Particles moved = built;
  for (std::size_t i = 0; i < moved.size(); ++i) {
    moved.x[i] += 0.3;
    moved.y[i] -= 0.1;
  }
  const dambreak::FileScene measured = dambreak::from_particles(moved, classic.l0, options);
  const dambreak::Params& p = measured.params;
  EXPECT_EQ(p.column, dambreak::Column::file);
  EXPECT_NEAR(p.tank_length, classic.tank_length, 1e-12);
  EXPECT_NEAR(p.tank_height, classic.tank_height, 1e-12);
  EXPECT_NEAR(p.width, classic.width, 1e-12);
  EXPECT_NEAR(p.height, classic.height, 1e-12);
  EXPECT_EQ(p.level_probes, classic.level_probes);
  EXPECT_NEAR(p.end_time, classic.end_time, 1e-12);
  double worst = 0;
  for (std::size_t i = 0; i < built.size(); ++i)
    worst = std::max({worst, std::abs(measured.particles.x[i] - built.x[i]), std::abs(measured.particles.y[i] - built.y[i])});
  EXPECT_LT(worst, 1e-12);

  auto refused = [&](const mps::Particles& particles, double dx, const std::string& cause) {
    try {
      (void)dambreak::from_particles(particles, dx, options);
      ADD_FAILURE() << "accepted; expected " << cause;
    } catch (const std::invalid_argument& e) {
      EXPECT_NE(std::string(e.what()).find(cause), std::string::npos) << e.what();
    }
  };
  refused(built, 2 * classic.l0, "give the spacing the file was made with");
  mps::Particles outside = built;
  outside.add(1.5, 0.1, mps::Kind::fluid);  // the tank is 8a = 1.168 m long
  refused(outside, classic.l0, "lies outside the tank its wall particles enclose");
  mps::Particles no_walls;
  mps::fill_rectangle(no_walls, {0, 0, 0.1, 0.1}, 0.01, mps::Kind::fluid);
  refused(no_walls, 0.0, "no wall particles");
}

// The seed column at H/25 to t sqrt(g/H) = 7: the default (the higher-order source and the dynamic stabilisation,
// without collisions) cuts the wall pressure's step-to-step noise (the RMS of the 0.2 H signal less its 0.1 moving
// mean) more than twofold against the classic divergence source, which needs collisions to run (measured 0.107
// against 0.300 rho g H), and keeps a first peak near Buchner's 0.654 (measured 0.645). At this spacing the peak is set
// to about 10 % by the solves' last digits: six solvers, each to 1e-8 or exact, gave 0.548-0.682 (docs/dambreak.md),
// so it is held to 20 %, which a lost impact (0.02-0.28 in the settings that lose it) fails.
TEST(DamBreak, HigherOrderSourceQuietsTheWallPressureOfTheSeedColumn) {
  auto impact = [](const std::string& treatment, double collision) {
    dambreak::Params p = dambreak::defaults(dambreak::Column::seed);
    p.pressure_treatment = treatment;
    p.collision = collision;
    dambreak::Scene scene(p);
    while (!scene.done()) scene.step();
    const std::size_t probe = static_cast<std::size_t>(
        std::find(p.pressure_probes.begin(), p.pressure_probes.end(), 0.2) - p.pressure_probes.begin());
    std::vector<double> t, pressure;
    for (const auto& s : scene.samples()) {
      t.push_back(s.time * std::sqrt(p.g / p.height));
      pressure.push_back(s.pressures.at(probe) / (1000.0 * p.g * p.height));
    }
    return dambreak::impact(t, pressure);
  };
  const dambreak::Impact hs = impact("hs+ds", 0.0), classic = impact("none", 0.8);
  EXPECT_LT(hs.noise_rms, 0.5 * classic.noise_rms);
  EXPECT_NEAR(hs.peak, 0.654, 0.2 * 0.654);
}

// The plain dam break runs on the dam break's defaults alone: no collisions, no asymmetry test, and the dynamic
// stabilisation ("ds") beside the higher-order source. Without "ds" the classic column at a/40 is stopped by the guard
// (measured at t = 0.191 s of 0.302: particles held at the surface's pressure run into each other); with it the
// column runs to T = 3.5 and its developed front speed is within 3 % of Martin & Moyce's two series (1.367 and 1.371 a per unit T).
TEST(DamBreak, TheDefaultsRunTheClassicColumnWithoutCollisions) {
  dambreak::Params p = dambreak::defaults(dambreak::Column::classic);
  ASSERT_EQ(p.collision, 0.0);
  ASSERT_EQ(p.asymmetry, 0.0);
  dambreak::Params without = p;
  without.pressure_treatment = "hs";
  dambreak::Scene stopped(without);
  EXPECT_THROW(
      {
        while (!stopped.done()) stopped.step();
      },
      mps::SimulationError);
  EXPECT_LT(stopped.sim().time(), p.end_time);
  dambreak::Scene scene(p);
  while (!scene.done()) scene.step();
  std::vector<double> T, x;
  for (const dambreak::Sample& s : scene.samples()) {
    T.push_back(s.time * std::sqrt(2 * p.g / p.width));
    x.push_back(s.front / p.width);
  }
  const dambreak::FrontLine line = dambreak::fit_front_line(T, x, 1.5, 3.5);
  EXPECT_NEAR(line.speed, 1.367, 0.03 * 1.367);
  EXPECT_NEAR(line.speed, 1.371, 0.03 * 1.371);
}

// The tank is its built walls: the seed column's 5.366 H is no whole number of spacings, and the scene's tank length
// (where the pressure probes sit and the wall backstop acts) is the first wall layer's centres less l0/2 at every
// spacing. The classic column's 8a, already whole, is kept to the bit.
TEST(DamBreak, TheTankLengthIsWhereTheWallIsBuilt) {
  for (double l0 : {0.04, 0.02, 0.01}) {
    dambreak::Params p = dambreak::defaults(dambreak::Column::seed);
    p.l0 = l0;
    const dambreak::Scene scene(p);
    const mps::Particles& s = scene.sim().particles();
    double first_layer = std::numeric_limits<double>::infinity();
    for (std::size_t i = 0; i < s.size(); ++i)
      if (s.kind[i] == mps::Kind::wall && s.y[i] > 0.0 && s.x[i] > 0.5 * p.tank_length)  // the downstream wall
        first_layer = std::min(first_layer, s.x[i]);
    EXPECT_NEAR(scene.params().tank_length, first_layer - 0.5 * l0, 1e-9 * l0) << "l0 = " << l0;
    EXPECT_GT(std::abs(scene.params().tank_length - p.tank_length), 0.1 * l0) << "l0 = " << l0;
  }
  const dambreak::Params classic = dambreak::defaults(dambreak::Column::classic);
  EXPECT_EQ(dambreak::Scene(classic).params().tank_length, classic.tank_length);
}

// A step far beyond the CFL limit is stopped by the guard, which names the app's time-step option.
TEST(DamBreak, ATimeStepFarBeyondTheCflLimitIsStoppedByTheGuard) {
  dambreak::Params p = dambreak::defaults(dambreak::Column::classic);
  p.cfl = 5.0;
  dambreak::Scene scene(p);
  try {
    while (!scene.done()) scene.step();
    FAIL() << "the run went to its end";
  } catch (const mps::SimulationError& e) {
    EXPECT_NE(std::string(e.what()).find("--cfl"), std::string::npos) << e.what();
  }
  EXPECT_LT(scene.sim().time(), p.end_time);
}

// The step carries its neighbour list at r* over to the next step (SimulationConfig::neighbor_skin) while no particle
// has moved half the skin: the classic column with its collisions, asymmetry test and wet walls, through two
// reorderings and a particle moved by hand, comes out bitwise as a run that searches every time.
TEST(DamBreak, ACarriedNeighbourListGivesTheBitsOfASearchEveryStep) {
  dambreak::Params p = dambreak::defaults(dambreak::Column::classic);
  struct Run {
    mps::Particles particles;
    int carried = 0;
    bool carried_after_the_move = true;
  };
  auto run = [&](double skin) {
    mps::SimulationConfig c = dambreak::make_config(p);
    c.neighbor_skin = skin;
    mps::Simulation sim(dambreak::make_particles(p), dambreak::make_domain(p), c);
    dambreak::add_dam_break_components<2>(sim, p, [](const mps::Vec<2>&) { return true; });
    Run out;
    for (int s = 0; s < 45; ++s) {
      if (s == 30) {  // a fluid particle a third of a spacing along x: more than half the skin
        mps::Particles moved = sim.particles();
        const auto i = static_cast<std::size_t>(
            std::find(moved.kind.begin(), moved.kind.end(), mps::Kind::fluid) - moved.kind.begin());
        moved.x[i] += p.l0 / 3;
        sim.set_particles(moved);
      }
      out.carried += sim.step().neighbors_carried ? 1 : 0;
      if (s == 30) out.carried_after_the_move = sim.last_step().neighbors_carried;
    }
    out.particles = sim.particles();
    return out;
  };
  const Run searched = run(0.0), carried = run(0.1);
  EXPECT_EQ(searched.carried, 0);
  EXPECT_GE(carried.carried, 35);  // all but the first step, the reorderings, the move and any large moves
  EXPECT_FALSE(carried.carried_after_the_move);
  EXPECT_EQ(carried.particles.x, searched.particles.x);
  EXPECT_EQ(carried.particles.y, searched.particles.y);
  EXPECT_EQ(carried.particles.u, searched.particles.u);
  EXPECT_EQ(carried.particles.v, searched.particles.v);
  EXPECT_EQ(carried.particles.p, searched.particles.p);
  EXPECT_GT(*std::max_element(searched.particles.p.begin(), searched.particles.p.end()), 1000.0);  // a flow
}

}  // namespace

// Loops over enough particles run on two threads, smaller ones on one (mps/core/threads.hpp); either way each particle's
// numbers are computed in the same order, so the column at a/40 (about 4,500 particles) must come out of 20 steps
// bitwise the same on one thread and on two.
TEST(DamBreak, TwoThreadsComputeBitwiseWhatOneComputes) {
  dambreak::Params p = dambreak::defaults(dambreak::Column::classic);
  p.l0 = p.width / 40;
  auto run = [&](int threads) {
    const int before = omp_get_max_threads();
    omp_set_num_threads(threads);
    dambreak::Scene scene(p);
    for (int s = 0; s < 20; ++s) scene.step();
    omp_set_num_threads(before);
    return scene.sim().particles();
  };
  const mps::Particles one = run(1), two = run(2);
  ASSERT_GT(one.size(), 2048u);  // above the library's threshold for a second thread
  EXPECT_EQ(one.x, two.x);
  EXPECT_EQ(one.y, two.y);
  EXPECT_EQ(one.u, two.u);
  EXPECT_EQ(one.v, two.v);
  EXPECT_EQ(one.p, two.p);
  EXPECT_GT(*std::max_element(one.p.begin(), one.p.end()), 1000.0);  // a flow, not water at rest
}
