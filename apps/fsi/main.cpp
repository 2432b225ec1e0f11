// Fluid-structure interaction (seed 003 §2.3-2.4): the classic dam-break column hits an elastic plate clamped to the
// tank's floor (plate), or water opens a rubber gate (gate). Writes tip.csv (the probe's displacement, the load on
// the body, the water level behind the gate), frames and summary.json to --out.
#include <CLI/CLI.hpp>
#include <chrono>
#include <cmath>
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
#include "scene.hpp"
#include "solve_log.hpp"
#include "solver_cli.hpp"

namespace fs = std::filesystem;

namespace {


// The command line.
struct Options {
  fsi::Params p;
  std::string out = "runs/fsi", scene_name = "plate", gradient, probes;
  double dx = 0, modulus = 0, poisson = 0, end_time = 0;
  int frames = 20;
  std::vector<int> export_ppe;
  CheckpointOptions checkpoints;
};

void add_options(CLI::App& app, Options& o) {
  add_general_options(app);
  add_two_d_only_option(app, "the elastic solid is 2-D");
  app.add_option("--scene", o.scene_name, "plate: dam break on a plate 0.08 m high, 0.012 m thick; gate: water 0.14 m "
                 "deep held by a rubber gate 0.079 m long, 0.005 m thick")
      ->capture_default_str()->check(CLI::IsMember({"plate", "gate"}))->group("Scene");
  app.add_option("--modulus", o.modulus, "the body's Young's modulus (default: plate 6e6, the seed also 1.2e7 and "
                 "2.38e7; gate 1.0e7 from the seed's K = 1.67e7, G = 3.57e6) [Pa]")->check(number_in(1e4, 1e10))
      ->group("Scene");
  app.add_option("--poisson", o.poisson, "the body's Poisson ratio (default: plate 0.4, not given by the seed; gate "
                 "0.40 from K and G)")->check(number_in(0.0, 0.49))->group("Scene");
  app.add_flag("--rigid", o.p.rigid, "the body as fixed wall particles")->group("Scene");
  app.add_option("--density", o.p.density, "the body's density (the seed: 1100; water is 1000) [kg/m^3]")
      ->capture_default_str()->check(number_in(10.0, 1e5))->group("Scene");
  app.add_option("--dx", o.dx, "spacing of fluid and body; must divide the body's thickness (default: plate 0.004, "
                 "the seed's 0.002; gate 0.00125, the seed's 0.001) [m]")->check(positive_up_to(0.005))
      ->group("Numerics");
  app.add_option("--cfl", o.p.cfl, "the fluid's time step: dt <= CFL l0 / |u|max")->capture_default_str()
      ->check(positive_up_to(2.0))->group("Numerics");
  app.add_option("--solid-cfl", o.p.solid_cfl, "the plate's own time step: CFL of its p-wave speed")
      ->capture_default_str()->check(positive_up_to(2.0))->group("Numerics");
  app.add_option("--relaxation", o.p.relaxation, "fraction of the way the body's load moves to each new pressure force "
                 "(1: none; filters MPS's step-to-step wall-pressure noise)")->capture_default_str()
      ->check(number_in(0.01, 1.0))->group("Numerics");
  app.add_option("--wet-walls", o.p.wet_walls, "walls next to the liquid's interior carry pressure even where the "
                 "density test calls them dry (mps::WetWalls): true | false")->default_str(o.p.wet_walls ? "true" : "false")
      ->check(true_or_false())->group("Numerics");
  app.add_option("--pressure-gradient", o.gradient, "conservative: every pressure pair equal and opposite, the body gets "
                 "exactly the fluid's push back (still water does not stay at rest with it); min-reference: the "
                 "body's load is -V grad P, corrected (default: plate conservative, gate min-reference; docs/fsi.md)")
      ->check(CLI::IsMember({"min-reference", "conservative"}))->group("Numerics");
  add_pressure_treatment_option(app, o.p.pressure_treatment);
  app.add_option("--collision", o.p.collision, "close pairs collide: two particles nearer than this that approach each "
                 "other keep only the dam break's restitution of their approach speed (0: off) [l0]")
      ->capture_default_str()->check(number_in(0.0, 0.99))->group("Numerics");
  app.add_option("--asymmetry", o.p.asymmetry, "free surface also where the neighbours lie one-sided: above this "
                 "fraction of a flat surface's asymmetry (0: the density test alone)")
      ->capture_default_str()->check(number_in(0.0, 10.0))->group("Numerics");
  app.add_option("--stabilisation-distance", o.p.stabilisation_distance, "with ds in --pressure-treatment: the "
                 "corrector puts pairs nearer than this back at it (dynamic stabilisation) [l0]")
      ->capture_default_str()->check(number_in(0.01, 0.99))->group("Numerics");
  app.add_option("--solver", o.p.solver, "pressure solver spec")->capture_default_str()->group("Solver");
  app.add_option("--end-time", o.end_time, "simulated time (default: plate 0.3, gate 0.4) [s]")
      ->check(positive_up_to(100))->group("Run");
  app.add_option("--out", o.out, "output directory")->check(output_directory())->capture_default_str()->group("Output");
  app.add_option("--frames", o.frames, "number of .vtp frames to write")->capture_default_str()
      ->check(whole_in(0, 100000))->group("Output");
  add_probes_option(app, o.probes);
  add_export_ppe_option(app, o.export_ppe);
  add_checkpoint_options(app, o.checkpoints);
}

// The scene's parameters: the case's defaults where an option was not given.
fsi::Params make_params(const Options& o) {
  fsi::Params p = o.p;
  const fsi::Params base = fsi::defaults(fsi::case_from_name(o.scene_name));
  p.scene = base.scene;
  p.pressure_gradient = o.gradient.empty() ? base.pressure_gradient : mps::gradient_variant_from_name(o.gradient);
  mps::SimulationConfig treatment;
  mps::set_pressure_treatment(treatment, p.pressure_treatment);
  if (treatment.pressure_gradient == mps::GradientVariant::corrected)
    throw std::invalid_argument("--pressure-treatment " + p.pressure_treatment + ": gc is a gradient, and the fsi app's "
                                "gradient is --pressure-gradient's (conservative or min-reference); leave gc out");
  p.l0 = o.dx > 0 ? o.dx : base.l0;
  p.youngs_modulus = o.modulus > 0 ? o.modulus : base.youngs_modulus;
  p.poisson_ratio = o.poisson > 0 ? o.poisson : base.poisson_ratio;
  p.end_time = o.end_time > 0 ? o.end_time : base.end_time;
  check_run_size((0.6 / p.l0 + 10) * (0.45 / p.l0 + 5), p.end_time * 2.4 / (p.cfl * p.l0), "raise --dx",
                 "shorten --end-time");
  return p;
}

// Steps to the end, writing frames, a line every tenth of the run and checkpoints when due; a SimulationError goes to
// the caller, and so does RunStopped once a signal's checkpoint is written. A restart continues from its checkpoint.
void run(fsi::Scene& scene, FrameSeries& series, Progress& progress, double end_time, Checkpoints& checkpoints) {
  const mps::Simulation& sim = scene.sim();
  double next_report = end_time / 10;
  const std::function<nlohmann::json()> save = [&] { return scene_state(scene, series, next_report); };
  if (!restore_scene(checkpoints, scene.sim(), scene, series, next_report)) series.write_if_due(sim);
  while (!scene.done()) {
    try {
      scene.step();
    } catch (const mps::SimulationError&) {
      checkpoints.write(sim, save);  // the last good state, to restart from
      throw;
    }
    progress.update(sim.time(), sim.last_step().step);
    series.write_if_due(sim);
    if (sim.time() >= next_report - 1e-12) {
      const auto& s = scene.samples().back();
      progress.clear();
      std::printf("t = %.3f s  step %d  probe (%.5f, %.5f) m  load %.2f N/m  solid sub-steps %d\n",
                  s.time, sim.last_step().step, s.tip_x, s.tip_y, s.force_x,
                  scene.structure() ? scene.structure()->substeps() : 0);
      next_report += end_time / 10;
    }
    checkpoints.after_step(sim, save, progress);
  }
}

// The guard's own advice names the fluid's step; in a coupled run the coupling is the likelier cause.
mps::SimulationError with_coupling_advice(const mps::SimulationError& e, const fsi::Params& p) {
  const bool exact = p.pressure_gradient == mps::GradientVariant::conservative;
  const std::string coupling =
      exact ? "; with an elastic body and the conservative gradient, lower --relaxation (now " +
                  short_number(p.relaxation) + ") or --cfl"
            : "; with an elastic body, a blow-up at the impact is usually the partitioned coupling: lower "
              "--relaxation (now " + short_number(p.relaxation) + ") and keep --wet-walls true";
  // The body's own step blowing up is its time step's fault, which its message names (--solid-cfl).
  const bool body_step = std::string(e.what()).find("elastic solid unstable") != std::string::npos;
  return mps::SimulationError(std::string(e.what()) +
                              (p.rigid || body_step ? std::string() : coupling + " (docs/fsi.md)"));
}

// After the run: tip.csv, the largest probe displacement, the body's energy and the summary.
int report(const fs::path& dir, const fsi::Scene& scene, const nlohmann::json& params, double wall) {
  const mps::Simulation& sim = scene.sim();
  std::vector<double> t, ux, uy, fx, level;
  double most = 0, at = 0;
  for (const auto& s : scene.samples()) {
    t.push_back(s.time);
    ux.push_back(s.tip_x);
    uy.push_back(s.tip_y);
    fx.push_back(s.force_x);
    level.push_back(s.level);
    if (std::abs(s.tip_x) > std::abs(most)) {
      most = s.tip_x;
      at = s.time;
    }
  }
  mps::write_csv(dir / "tip.csv", {"t", "ux", "uy", "force_x", "level"}, {t, ux, uy, fx, level});
  nlohmann::json checks{{"largest_probe_ux_m", most}, {"largest_probe_ux_at_s", at}};
  nlohmann::json timings = timings_json(sim.times(), sim.last_step().step, sim.particles().size());
  timings["wall_s"] = wall;
  if (const auto* st = scene.structure()) {
    timings["solid_s"] = st->solid_seconds();
    timings["coupling_s"] = st->coupling_seconds();
    timings["fluid_s"] = wall - st->solid_seconds() - st->coupling_seconds();
    const auto& e = st->solid().energy();
    const double body = e.kinetic + e.strain + e.hourglass + e.gravity;
    checks["pressure_work_on_body_j_per_m"] = st->solid().external_work();
    checks["body_energy_j_per_m"] = body;
  }
  write_solves(dir, sim);
  write_summary(dir,
                {{"status", "completed"}, {"parameters", params}, {"steps", sim.last_step().step},
                 {"time_s", sim.time()}, {"checks", checks},
                 {"timings", timings}});
  std::printf("\nlargest probe displacement %.5f m at t = %.3f s; outputs in %s\n", most, at, dir.string().c_str());
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  prefer_passive_openmp_wait(argv);
  require_one_process(AppRanks(&argc, &argv), "fsi");
  record_run("fsi", argc, argv);
  std::setvbuf(stdout, nullptr, _IOLBF, 0);
  CLI::App app{"SparseMPS fluid-structure interaction (seed 003): a dam-break column hits an elastic plate (§2.4), "
               "water opens a rubber gate (§2.3)"};
  Options o;
  add_options(app, o);
  if (const auto status = parse_options(app, argc, argv)) return *status;
  try {
    const fsi::Params p = make_params(o);
    fsi::Scene scene(p);
    const mps::Simulation& sim = scene.sim();
    nlohmann::json params{
        {"scene", o.scene_name}, {"dx_m", p.l0}, {"water_width_m", scene.water_width},
        {"water_height_m", scene.water_height}, {"body_x_m", scene.body_x}, {"body_width_m", scene.body_width},
        {"body_height_m", scene.body_height}, {"rigid", p.rigid}, {"modulus_pa", p.youngs_modulus},
        {"poisson", p.poisson_ratio}, {"density_kg_per_m3", p.density}, {"solid_cfl", p.solid_cfl},
        {"relaxation", p.relaxation}, {"wet_walls", p.wet_walls},
        {"pressure_gradient", mps::to_string(p.pressure_gradient)},
        {"pressure_treatment", mps::pressure_treatment(sim.config())}, {"collision_l0", p.collision},
        {"asymmetry", p.asymmetry}, {"stabilisation_distance_l0", sim.config().stabilisation_distance},
        {"cfl", p.cfl},
        {"end_time_s", p.end_time}, {"solver", sim.solver().spec()},
        {"simulation_config", mps::config_json(sim.config())},
        {"coupling", "staggered: solid advanced to t^{n+1} under the force of step n, in its own sub-steps"}};
    if (!o.probes.empty()) params["probes_file"] = o.probes;
    std::cout << parameter_table(
        "fsi, " + o.scene_name + (p.rigid ? " (rigid): " : " (elastic): ") +
            std::to_string(sim.particles().count(mps::Kind::fluid)) + " fluid particles, " +
            std::to_string(scene.body_particles()) + " body particles",
        params,
        {{"scene", {"water_width_m", "water_height_m", "body_x_m", "body_width_m", "body_height_m", "rigid",
                    "modulus_pa", "poisson", "density_kg_per_m3"}},
         {"numerics", {"dx_m", "cfl", "solid_cfl", "relaxation", "wet_walls", "pressure_gradient",
                       "pressure_treatment", "collision_l0", "asymmetry", "stabilisation_distance_l0"}},
         {"solver", {"solver"}},
         {"run", {"end_time_s"}}});
    const fs::path dir(o.out);
    Checkpoints checkpoints(o.checkpoints, dir, "fsi", params, {"/end_time_s"});
    if (!checkpoints.restart())  // a restart keeps what the run wrote before its checkpoint
      clear_outputs(dir, {"frames", "fsi.pvd", "tip.csv", "summary.json", "last_good.vtp", "config.toml",
                          "solves.csv", "ppe", "checkpoint.cbor", "probes.csv"});
    scene.sim().add<SolveLog>(dir, std::set<int>(o.export_ppe.begin(), o.export_ppe.end()), "fsi, " + o.scene_name);
    write_run_config(app, "fsi", dir);
    fs::create_directories(dir / "frames");
    FrameSeries series(dir, "fsi", o.frames, p.end_time);
    attach_probes(series, o.probes, scene.sim());
    const auto start = std::chrono::steady_clock::now();
    Progress progress(p.end_time, "s");
    try {
      run(scene, series, progress, p.end_time, checkpoints);
    } catch (const RunStopped& stop) {
      progress.finish(sim.time(), sim.last_step().step);
      return report_stop(dir, stop, params, sim, checkpoints);
    } catch (const mps::SimulationError& e) {
      progress.finish(sim.time(), sim.last_step().step);
      return report_guard_stop(dir, with_coupling_advice(e, p), params, sim);
    }
    progress.finish(sim.time(), sim.last_step().step);
    return report(dir, scene, params, std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count());
  } catch (const std::exception& e) {
    std::cerr << "error: " << error_message(e) << "\n";
    return 1;
  }
}
