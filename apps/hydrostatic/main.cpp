// Hydrostatic tank demo: a water column settles under gravity, in 2-D or 3-D (--dim); the band-averaged pressure is
// compared with rho g (H - y). Writes frames (.vtp/.pvd), pressure.csv and summary.json to --out.
#include <CLI/CLI.hpp>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <iostream>

#include "checkpoints.hpp"
#include "checks.hpp"
#include "console.hpp"
#include "help.hpp"
#include "mps/io/io.hpp"
#include "openmp_wait.hpp"
#include "probe_file.hpp"
#include "ranks.hpp"
#include "run_config.hpp"
#include "run_json.hpp"
#include "solve_log.hpp"
#include "solver_cli.hpp"
#include "tank.hpp"

namespace fs = std::filesystem;

namespace {

template <int D>
nlohmann::json params_json(const tank::Params& p, const mps::BasicSimulation<D>& sim) {
  const auto& c = sim.config();
  return {{"scene", "hydrostatic tank"}, {"dimensions", D},
          {"width_m", p.width}, {"height_m", p.water_height}, {"dx_m", p.l0}, {"gamma", p.gamma},
          {"beta", c.beta}, {"dt_s", p.dt}, {"end_time_s", p.end_time}, {"window_s", p.window},
          {"band_l0", p.band}, {"g_m_per_s2", p.g}, {"rho_kg_per_m3", c.rho}, {"nu_m2_per_s", c.nu},
          {"simulation_config", mps::config_json(c)}, {"solver", sim.solver().spec()},
          {"physics_on", {"gravity", "viscosity (explicit)", "free surface"}},
          {"wall_layers", 1}, {"dummy_layers", 4}};
}

// The run once the options are read: the scene in D dimensions, its frames, pressure.csv and summary.json.
template <int D>
int run(const tank::Params& p, const CLI::App& app, const std::string& out, const std::string& probes, int frames,
        double tolerance, const std::vector<int>& export_ppe, const CheckpointOptions& checkpoint_options);

}  // namespace

int main(int argc, char** argv) {
  prefer_passive_openmp_wait(argv);
  require_one_process(AppRanks(&argc, &argv), "hydrostatic");
  record_run("hydrostatic", argc, argv);
  std::setvbuf(stdout, nullptr, _IOLBF, 0);  // progress lines reach a log file as they are printed
  tank::Params p;
  std::string out = "runs/hydrostatic", probes;
  int frames = 20, dim = 2;
  double tolerance = 0.05, dx = 0;
  CLI::App app{"SparseMPS hydrostatic tank: water at rest under gravity, pressure against rho g (H - y)"};
  add_general_options(app);
  app.add_option("--dim", dim, "2: a rectangle of water, gravity along -y; 3: a square box of it, gravity along -z")
      ->capture_default_str()->check(CLI::IsMember({2, 3}))->group("Scene");
  app.add_option("--width", p.width, "tank width (both widths in 3-D) [m]")->capture_default_str()->check(positive_up_to(1e3))
      ->group("Scene");
  app.add_option("--height", p.water_height, "water height H [m]")->capture_default_str()
      ->check(positive_up_to(1e3))->group("Scene");
  app.add_option("--dx", dx, "particle spacing l0 (default: 0.01 in 2-D, 0.04 in 3-D) [m]")
      ->check(positive_up_to(1e3))->group("Numerics");
  app.add_option("--gamma", p.gamma, "mixed source weight in [0,1] (1: number density only)")->capture_default_str()
      ->check(number_in(0.0, 1.0))->group("Numerics");
  app.add_option("--dt", p.dt, "time step dt_max [s]")->capture_default_str()->check(positive_up_to(10))
      ->group("Numerics");
  add_solver_options(app, p.solver);
  app.add_option("--end-time", p.end_time, "simulated time [s]")->capture_default_str()->check(positive_up_to(1e6))
      ->group("Run");
  app.add_option("--window", p.window, "pressures averaged over the last WINDOW seconds [s]")->capture_default_str()
      ->check(positive_up_to(1e6))->group("Run");
  app.add_option("--band", p.band, "height of averaging bands (at most H / l0) [l0]")->capture_default_str()
      ->check(number_in(1.0, 1e6))->group("Run");
  app.add_option("--tolerance", tolerance, "pass if every band below the top is within this relative error")
      ->capture_default_str()->check(positive_up_to(10))->group("Run");
  app.add_option("--out", out, "output directory")->check(output_directory())->capture_default_str()->group("Output");
  app.add_option("--frames", frames, "number of .vtp frames to write")->capture_default_str()
      ->check(whole_in(0, 100000))->group("Output");
  add_probes_option(app, probes);
  std::vector<int> export_ppe;
  add_export_ppe_option(app, export_ppe);
  CheckpointOptions checkpoint_options;
  add_checkpoint_options(app, checkpoint_options);
  if (const auto status = parse_options(app, argc, argv)) return *status;

  p.l0 = dx > 0 ? dx : dim == 2 ? 0.01 : 0.04;
  try {
    return dim == 2 ? run<2>(p, app, out, probes, frames, tolerance, export_ppe, checkpoint_options)
                    : run<3>(p, app, out, probes, frames, tolerance, export_ppe, checkpoint_options);
  } catch (const std::exception& e) {
    std::cerr << "error: " << error_message(e) << "\n";
    return 1;
  }
}

namespace {

template <int D>
int run(const tank::Params& p, const CLI::App& app, const std::string& out, const std::string& probes, int frames,
        double tolerance, const std::vector<int>& export_ppe, const CheckpointOptions& checkpoint_options) {
  const double across = p.width / p.l0 + 10.0;
  check_run_size((D == 2 ? across : across * across) * (1.2 * p.water_height / p.l0 + 5.0), p.end_time / p.dt,
                 "raise --dx", "shorten --end-time or raise --dt");
  tank::BasicTank<D> scene(p);
  const mps::BasicSimulation<D>& sim = scene.sim();
  nlohmann::json params = params_json(p, sim);
  if (!probes.empty()) params["probes_file"] = probes;
  std::cout << parameter_table(
      "hydrostatic tank, " + std::to_string(D) + "-D: " + std::to_string(sim.particles().size()) + " particles (" +
          std::to_string(sim.particles().count(mps::Kind::fluid)) + " fluid)",
      params,
      {{"scene", {"dimensions", "width_m", "height_m", "g_m_per_s2", "rho_kg_per_m3", "nu_m2_per_s"}},
       {"numerics", {"dx_m", "gamma", "beta", "dt_s"}},
       {"solver", {"solver"}},
       {"run", {"end_time_s", "window_s", "band_l0"}}});
  const fs::path dir(out);
  Checkpoints checkpoints(checkpoint_options, dir, "hydrostatic", params, {"/end_time_s"});
  if (!checkpoints.restart())
    clear_outputs(dir, {"frames", "tank.pvd", "pressure.csv", "summary.json", "last_good.vtp", "config.toml",
                        "solves.csv", "ppe", "checkpoint.cbor", "probes.csv"});
  scene.sim().template add<BasicSolveLog<D>>(dir, std::set<int>(export_ppe.begin(), export_ppe.end()),
                                             "hydrostatic tank, " + std::to_string(D) + "-D");
  write_run_config(app, "hydrostatic", dir);
  fs::create_directories(dir / "frames");
  FrameSeries series(dir, "tank", frames, p.end_time);
  attach_probes(series, probes, scene.sim());
  double next_report = 0.1;
  const std::function<nlohmann::json()> save = [&] { return scene_state(scene, series, next_report); };
  if (!restore_scene(checkpoints, scene.sim(), scene, series, next_report)) series.write_if_due(sim);
  const auto step = [&] { scene.step(); };
  const auto done = [&] { return scene.done(); };
  if (const auto stopped =
          step_to_end(scene.sim(), step, done, p.end_time, 0.1, next_report, series, checkpoints, save, dir, params))
    return *stopped;

  const tank::Result r = scene.result();
  std::vector<double> y, measured, exact, error;
  for (const auto& b : r.bands) {
    y.push_back(b.y_center);
    measured.push_back(b.mean_pressure);
    exact.push_back(b.exact_pressure);
    error.push_back(b.relative_error);
  }
  mps::write_csv(dir / "pressure.csv", {D == 2 ? "y_m" : "z_m", "mean_pressure_pa", "exact_pressure_pa", "relative_error"},
                 {y, measured, exact, error});
  const bool pass = r.max_error_below_top <= tolerance;
  write_solves(dir, sim);
  write_summary(dir,
                {{"status", pass ? "passed" : "check failed"}, {"parameters", params},
                 {"particles", {{"fluid", r.fluid}, {"boundary", r.boundary}}}, {"steps", r.steps},
                 {"time_s", r.time}, {"dt_limit", r.dt_limit},
                 {"checks", {{"max_band_pressure_error", r.max_error_below_top},
                             {"tolerance", tolerance},
                             {"max_displacement_l0", r.max_displacement_l0}}},
                 {"timings", timings_json(sim.times(), r.steps, sim.particles().size())}});
  std::printf("\nband  %s [m]    mean P [Pa]   rho g (H-%s) [Pa]   error\n", D == 2 ? "y" : "z", D == 2 ? "y" : "z");
  for (std::size_t b = 0; b < r.bands.size(); ++b)
    std::printf("%4zu  %.4f  %11.2f  %11.2f        %6.2f %%%s\n", b, r.bands[b].y_center, r.bands[b].mean_pressure,
                r.bands[b].exact_pressure, 100 * r.bands[b].relative_error,
                b + 1 == r.bands.size() ? "  (top band, not checked)" : "");
  std::printf("\ncheck: max band pressure error below the top band %.2f %% (limit %.1f %%): %s\n"
              "drift: the farthest fluid particle ended %.3f l0 from its start\n",
              100 * r.max_error_below_top, 100 * tolerance, pass ? "PASS" : "FAIL", r.max_displacement_l0);
  std::printf("outputs: %s (ParaView), %s, %s\n", series.path().string().c_str(), (dir / "pressure.csv").string().c_str(),
              (dir / "summary.json").string().c_str());
  return pass ? 0 : 2;
}

}  // namespace
