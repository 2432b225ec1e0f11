// Fluid-structure interaction (seed 003 §2.4): the classic dam-break column hits an elastic plate clamped to the
// tank's floor. Writes tip.csv (the plate top's displacement and the fluid's force on the plate), frames and
// summary.json to --out.
#include <CLI/CLI.hpp>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <iostream>

#include "checks.hpp"
#include "mps/io.hpp"
#include "mps/version.hpp"
#include "plate.hpp"
#include "run_json.hpp"

namespace fs = std::filesystem;

int main(int argc, char** argv) {
  std::setvbuf(stdout, nullptr, _IOLBF, 0);
  fsi::PlateParams p;
  std::string out = "runs/fsi";
  int frames = 20;
  CLI::App app{"SparseMPS fluid-structure interaction: a dam-break column hits an elastic plate (seed 003 §2.4)"};
  app.set_version_flag("--version", std::string("SparseMPS ") + mps::version);
  app.add_option("--dx", p.l0, "spacing of fluid and plate [m]; must divide the plate's 0.012 m and 0.08 m (the seed: "
                 "0.002)")->capture_default_str()->check(positive_up_to(0.012));
  app.add_option("--modulus", p.youngs_modulus, "the plate's Young's modulus [Pa] (the seed: 6e6, 1.2e7, 2.38e7)")
      ->capture_default_str()->check(number_in(1e4, 1e10));
  app.add_option("--poisson", p.poisson_ratio, "the plate's Poisson ratio (not given by the seed)")
      ->capture_default_str()->check(number_in(0.0, 0.49));
  app.add_flag("--rigid", p.rigid, "the plate as fixed wall particles");
  app.add_option("--solid-cfl", p.solid_cfl, "the plate's own time step: CFL of its p-wave speed")
      ->capture_default_str()->check(positive_up_to(2.0));
  app.add_option("--relaxation", p.relaxation, "fraction of the way the plate's load moves to each new pressure "
                 "force (1: none; filters MPS's step-to-step wall-pressure noise)")->capture_default_str()
      ->check(number_in(0.01, 1.0));
  app.add_option("--end-time", p.end_time, "simulated time [s]")->capture_default_str()->check(positive_up_to(100));
  app.add_option("--solver", p.solver, "pressure solver spec")->capture_default_str();
  app.add_option("--frames", frames, "number of .vtp frames to write")->capture_default_str()->check(whole_in(0, 100000));
  app.add_option("--out", out, "output directory")->capture_default_str();
  CLI11_PARSE(app, argc, argv);
  try {
    check_run_size((4 * 0.146 / p.l0 + 10) * (3 * 0.146 / p.l0 + 5), p.end_time * 2.4 / (0.2 * p.l0), "raise --dx",
                   "shorten --end-time");
    fsi::PlateScene scene(p);
    const mps::Simulation& sim = scene.sim();
    const nlohmann::json params{
        {"scene", "dam break on a plate"}, {"dx_m", p.l0}, {"column_width_m", scene.column_width()},
        {"plate_height_m", p.plate_height}, {"plate_thickness_m", p.plate_thickness},
        {"plate_upstream_face_x_m", 2 * p.column_width}, {"rigid", p.rigid}, {"youngs_modulus_pa", p.youngs_modulus},
        {"poisson_ratio", p.poisson_ratio}, {"plate_density", p.plate_density}, {"solid_cfl", p.solid_cfl}, {"load_relaxation", p.relaxation},
        {"end_time_s", p.end_time}, {"solver", sim.solver().spec()}, {"hydrostatic_split", false},
        {"coupling", "staggered: solid advanced to t^{n+1} under the force of step n, in its own sub-steps"},
        {"version", mps::version}};
    std::cout << "dam break on a " << (p.rigid ? "rigid" : "elastic") << " plate: "
              << sim.particles().count(mps::Kind::fluid) << " fluid particles, " << scene.plate_particles()
              << " plate particles, dx " << p.l0 << " m, to t = " << p.end_time << " s\n";
    const fs::path dir(out);
    clear_outputs(dir, {"frames", "fsi.pvd", "tip.csv", "summary.json", "last_good.vtp"});
    fs::create_directories(dir / "frames");
    FrameSeries series(dir, "fsi", frames, p.end_time);
    series.write_if_due(sim);
    double next_report = p.end_time / 10;
    try {
      while (!scene.done()) {
        scene.step();
        series.write_if_due(sim);
        if (sim.time() >= next_report - 1e-12) {
          const auto& s = scene.samples().back();
          std::printf("t = %.3f s  step %d  tip (%.5f, %.5f) m  force on the plate %.2f N/m  solid sub-steps %d\n",
                      s.time, sim.last_step().step, s.tip_x, s.tip_y, s.force_x,
                      scene.structure() ? scene.structure()->substeps() : 0);
          next_report += p.end_time / 10;
        }
      }
    } catch (const mps::SimulationError& e) {
      return report_guard_stop(dir, e, params, sim);
    }
    std::vector<double> t, ux, uy, fx;
    double most = 0, at = 0;
    for (const auto& s : scene.samples()) {
      t.push_back(s.time);
      ux.push_back(s.tip_x);
      uy.push_back(s.tip_y);
      fx.push_back(s.force_x);
      if (std::abs(s.tip_x) > std::abs(most)) {
        most = s.tip_x;
        at = s.time;
      }
    }
    mps::write_csv(dir / "tip.csv", {"t", "ux", "uy", "force_x"}, {t, ux, uy, fx});
    nlohmann::json checks{{"largest_tip_ux_m", most}, {"at_s", at}};
    if (const auto* st = scene.structure()) {
      const auto& e = st->solid().energy();
      const double body = e.kinetic + e.strain + e.hourglass + e.gravity;
      checks["pressure_work_on_plate_j_per_m"] = st->solid().external_work();
      checks["plate_energy_j_per_m"] = body;
    }
    mps::write_json(dir / "summary.json",
                    {{"status", "completed"}, {"parameters", params}, {"steps", sim.last_step().step},
                     {"time_s", sim.time()}, {"checks", checks},
                     {"timings", timings_json(sim.times(), sim.last_step().step, sim.particles().size())}});
    std::printf("\nlargest tip displacement %.5f m at t = %.3f s; outputs in %s\n", most, at, dir.string().c_str());
    return 0;
  } catch (const std::exception& e) {
    std::cerr << "error: " << error_message(e) << "\n";
    return 1;
  }
}
