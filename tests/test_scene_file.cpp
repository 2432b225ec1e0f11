// Scene files (apps/run/scene_file.hpp): the particles a file describes, its physics and numerics in the simulation's
// configuration, a moving obstacle on its prescribed motion, an annulus's rings and turning walls, and every malformed
// file refused with its line and key.
#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <numbers>
#include <string>
#include <vector>

#include "mps/solids/fsi.hpp"
#include "mps/step/components.hpp"
#include "scene_file.hpp"

namespace {

namespace fs = std::filesystem;

// Named by the process too: ctest runs each test in its own process, in parallel, and two tests' "edited" files
// had overwritten each other.
fs::path write_file(const std::string& name, const std::string& text) {
  const fs::path path = fs::temp_directory_path() /
                        ("sparsemps_scene_file_" + std::to_string(::getpid()) + "_" + name + ".toml");
  std::ofstream(path) << text;
  return path;
}

// A 2-D tank 0.4 m x 0.3 m at l0 = 0.02 m with water 0.2 m x 0.1 m in it; `extra` is appended.
std::string tank(const std::string& extra = "") {
  return R"(dimensions = 2
spacing = 0.02
[tank]
min = [0.0, 0.0]
max = [0.4, 0.3]
[[fluid]]
min = [0.0, 0.0]
max = [0.2, 0.1]
[physics]
gravity = 9.81
[numerics]
dt_max = 1e-3
[run]
end_time = 0.01
)" + extra;
}

// The message of the reader's refusal of `text` ("" if it was read), the reader chosen as sparsemps-run chooses it.
std::string refusal(const std::string& name, const std::string& text) {
  const fs::path path = write_file(name, text);
  try {
    if (scene_file::is_acoustic(path)) static_cast<void>(scene_file::read_acoustic_scene(path));
    else if (scene_file::dimensions_of(path) == 2) static_cast<void>(scene_file::read_scene<2>(path));
    else static_cast<void>(scene_file::read_scene<3>(path));
  } catch (const std::invalid_argument& e) {
    return e.what();
  }
  return "";
}

// `text` with `from` replaced by `to` is refused with a message holding `part`.
void expect_refusal_of_edit(std::string text, const std::string& from, const std::string& to, const std::string& part) {
  text.replace(text.find(from), from.size(), to);
  const std::string message = refusal("edited", text);
  EXPECT_NE(message.find(part), std::string::npos) << "after '" << from << "' -> '" << to << "', got: " << message;
}

// The lattice gives every count: 10 x 5 fluid; the walls one layer, the dummies four, on three sides with their
// corners; the obstacle's four spacings square, its top and sides wall (not its bottom, on the floor).
TEST(SceneFile, ParticlesAreTheBlocksWallsAndObstaclesTheFileDescribes) {
  const fs::path path = write_file("counts", tank(R"([[obstacle]]
min = [0.28, 0.0]
max = [0.36, 0.08]
)"));
  const auto scene = scene_file::read_scene<2>(path);
  const auto s = scene_file::make_particles(scene);
  EXPECT_EQ(s.count(mps::Kind::fluid), 50u);
  // The tank is 20 x 15 cells: its layer k (1 to 5) has 20 + 2k floor cells and 15 + k - 1 in each side below the top.
  std::size_t walls = 0, dummies = 0;
  for (int k = 1; k <= 5; ++k) (k == 1 ? walls : dummies) += static_cast<std::size_t>(20 + 2 * k + 2 * (15 + k - 1));
  std::size_t obstacle_walls = 0, obstacle_dummies = 0;
  for (std::size_t i = 0; i < s.size(); ++i)
    if (s.x[i] > 0.28 && s.x[i] < 0.36 && s.y[i] > 0.0 && s.y[i] < 0.08)
      ++(s.kind[i] == mps::Kind::wall ? obstacle_walls : obstacle_dummies);
  EXPECT_EQ(obstacle_walls, 10u);   // 4 x 4 cells, all but the 2 x 3 inner ones below the top row
  EXPECT_EQ(obstacle_dummies, 6u);
  EXPECT_EQ(s.count(mps::Kind::wall), walls + obstacle_walls);
  EXPECT_EQ(s.count(mps::Kind::dummy), dummies + obstacle_dummies);
  // The default domain: the particles' box with 6 l0 around it and half its height above.
  const double lowest = -4.5 * 0.02, highest = 0.3 - 0.5 * 0.02;
  EXPECT_NEAR(scene.domain.ymin, lowest - 0.12, 1e-12);
  EXPECT_NEAR(scene.domain.ymax, highest + 0.12 + 0.5 * (highest - lowest), 1e-12);
}

// [physics], [numerics] and [solver] set SimulationConfig's fields by their schema names; gravity points down the
// last axis; the treatments by their names.
TEST(SceneFile, PhysicsAndNumericsSetTheConfigurationByName) {
  const auto c2 = scene_file::read_scene<2>(write_file("config", tank(R"(
[solver]
solver = "eigen-cg"
warm_start = false
)"))).config;
  EXPECT_EQ(c2.fy, -9.81);
  EXPECT_EQ(c2.solver, "eigen-cg");
  EXPECT_FALSE(c2.warm_start);
  std::string text = tank();
  text.replace(text.find("dt_max = 1e-3"), 13,
               "dt_max = 1e-3\ngamma = 0.25\nweight = \"classic\"\nreorder_every = 0\npressure_treatment = \"hs+ecs\"");
  const auto c = scene_file::read_scene<2>(write_file("numerics", text)).config;
  EXPECT_EQ(c.gamma, 0.25);
  EXPECT_EQ(c.weight, mps::Weight::classic);
  EXPECT_EQ(c.reorder_every, 0);
  EXPECT_TRUE(c.higher_order_source && c.error_compensating_source && !c.higher_order_laplacian);
  EXPECT_EQ(c.l0, 0.02);
  const auto c3 = scene_file::read_scene<3>(write_file("config3", R"(dimensions = 3
spacing = 0.05
[[fluid]]
min = [0.0, 0.0, 0.0]
max = [0.2, 0.2, 0.2]
[physics]
gravity = 9.81
[numerics]
dt_max = 1e-3
[run]
end_time = 0.01
)")).config;
  EXPECT_EQ(c3.fz, -9.81);
  EXPECT_EQ(c3.fy, 0.0);
}

// A moving obstacle is where its motion puts it at every step, and moves at its derivative; the fixed walls stay.
TEST(SceneFile, MovingObstacleFollowsItsMotion) {
  const fs::path path = write_file("paddle", R"(dimensions = 2
spacing = 0.02
[tank]
min = [0.0, 0.0]
max = [0.8, 0.4]
[[fluid]]
min = [0.2, 0.0]
max = [0.8, 0.2]
[[obstacle]]
min = [0.1, 0.0]
max = [0.2, 0.3]
group = 3
motion = {axis = 0, amplitude = 0.01, period = 0.2}
[physics]
gravity = 9.81
[numerics]
dt_max = 1e-3
[run]
end_time = 0.05
)");
  const auto scene = scene_file::read_scene<2>(path);
  auto sim = scene_file::make_simulation(scene);
  const mps::Particles start = sim->particles();
  while (sim->time() < 0.05 - 1e-12) sim->step();
  const mps::Particles& s = sim->particles();
  const double t = sim->time(), omega = 2 * std::numbers::pi / 0.2;
  std::size_t paddle = 0;
  for (std::size_t i = 0; i < s.size(); ++i) {
    const auto k = static_cast<std::size_t>(s.id[i]);
    if (s.kind[i] == mps::Kind::fluid) continue;
    if (s.group[i] == 3) {
      ++paddle;
      ASSERT_DOUBLE_EQ(s.x[i], start.x[k] + 0.01 * std::sin(omega * t));
      ASSERT_DOUBLE_EQ(s.u[i], 0.01 * omega * std::cos(omega * t));
      ASSERT_EQ(s.y[i], start.y[k]);
    } else {
      ASSERT_EQ(s.x[i], start.x[k]);
      ASSERT_EQ(s.y[i], start.y[k]);
    }
  }
  EXPECT_EQ(paddle, 5u * 15u);
  // The paddle has pushed into the water (x = start + 0.01 sin(omega t) > start for t < 0.1 s): the water moves +x.
  double momentum = 0;
  for (std::size_t i = 0; i < s.size(); ++i)
    if (s.kind[i] == mps::Kind::fluid) momentum += s.u[i];
  EXPECT_GT(momentum, 0.0);
}

// Each fault is refused naming the file's line and the key, or the two lines that clash.
TEST(SceneFile, MalformedFilesAreRefusedWithTheirLineAndKey) {
  const auto expect = [](const std::string& name, const std::string& text, const std::string& part) {
    const std::string message = refusal(name, text);
    EXPECT_NE(message.find(part), std::string::npos) << name << ": " << message;
  };
  expect("syntax", "dimensions = 2\nspacing = = 1\n", "line 2, column");
  expect("no_dimensions", "spacing = 0.1\n", "needs 'dimensions = 2'");
  expect("dimensions", "dimensions = 4\n", "line 1: 'dimensions' must be 2 or 3");
  expect("unknown_top", "colour = \"blue\"\n" + tank(), "line 1: 'colour' is no key of a scene file");
  expect("spacing", [] { std::string t = tank(); t.replace(t.find("0.02"), 4, "-1"); return t; }(),
         "line 2: 'spacing' (l0) must be positive");
  expect("table_twice", tank("[numerics]\ngamma = 0.5\n"), "line 15, column");  // TOML's own error
  {
    std::string t = tank();
    t.replace(t.find("dt_max = 1e-3"), 13, "dt_max = 1e-3\ngamma = 2");
    expect("gamma_range", t, "line 13: 'gamma' must be in [0, 1]");
    t = tank();
    t.replace(t.find("dt_max = 1e-3"), 13, "dt_max = 1e-3\nrho = 1000");
    expect("wrong_section", t, "line 13: 'rho' is no key of [numerics] (it belongs to [physics])");
    t = tank();
    t.replace(t.find("dt_max = 1e-3"), 13, "dt_max = 1e-3\nweight = \"gaussian\"");
    expect("weight", t, "line 13:");
    t = tank();
    t.replace(t.find("dt_max = 1e-3"), 13, "cfl = 0.1");
    expect("no_dt", t, "[numerics] needs 'dt_max'");
  }
  expect("block_overlap", tank("[[fluid]]\nmin = [0.1, 0.05]\nmax = [0.3, 0.2]\n"),
         "line 15: this [[fluid]] block overlaps the one on line 6");
  expect("through_wall", tank("[[fluid]]\nmin = [0.3, 0.0]\nmax = [0.5, 0.1]\n"),
         "line 15: this [[fluid]] block reaches through a wall of the tank (line 3) on axis x");
  expect("obstacle_in_water", tank("[[obstacle]]\nmin = [0.1, 0.0]\nmax = [0.3, 0.1]\n"),
         "line 15: this [[obstacle]] overlaps the [[fluid]] block on line 6");
  expect("obstacles_overlap",
         tank("[[obstacle]]\nmin = [0.3, 0.0]\nmax = [0.38, 0.1]\n[[obstacle]]\nmin = [0.34, 0.0]\nmax = [0.4, 0.1]\n"),
         "line 18: this [[obstacle]] overlaps the one on line 15");
  expect("obstacle_in_wall", tank("[[obstacle]]\nmin = [0.3, 0.0]\nmax = [0.44, 0.1]\n"),
         "line 15: this [[obstacle]] reaches into a wall of the tank (line 3) on axis x");
  expect("moving_no_group",
         tank("[[obstacle]]\nmin = [0.3, 0.0]\nmax = [0.38, 0.1]\nmotion = {axis = 0, amplitude = 0.01, period = 1}\n"),
         "line 15: a moving obstacle needs a 'group' of its own");
  expect("motion_axis",
         tank("[[obstacle]]\nmin = [0.3, 0.0]\nmax = [0.38, 0.1]\ngroup = 1\nmotion = {axis = 2, amplitude = 0.01, "
              "period = 1}\n"),
         "line 19: 'axis' must be a whole number from 0 to 1");
  expect("walls", [] { std::string t = tank(); t.insert(t.find("[[fluid]]"), "walls = [\"left\"]\n"); return t; }(),
         "line 6: 'walls' lists faces, each one of x_low, x_high, y_low, y_high");
  expect("point", [] { std::string t = tank(); t.replace(t.find("max = [0.2, 0.1]"), 16, "max = [0.2]"); return t; }(),
         "line 8: 'max' must be 2 numbers [m]");
  expect("thin",
         [] {
           std::string t = tank();
           t.replace(t.find("max = [0.2, 0.1]"), 16, "max = [0.2, 0.01]");
           return t;
         }(),
         "line 8: a [[fluid]]: 'max' must lie at least a spacing");
  expect("domain", tank("[domain]\nmin = [-0.05, -0.05]\nmax = [0.5, 0.5]\n"),
         "line 15: the domain must hold every particle: on axis x");
  expect("no_run", [] { std::string t = tank(); t.erase(t.find("[run]")); return t; }(),
         "it needs [run] with 'end_time'");
  expect("component", tank("[components]\nsplash = true\n"), "line 16: 'splash' is no key of [components]");
  expect("backstop", tank("[components]\nwall_backstop = \"yes\"\n"),
         "line 16: 'wall_backstop' must be true, false or a table {slack = S}");
  expect("backstop_slack", tank("[components]\nwall_backstop = {slack = -0.5}\n"),
         "line 16: 'slack' must be in [0, 10] l0");
  expect("too_fine",
         [] {
           std::string t = tank();
           t.replace(t.find("spacing = 0.02"), 14, "spacing = 1e-5");
           return t;
         }(),
         "line 2: at spacing 1e-05 m the scene's boxes hold up to");
  expect("no_slip_faces",
         tank("[[wall]]\nmin = [0.0, 0.0]\nmax = [0.4, 0.3]\nwalls = [\"y_low\", \"y_high\"]\ngroup = 1\n"
              "no_slip = true\n"),
         "line 15: a no-slip [[wall]] lies on one face");
  expect("no_slip_group", tank("[[wall]]\nmin = [0.0, 0.0]\nmax = [0.4, 0.3]\nwalls = [\"y_low\"]\nno_slip = true\n"),
         "line 15: a no-slip [[wall]] needs a 'group' of its own");
  expect("periodic_axis", tank("[domain]\nmin = [-0.2, -0.2]\nmax = [0.6, 0.5]\nperiodic = [\"z\"]\n"),
         "line 18: 'periodic' lists axes, each one of x, y");
}

// A periodic channel between no-slip [[wall]]s, the top one sliding (Couette start-up): the walls in their groups on
// either side, the domain periodic along x, and the fluid set moving along the sliding wall, not across the walls.
TEST(SceneFile, PeriodicChannelBetweenNoSlipWalls) {
  const fs::path path = write_file("couette", R"(dimensions = 2
spacing = 0.02
[[fluid]]
min = [0.0, 0.0]
max = [0.32, 0.2]
[[wall]]
min = [0.0, 0.0]
max = [0.32, 0.2]
walls = ["y_low"]
group = 1
no_slip = true
[[wall]]
min = [0.0, 0.0]
max = [0.32, 0.2]
walls = ["y_high"]
group = 2
no_slip = true
velocity = [0.01, 0.0]
[domain]
min = [0.0, -0.12]
max = [0.32, 0.32]
periodic = ["x"]
[numerics]
dt_max = 0.01
[components]
free_surface = false
[run]
end_time = 1.0
)");
  const auto scene = scene_file::read_scene<2>(path);
  EXPECT_TRUE(scene.domain.periodic_x);
  EXPECT_FALSE(scene.domain.periodic_y);
  auto sim = scene_file::make_simulation(scene);
  const mps::Particles& s0 = sim->particles();
  std::size_t below = 0, above = 0;
  for (std::size_t i = 0; i < s0.size(); ++i) {
    if (s0.group[i] == 1) {
      ASSERT_LT(s0.y[i], 0.0);
      ++below;
    }
    if (s0.group[i] == 2) {
      ASSERT_GT(s0.y[i], 0.2);
      ++above;
    }
  }
  EXPECT_EQ(below, 16u * 5u);
  EXPECT_EQ(above, 16u * 5u);
  for (int k = 0; k < 20; ++k) sim->step();
  // Momentum diffuses in from the top wall: the fluid near it moves along +x, the fluid near the bottom barely.
  double top = 0, bottom = 0, across = 0;
  const mps::Particles& s = sim->particles();
  for (std::size_t i = 0; i < s.size(); ++i) {
    if (s.kind[i] != mps::Kind::fluid) continue;
    if (s.y[i] > 0.18) top += s.u[i];
    if (s.y[i] < 0.02) bottom += s.u[i];
    across = std::max(across, std::abs(s.v[i]));
  }
  EXPECT_GT(top, 0.0);
  EXPECT_GT(top, 100 * std::abs(bottom));
  EXPECT_LT(across, 1e-3 * 0.01 * 16);
}

// A probe's fault is the probe reader's, with the scene file's name and line.
TEST(SceneFile, ProbesAreReadWithTheSceneFilesLines) {
  const fs::path path = write_file("probes", tank(R"([output]
probe_interval = 0.005
[[probe]]
name = "depth"
quantity = "level"
points = [[0.1, 0.0]]
[[probe]]
name = "p"
quantity = "density"
points = [[0.1, 0.05]]
)"));
  const auto scene = scene_file::read_scene<2>(path);
  auto sim = scene_file::make_simulation(scene);
  try {
    static_cast<void>(scene_file::read_probes(scene, *sim));
    FAIL() << "a probe of no known quantity was read";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("scene file " + path.string() + ", line 23: probe 'p': quantity 'density'"),
              std::string::npos)
        << e.what();
  }
  std::string good = tank("[output]\nprobe_interval = 0.005\n[[probe]]\nname = \"depth\"\nquantity = \"level\"\n"
                          "points = [[0.1, 0.0]]\n");
  const auto ok = scene_file::read_scene<2>(write_file("probes_ok", good));
  auto sim_ok = scene_file::make_simulation(ok);
  auto series = scene_file::read_probes(ok, *sim_ok);
  ASSERT_EQ(series.probes().size(), 1u);
  ASSERT_TRUE(series.sample(0.0, sim_ok->particles()));
  EXPECT_NEAR(series.rows().back().at(1), 0.1, 1e-12);  // the water's depth
}

// An annular channel: every ring holds round(r span / l0) fluid particles over the opening at r = R1 + (k + 1/2) l0,
// the walls and flights lie outside the fluid's radii and angles, and the walls turn as the file says: the barrel
// carried round at -1 rad/s but at rest, the flights carried and moving at their rigid velocity.
TEST(SceneFile, AnnulusIsRingsOfFluidBetweenTurningWalls) {
  const std::string text = R"(dimensions = 2
spacing = 0.1
[annulus]
inner_radius = 1.0
outer_radius = 2.0
span = 1.0
inner = {omega = -1.0}
flights = {omega = -1.0}
outer = {omega = 0.0, turns = -1.0}
[physics]
nu = 1.0
rho = 1.0
[numerics]
dt_max = 0.01
[components]
free_surface = false
[run]
end_time = 0.01
)";
  const auto scene = scene_file::read_scene<2>(write_file("annulus", text));
  const mps::Particles p = scene_file::make_particles(scene);
  long expected_fluid = 0;
  for (int k = 0; k < 10; ++k) expected_fluid += std::lround((1.0 + (k + 0.5) * 0.1) * 1.0 / 0.1);
  long fluid = 0;
  const double centre = std::numbers::pi / 2;
  for (std::size_t i = 0; i < p.size(); ++i) {
    const double r = std::hypot(p.x[i], p.y[i]), phi = std::atan2(p.y[i], p.x[i]) - centre;
    if (p.kind[i] == mps::Kind::fluid) {
      ++fluid;
      EXPECT_EQ(p.group[i], 0);
      EXPECT_TRUE(r > 1.0 && r < 2.0 && std::abs(phi) < 0.5) << "fluid at r = " << r << ", phi = " << phi;
    } else if (p.group[i] == 1) {
      EXPECT_LT(r, 1.0);
    } else if (p.group[i] == 2) {
      EXPECT_GT(r, 2.0);
    } else {
      EXPECT_EQ(p.group[i], 3);
      EXPECT_GT(std::abs(phi), 0.5);
    }
  }
  EXPECT_EQ(fluid, expected_fluid);

  auto sim = scene_file::make_simulation(scene);
  for (int n = 0; n < 5; ++n) sim->step();
  const mps::Particles& s = sim->particles();
  const double t = sim->time(), c = std::cos(-t), sn = std::sin(-t);
  std::size_t barrel = 0, flights = 0;
  for (std::size_t i = 0; i < s.size(); ++i) {
    if (s.kind[i] == mps::Kind::fluid || s.group[i] == 1) continue;
    const auto k = static_cast<std::size_t>(s.id[i]);
    ASSERT_NEAR(s.x[i], c * p.x[k] - sn * p.y[k], 1e-12);  // every wall turned by -t
    ASSERT_NEAR(s.y[i], sn * p.x[k] + c * p.y[k], 1e-12);
    if (s.group[i] == 2) {
      ++barrel;
      ASSERT_EQ(s.u[i], 0.0);
      ASSERT_EQ(s.v[i], 0.0);
    } else {
      ++flights;
      ASSERT_NEAR(s.u[i], s.y[i], 1e-12);  // omega = -1 about z: (-omega y, omega x)
      ASSERT_NEAR(s.v[i], -s.x[i], 1e-12);
    }
  }
  EXPECT_GT(barrel, 0u);
  EXPECT_GT(flights, 0u);

  // Its faults, each with its line and key.
  const auto expect = [&](const std::string& from, const std::string& to, const std::string& part) {
    expect_refusal_of_edit(text, from, to, part);
  };
  expect("outer_radius = 2.0", "outer_radius = 2.05", "line 5: the gap outer_radius - inner_radius must be a whole");
  expect("span = 1.0", "span = 6.0", "line 6: a sector's 'span' must be from 0.3 rad");
  expect("span = 1.0\n", "", "line 7: flights close a sector");
  expect("inner_radius = 1.0", "inner_radius = 0.5", "line 4: the inner wall's 5 rings would reach past the centre");
  expect("[physics]", "height = 1.0\n[physics]", "'height' extrudes an annulus in 3-D");
  expect("[physics]", "[tank]\nmin = [0.0, 0.0]\nmax = [1.0, 1.0]\n[physics]",
         "line 3: an [annulus] is a scene of its own");
  expect("inner = {omega = -1.0}", "inner = {omega = -1.0, spin = 2}", "'spin' is no key of [annulus.inner]");
  expect("dimensions = 2", "dimensions = 3", "a 3-D [annulus] needs 'height' [m]");
}

// An inlet channel: the conveyor part of each wall takes its own group, the ghost pool lies one spacing behind the
// plate's last layer (ghost_rows to a spacing of its height, none coinciding), and as the plate advances one spacing
// it adds a column of fluid, one particle per plate wall particle, taken from the pool.
TEST(SceneFile, InletPlateAddsAColumnPerSpacingFromItsGhostPool) {
  const std::string text = R"(dimensions = 2
spacing = 0.1
[[fluid]]
min = [0.0, 0.0]
max = [2.0, 1.0]
velocity = [1.0, 0.0]
[[wall]]
min = [-0.5, 0.0]
max = [2.5, 1.0]
walls = ["y_low"]
group = 1
no_slip = true
part = {below = 0.3, group = 4, velocity = [1.0, 0.0]}
[[wall]]
min = [-0.5, 0.0]
max = [2.5, 1.0]
walls = ["y_high"]
group = 2
no_slip = true
[[wall]]
min = [0.0, 0.0]
max = [2.0, 1.0]
walls = ["x_low"]
group = 3
[inlet]
plate = 3
speed = 1.0
outlet = 2.0
buffer = 0.5
[physics]
nu = 0.01
rho = 1.0
[numerics]
dt_max = 0.01
clamp_negative_pressure = false
[components]
free_surface = false
[run]
end_time = 0.2
)";
  const auto scene = scene_file::read_scene<2>(write_file("inlet", text));
  const mps::Particles p = scene_file::make_particles(scene);
  std::size_t ghosts = 0, conveyor = 0, plate_walls = 0;
  for (std::size_t i = 0; i < p.size(); ++i) {
    if (p.kind[i] == mps::Kind::ghost) {
      ++ghosts;
      EXPECT_NEAR(p.x[i], -0.55, 1e-12);  // behind the plate's 1 wall + 4 dummy layers, one spacing on
      EXPECT_NEAR(std::fmod(p.y[i] * 30 + 1e-9, 1.0), 0.5, 1e-6);  // (k + 1/2) / 30 of the height
    }
    if (p.group[i] == 4) {
      ++conveyor;
      EXPECT_LT(p.x[i], 0.3);
    }
    if (p.group[i] == 1) {
      EXPECT_GT(p.x[i], 0.3);
    }
    if (p.group[i] == 3 && p.kind[i] == mps::Kind::wall) ++plate_walls;
  }
  EXPECT_EQ(ghosts, 30u);  // 3 rows to each of the 10 spacings of the plate's height
  EXPECT_EQ(conveyor, 8u * 5u);  // x = -0.45 ... 0.25, five layers deep (the top wall has no part)
  EXPECT_EQ(plate_walls, 10u);

  std::shared_ptr<mps::PushingPlate> plate;
  auto sim = scene_file::make_simulation(scene, &plate);
  ASSERT_NE(plate, nullptr);
  const std::size_t fluid0 = sim->particles().count(mps::Kind::fluid);
  while (sim->time() < 0.15) sim->step();
  // 0.15 s at 1 m/s: the plate has stepped back once; the outlet, at the fluid's end, has taken what crossed it.
  EXPECT_EQ(plate->columns_added(), 1);
  EXPECT_EQ(sim->particles().count(mps::Kind::fluid) + static_cast<std::size_t>(plate->particles_removed()),
            fluid0 + plate_walls);

  const auto expect = [&](const std::string& from, const std::string& to, const std::string& part) {
    expect_refusal_of_edit(text, from, to, part);
  };
  expect("plate = 3", "plate = 1", "line 26: the inlet's 'plate' must be the group of a [[wall]] on x_low alone");
  expect("buffer = 0.5", "buffer = 0.2", "line 29: an outflow buffer must be at least 4.1 spacings thick");
  expect("outlet = 2.0", "outlet = 0.2", "line 28: the outlet must lie downstream of the plate");
  expect("no_slip = true\npart", "part", "a 'part' slides beside the rest of a no-slip wall");
  expect("group = 4,", "group = 1,", "a wall's part needs a group other than the wall's");
}

// An elastic gate hung from a mount: the body's moving particles are the fluid's wall (its faces to the water) and
// dummy particles of its group, its clamped rows are not the fluid's, the mount continues its lattice up to `to` with a
// wall face to the water; faults are refused with their line and key.
TEST(SceneFile, ElasticBodyIsTheFluidsWallsAndHangsFromItsMount) {
  const std::string text = R"(dimensions = 2
spacing = 0.01
[tank]
min = [0.0, 0.0]
max = [0.5, 0.3]
walls = ["x_low", "x_high", "y_low"]
[[fluid]]
min = [0.0, 0.0]
max = [0.2, 0.2]
[[elastic]]
min = [0.2, 0.0]
max = [0.24, 0.1]
clamp = "y_high"
walls = ["x_low", "x_high", "y_low"]
mount = {to = 0.3, walls = ["x_low"]}
group = 2
youngs_modulus = 1e6
poisson_ratio = 0.4
[physics]
gravity = 9.81
[numerics]
dt_max = 1e-3
hydrostatic_split = false
[run]
end_time = 0.01
)";
  const auto scene = scene_file::read_scene<2>(write_file("elastic", text));
  const mps::Particles p = scene_file::make_particles(scene);
  std::size_t body = 0, body_walls = 0, mount = 0, mount_walls = 0;
  for (std::size_t i = 0; i < p.size(); ++i) {
    if (p.group[i] == 2) {
      ++body;
      EXPECT_TRUE(p.x[i] > 0.2 && p.x[i] < 0.24 && p.y[i] > 0.0 && p.y[i] < 0.1);  // no clamped row
      const bool face = p.x[i] < 0.21 || p.x[i] > 0.23 || p.y[i] < 0.01;
      EXPECT_EQ(p.kind[i], face ? mps::Kind::wall : mps::Kind::dummy) << p.x[i] << ", " << p.y[i];
      body_walls += face ? 1 : 0;
    } else if (p.group[i] == 0 && p.kind[i] != mps::Kind::fluid && p.x[i] > 0.2 && p.x[i] < 0.24 && p.y[i] > 0.1) {
      ++mount;
      EXPECT_LT(p.y[i], 0.3);
      if (p.kind[i] == mps::Kind::wall) {
        ++mount_walls;
        EXPECT_LT(p.x[i], 0.21);
      }
    }
  }
  EXPECT_EQ(body, 4u * 10u);
  EXPECT_EQ(body_walls, 10u + 10u + 2u);
  EXPECT_EQ(mount, 4u * 20u);
  EXPECT_EQ(mount_walls, 20u);
  // The coupled step runs: the solid is advanced under the fluid's load.
  auto sim = scene_file::make_simulation(scene);
  for (int n = 0; n < 3; ++n) sim->step();
  ASSERT_NE(sim->find<mps::ElasticStructure>(), nullptr);
  EXPECT_GT(sim->find<mps::ElasticStructure>()->substeps(), 0);

  // A displacement probe names the body by its group: it reads the solid's own displacement at its free end.
  const std::string probe =
      "[[probe]]\nname = \"tip\"\nquantity = \"displacement\"\ngroup = 2\npoints = [[0.22, 0.0]]\n";
  const auto probed = scene_file::read_scene<2>(write_file("elastic_probe", text + probe));
  auto probed_sim = scene_file::make_simulation(probed);
  mps::ProbeSeries series = scene_file::read_probes(probed, *probed_sim);
  for (int n = 0; n < 3; ++n) probed_sim->step();
  series.sample(probed_sim->time(), probed_sim->particles());
  const auto expected = probed_sim->find<mps::ElasticStructure>()->solid().displacement_at(0.22, 0.0);
  ASSERT_EQ(series.rows().size(), 1u);
  EXPECT_EQ(series.rows()[0][1], expected[0]);
  EXPECT_EQ(series.rows()[0][2], expected[1]);
  EXPECT_NE(expected[1], 0.0);  // the hanging gate has moved under gravity and the water's push
  std::string other = text + probe;
  other.replace(other.rfind("group = 2"), 9, "group = 3");
  const auto wrong = scene_file::read_scene<2>(write_file("elastic_probe_wrong", other));
  auto wrong_sim = scene_file::make_simulation(wrong);
  try {
    static_cast<void>(scene_file::read_probes(wrong, *wrong_sim));
    ADD_FAILURE() << "a displacement probe of no body's group was read";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("no elastic body has group 3"), std::string::npos) << e.what();
  }

  const auto expect = [&](const std::string& from, const std::string& to, const std::string& part) {
    expect_refusal_of_edit(text, from, to, part);
  };
  expect("max = [0.24, 0.1]", "max = [0.225, 0.1]", "line 12: an elastic body's edges must be whole numbers");
  expect("clamp = \"y_high\"", "clamp = \"top\"", "line 13: 'clamp' must be one of x_low");
  expect("to = 0.3,", "to = 0.12,", "line 15: a mount reaches from the clamp face beyond the clamp's 3 spacings");
  expect("group = 2", "group = 0", "line 16: 'group' must be a whole number from 1");
  expect("poisson_ratio = 0.4", "poisson_ratio = 0.5", "line 18: 'poisson_ratio' must be in (-1, 0.5)");
  expect("min = [0.2, 0.0]\nmax = [0.24", "min = [0.1, 0.0]\nmax = [0.24", "overlaps the [[fluid]] block on line 7");
  const std::string in_3d = refusal("elastic_3d", R"(dimensions = 3
spacing = 0.01
[[fluid]]
min = [0.0, 0.0, 0.0]
max = [0.1, 0.1, 0.1]
[[elastic]]
min = [0.2, 0.0, 0.0]
max = [0.24, 0.1, 0.1]
)");
  EXPECT_NE(in_3d.find("line 6: elastic bodies are 2-D"), std::string::npos) << "got: " << in_3d;
  expect("clamp = \"y_high\"", "clamp = \"y_high\"\nclamp_cylinder = {radius = 1}",
         "line 14: 'clamp_cylinder' is for a body alone");
}

// An elastic body alone: the solid of the box's lattice and its clamp rows, swinging in its first mode at the tip's
// velocity given, under the file's gravity; its displacement probe reads the solid. A key of a fluid's scene, a second
// body or a probe of another quantity or body is refused naming its line.
TEST(SceneFile, ElasticBodyAloneIsTheSolidItsFileDescribes) {
  const std::string text = R"(dimensions = 2
spacing = 0.01
[[elastic]]
min = [0.0, 0.0]
max = [0.1, 0.03]
clamp = "x_low"
youngs_modulus = 1e6
first_mode_tip_velocity = 0.5
[physics]
gravity = 2.0
[run]
end_time = 0.01
[[probe]]
name = "tip"
quantity = "displacement"
group = 1
points = [[0.1, 0.015]]
)";
  const auto scene = scene_file::read_scene<2>(write_file("alone", text));
  ASSERT_TRUE(scene.solid_alone);
  mps::ElasticSolid solid = scene_file::make_solid(scene);
  ASSERT_EQ(solid.moving(), 10u * 3u);
  ASSERT_EQ(solid.size(), 13u * 3u);
  EXPECT_EQ(solid.config().gravity_y, -2.0);
  EXPECT_EQ(solid.config().material.youngs_modulus, 1e6);
  for (std::size_t i = 0; i < solid.size(); ++i) {
    const double x = solid.reference_x()[i];
    EXPECT_EQ(solid.u()[i], 0.0);
    EXPECT_EQ(solid.v()[i], i < solid.moving() ? 0.5 * mps::cantilever_first_mode(x, 0.1) : 0.0) << x;
    EXPECT_EQ(x < 0, i >= solid.moving());  // the clamp rows to x < 0 are held
  }
  mps::ProbeSeries probes = scene_file::read_solid_probes(scene, solid);
  for (int n = 0; n < 5; ++n) solid.step();
  probes.sample(solid.time(), mps::Particles{});
  ASSERT_EQ(probes.rows().size(), 1u);
  EXPECT_EQ(probes.rows()[0][2], solid.displacement_at(0.1, 0.015)[1]);
  EXPECT_GT(probes.rows()[0][2], 0.0);  // the tip has moved up with its velocity

  const auto expect = [&](const std::string& from, const std::string& to, const std::string& part) {
    expect_refusal_of_edit(text, from, to, part);
  };
  expect("clamp = \"x_low\"", "clamp = \"x_low\"\nwalls = [\"y_high\"]", "line 7: 'walls' is for a body among fluid");
  expect("[run]", "[numerics]\ndt_max = 1e-3\n[run]", "line 11: a scene of an elastic body alone (no [[fluid]]) has "
                                                      "no 'numerics'");
  expect("[physics]", "[[elastic]]\nmin = [0.0, 0.1]\nmax = [0.1, 0.13]\nclamp = \"x_low\"\n[physics]",
         "line 3: a scene without fluid steps one elastic body alone; this file has 2");
  expect("gravity = 2.0", "gravity = 2.0\nviscosity = 1e-6", "'viscosity' is no key of [physics] of a body alone");
  expect("clamp = \"x_low\"", "clamp = \"y_low\"\nclamp_cylinder = {centre = [0.0, -0.05], radius = 0.05}",
         "line 7: a body is held in a cylinder at its x_low face");
  expect("clamp = \"x_low\"", "clamp = \"x_low\"\nclamp_cylinder = {centre = [-0.2, 0.015], radius = 0.05}",
         "line 7: the cylinder must reach the body's x_low face");
  expect("clamp = \"x_low\"", "clamp = \"x_low\"\nclamp_cylinder = {centre = [-0.005, 0.015], radius = 0.008}",
         "line 7: every row of the body must meet the cylinder");
  const auto probe_refusal = [&](const std::string& from, const std::string& to, const std::string& part) {
    std::string edited = text;
    edited.replace(edited.find(from), from.size(), to);
    const auto s = scene_file::read_scene<2>(write_file("alone_probe", edited));
    const mps::ElasticSolid body = scene_file::make_solid(s);
    try {
      static_cast<void>(scene_file::read_solid_probes(s, body));
      ADD_FAILURE() << "read after '" << from << "' -> '" << to << "'";
    } catch (const std::invalid_argument& e) {
      EXPECT_NE(std::string(e.what()).find(part), std::string::npos) << e.what();
    }
  };
  probe_refusal("quantity = \"displacement\"", "quantity = \"pressure\"",
                "line 15: probe 'tip': an elastic body alone has displacement probes only");
  probe_refusal("group = 1", "group = 2", "line 16: probe 'tip': the body's group is 1");
}

// An acoustic file: the box, boundary, flow and numerics into the solver's configuration, its pulses, the times past
// the end dropped and the end sampled; each defect refused naming its line.
TEST(SceneFile, AcousticFileIsTheCaseItDescribes) {
  const std::string text = R"(dimensions = 2
spacing = 0.5
[acoustic]
min = [-10.0, -5.0]
max = [10.0, 5.0]
boundary = "mur"
mean_flow = [20.0, 0.0]
repeat_frequency = 100.0
[[pulse]]
centre = [1.0, 0.5]
amplitude = 2.0
half_width = 1.0
[run]
end_time = 0.05
[output]
samples = [0.1, 0.02]
maps = [0.0, 0.2]
)";
  const fs::path path = write_file("acoustic", text);
  ASSERT_TRUE(scene_file::is_acoustic(path));
  const auto scene = scene_file::read_acoustic_scene(path);
  const acoustic::AcousticRun& run = scene.run;
  EXPECT_EQ(run.config.box.x0, -10.0);
  EXPECT_EQ(run.config.box.y1, 5.0);
  EXPECT_EQ(run.config.l0, 0.5);
  EXPECT_EQ(run.config.u0x, 20.0);
  EXPECT_EQ(run.config.boundary, mps::AcousticBoundary::mur);
  ASSERT_EQ(run.sources.size(), 1u);
  EXPECT_EQ(run.sources[0].x, 1.0);
  EXPECT_EQ(run.sources[0].amplitude, 2.0);
  EXPECT_EQ(run.sources[0].half_width, 1.0);
  EXPECT_TRUE(run.repeated);
  EXPECT_EQ(run.frequency, 100.0);
  EXPECT_EQ(run.samples, (std::vector<double>{0.02, 0.05}));  // 0.1 is past the end, which is sampled
  EXPECT_EQ(run.maps, (std::vector<double>{0.0}));
  EXPECT_EQ(run.frames, -1);  // a frame at every map
  EXPECT_EQ(scene_file::read_acoustic_scene(path, 0.3).run.samples, (std::vector<double>{0.02, 0.1, 0.3}));

  const auto expect = [&](const std::string& from, const std::string& to, const std::string& part) {
    expect_refusal_of_edit(text, from, to, part);
  };
  expect("boundary = \"mur\"", "boundary = \"hard\"", "line 7: hard walls with a mean flow have no exact solution");
  expect("boundary = \"mur\"", "boundary = \"open\"", "line 6: unknown acoustic boundary 'open'");
  expect("centre = [1.0, 0.5]", "centre = [11.0, 0.5]", "line 10: a pulse's centre must lie inside the box");
  expect("half_width = 1.0", "half_width = 3.0", "line 12: 'half_width' must be in (0, 2.5] m");
  expect("mean_flow = [20.0, 0.0]", "mean_flow = [400.0, 0.0]", "line 7: the mean flow must be below the speed");
  expect("[[pulse]]", "[[pulses]]", "'pulses' is no key of an acoustic scene file");
  expect("dimensions = 2", "dimensions = 3", "line 1: the acoustic solver is 2-D");
  expect("end_time = 0.05", "end_time = 1e-6", "the end time is shorter than one step");
  expect("max = [10.0, 5.0]", "max = [10.2, 5.0]", "line 3: acoustic config: box width 20.2 m is not a multiple of l0");
}

}  // namespace
