// A tank of water at rest, built from the library in a page: particles on a lattice, walls, the step with its
// defaults, and probes (mps/io/probes.hpp) that read the pressure on a vertical line and the water level as it runs.
// The pressure is rho g (H - y) and the level H: the program checks both and exits 1 if either is off, so the
// tests run it as it is (examples/README.md).
//
//   build/release/examples/cpp/tank_probes [end_time_s] [out.csv]
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <string>

#include "mps/boundaries/geometry.hpp"
#include "mps/io/probes.hpp"
#include "mps/step/step.hpp"

int main(int argc, char** argv) {
  const double end_time = argc > 1 ? std::atof(argv[1]) : 0.5;
  const std::string out = argc > 2 ? argv[2] : "tank_probes.csv";
  const double l0 = 0.01, width = 0.3, height = 0.2, g = 9.81, rho = 1000.0;

  mps::Particles particles;
  mps::fill_rectangle(particles, {0.0, 0.0, width, height}, l0, mps::Kind::fluid);
  mps::add_rectangle_walls(particles, {0.0, 0.0, width, 1.5 * height}, l0, mps::left | mps::right | mps::bottom, 1, 4);
  mps::SimulationConfig config;
  config.l0 = l0;
  config.fy = -g;
  config.dt_max = 1e-3;
  mps::Simulation sim(std::move(particles), mps::Domain{-0.1, width + 0.1, -0.1, 2 * height}, config);

  mps::ProbeSeries probes(0.05);  // a sample every 0.05 s
  const mps::Kernel kernel = mps::make_kernel(2.1, l0);
  probes.add(mps::pressure_probe<2>("p", mps::line_points<2>({0.15, 0.02}, {0.15, 0.14}, 7), kernel));
  probes.add(mps::level_probe<2>("level", {{0.15, 0.0}}, l0));
  probes.sample(sim.time(), sim.particles());
  while (sim.time() < end_time - 1e-9) {
    sim.step();
    probes.sample(sim.time(), sim.particles());
  }
  probes.write_csv(out);

  // The last sample against the exact hydrostatic pressure and the water's height.
  const std::vector<double>& last = probes.rows().back();
  const auto& line = probes.probes()[0].points;
  double worst = 0.0;
  for (std::size_t k = 0; k < line.size(); ++k) {
    const double exact = rho * g * (height - line[k][1]);
    worst = std::max(worst, std::abs(last[1 + k] - exact) / exact);
  }
  const double level = last.back();
  const bool ok = worst < 0.01 && std::abs(level - height) < 0.5 * l0;
  std::printf("t = %.2f s, %d steps: pressure within %.3f %% of rho g (H - y) on the line, level %.4f m (H = %.2f m)"
              " %s; probes in %s\n",
              sim.time(), sim.last_step().step, 100 * worst, level, height, ok ? "ok" : "FAIL", out.c_str());
  return ok ? 0 : 1;
}
