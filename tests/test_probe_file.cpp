// The apps' --probes files (apps/common/probe_file.hpp): every kind of probe read into the library's series, and
// every malformed file refused with its line and the key at fault.
#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <string>

#include "mps/boundaries/geometry.hpp"
#include "probe_file.hpp"

namespace {

namespace fs = std::filesystem;

// Named by the process too: ctest runs the tests in parallel processes, which must not share a file.
fs::path write_file(const std::string& name, const std::string& text) {
  const fs::path path = fs::temp_directory_path() /
                        ("sparsemps_probe_file_" + std::to_string(::getpid()) + "_" + name + ".toml");
  std::ofstream(path) << text;
  return path;
}

mps::Simulation still_water(bool split) {
  const double l0 = 0.02;
  mps::Particles s;
  mps::fill_rectangle(s, {0.0, 0.0, 0.4, 0.2}, l0, mps::Kind::fluid);
  mps::add_rectangle_walls(s, {0.0, 0.0, 0.4, 0.3}, l0, mps::left | mps::right | mps::bottom, 1, 2, 1);
  mps::SimulationConfig c;
  c.l0 = l0;
  c.fy = -9.81;
  c.dt_max = 1e-3;
  c.hydrostatic_split = split;
  return mps::Simulation(s, mps::Domain{-0.1, 0.5, -0.1, 0.4}, c);
}

// Every kind of probe a file can describe, with its points from a list, a line and a plane, in the file's order;
// read at t = 0 the level probe gives the water's depth.
TEST(ProbeFile, EveryKindOfProbeIsReadInTheFilesOrder) {
  mps::Simulation sim = still_water(false);
  const fs::path path = write_file("all", R"(interval = 0.01
[[probe]]
name = "p"
quantity = "pressure"
line = { from = [0.1, 0.05], to = [0.3, 0.05], count = 3 }
[[probe]]
name = "wall"
quantity = "pressure"
method = "patch"
points = [[0.0, 0.05]]
normal_axis = 0
reach = 0.04
half_size = 0.02
[[probe]]
name = "u"
quantity = "velocity"
kernel_radius = 3.1
plane = { origin = [0.1, 0.05], edge1 = [0.2, 0.0], edge2 = [0.0, 0.1], count = [2, 2] }
[[probe]]
name = "depth"
quantity = "level"
method = "wire"
points = [[0.2, 0.0]]
[[probe]]
name = "floor"
quantity = "force"
group = 1
)");
  mps::ProbeSeries series = read_probe_file<2>(path, sim);
  EXPECT_EQ(series.interval(), 0.01);
  ASSERT_EQ(series.probes().size(), 5u);
  EXPECT_EQ(series.probes()[0].points.size(), 3u);
  EXPECT_EQ(series.probes()[2].points.size(), 4u);
  EXPECT_EQ(series.columns().size(), 1u + 3 + 1 + 8 + 1 + 2);
  series.sample(0.0, sim.particles());
  EXPECT_NEAR(series.rows()[0][13], 0.2, 1e-12);  // the wire over the floor: the water's depth
  fs::remove(path);
}

// Each malformed file is refused naming its line and what to change.
TEST(ProbeFile, MalformedFilesAreRefusedWithTheLineAndTheKey) {
  const std::string head = "[[probe]]\nname = \"p\"\nquantity = \"pressure\"\n";
  const std::vector<std::pair<std::string, std::string>> cases = {
      {"interval = 0.01\n", "probes are listed as [[probe]] tables"},
      {"intervall = 0.01\n" + head + "points = [[0.1, 0.1]]\n", "line 1: 'intervall' is no key of a probe file"},
      {head + "points = [[0.1, 0.1]]\nradius = 2\n", "line 5: 'radius' is no key of a [[probe]]"},
      {head + "points = [[0.1, 0.1, 0.2]]\n", "line 4: 'points' must be a point of 2 numbers"},
      {head + "points = [[0.1, \"a\"]]\n", "line 4: 'points' must be a number"},
      {head, "needs exactly one of 'points', 'line' and 'plane'"},
      {head + "points = [[0.1, 0.1]]\nline = { from = [0, 0], to = [1, 1], count = 2 }\n", "exactly one of"},
      {head + "line = { from = [0, 0], to = [1, 1] }\n", "a line needs 'count'"},
      {head + "line = { from = [0, 0], to = [1, 1], count = 0 }\n", "'count' must be a whole number"},
      {head + "line = { from = [0, 0], to = [1, 1], count = 2, step = 1 }\n", "'step' is no key of a line"},
      {"[[probe]]\nname = \"p\"\nquantity = \"temperature\"\npoints = [[0.1, 0.1]]\n",
       "line 3: probe 'p': quantity 'temperature' is none of"},
      {head + "method = \"nearest\"\npoints = [[0.1, 0.1]]\n", "line 4: probe 'p': the pressure's method is kernel or patch"},
      {head + "method = \"patch\"\npoints = [[0.1, 0.1]]\nnormal_axis = 0\n", "a patch needs 'reach'"},
      {head + "method = \"patch\"\npoints = [[0.1, 0.1]]\nnormal_axis = 5\nreach = 0.1\n", "normal axis"},
      {head + "points = [[0.1, 0.1]]\nkernel_radius = 0.5\n", "radius"},
      {head + "points = [[0.1, 0.1]]\n" + head + "points = [[0.2, 0.1]]\n", "line 5: probe 'p': the name is taken"},
      {"[[probe]]\nname = \"a b\"\nquantity = \"level\"\npoints = [[0.1, 0.0]]\n", "a name is letters, digits"},
      {"[[probe]]\nquantity = \"level\"\npoints = [[0.1, 0.0]]\n", "line 1: a [[probe]] needs 'name'"},
      {head + "points = [[0.1, 0.1]\n", "line 4, column"},  // a TOML syntax error
      {"[[probe]]\nname = \"f\"\nquantity = \"force\"\n", "a [[probe]] needs 'group'"},
  };
  mps::Simulation sim = still_water(false);
  for (std::size_t k = 0; k < cases.size(); ++k) {
    const fs::path path = write_file("bad" + std::to_string(k), cases[k].first);
    try {
      read_probe_file<2>(path, sim);
      ADD_FAILURE() << "accepted: " << cases[k].first;
    } catch (const std::invalid_argument& e) {
      const std::string what = e.what();
      EXPECT_NE(what.find("probe file " + path.string()), std::string::npos) << what;
      EXPECT_NE(what.find(cases[k].second), std::string::npos) << what;
    }
    fs::remove(path);
  }
  // A force needs the whole pressure: refused where the run splits off its hydrostatic part.
  mps::Simulation split = still_water(true);
  const fs::path path = write_file("split", "[[probe]]\nname = \"f\"\nquantity = \"force\"\ngroup = 1\n");
  EXPECT_THROW(read_probe_file<2>(path, split), std::invalid_argument);
  // ... and force probes are 2-D.
  mps::Simulation3 sim3 = [] {
    mps::Particles3 s;
    mps::fill_box(s, {0.0, 0.0, 0.0, 0.2, 0.2, 0.2}, 0.04, mps::Kind::fluid);
    mps::SimulationConfig c;
    c.l0 = 0.04;
    c.dt_max = 1e-3;
    return mps::Simulation3(s, mps::Domain3{-0.2, 0.4, -0.2, 0.4, -0.2, 0.4}, c);
  }();
  EXPECT_THROW(read_probe_file<3>(path, sim3), std::invalid_argument);
  fs::remove(path);
}

}  // namespace
