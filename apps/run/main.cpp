// sparsemps-run: a scene described in a TOML file (docs/scene-files.md), in 2-D or 3-D. Writes frames (.vtp/.pvd),
// probes.csv, solves.csv, a copy of the scene file and summary.json to the file's [output] out (or --out); an
// elastic body alone energy.csv instead of solves.csv, an acoustic field what `acoustic` writes.
#include <CLI/CLI.hpp>
#include <cstdio>
#include <filesystem>
#include <iostream>

#include "checkpoints.hpp"
#include "checks.hpp"
#include "console.hpp"
#include "help.hpp"
#include "mps/io/io.hpp"
#include "mps/step/components.hpp"
#include "openmp_wait.hpp"
#include "ranks.hpp"
#include "run_config.hpp"
#include "run_json.hpp"
#include "scene_file.hpp"
#include "solid_run.hpp"
#include "solve_log.hpp"

namespace fs = std::filesystem;

namespace {

struct Options {
  std::string scene, out;
  double end_time = 0;
  int frames = -1;
  bool check = false;
  std::vector<int> export_ppe;
  CheckpointOptions checkpoint;
};

// A scene file's run keeps no state of its own beside the simulation's and the frames', but an inlet's plate's counts.
template <int D>
struct SceneState {
  std::shared_ptr<mps::BasicPushingPlate<D>> plate;
  [[nodiscard]] nlohmann::json save_state() const {
    return plate ? nlohmann::json{{"plate", plate->save_state()}} : nlohmann::json::object();
  }
  void restore_state(const nlohmann::json& state) {
    if (plate) plate->restore_state(state.at("plate"));
  }
};

// config.toml, and the scene as run beside its results (unless the file is that copy already).
void write_config_and_scene(const CLI::App& app, const fs::path& scene, const fs::path& dir) {
  write_run_config(app, "run", dir);
  if (!fs::exists(dir / "scene.toml") || !fs::equivalent(scene, dir / "scene.toml"))
    fs::copy_file(scene, dir / "scene.toml", fs::copy_options::overwrite_existing);
}

template <int D>
int run(const Options& o, const CLI::App& app);
int run_alone(const Options& o, const CLI::App& app, const scene_file::Scene<2>& scene);
int run_acoustic(const Options& o, const CLI::App& app);

}  // namespace

int main(int argc, char** argv) {
  prefer_passive_openmp_wait(argv);
  require_one_process(AppRanks(&argc, &argv), "run");
  record_run("run", argc, argv);
  std::setvbuf(stdout, nullptr, _IOLBF, 0);  // progress lines reach a log file as they are printed
  Options o;
  CLI::App app{"SparseMPS run: the scene a TOML file describes (its tank, water, obstacles, physics, numerics, "
               "probes and outputs; an elastic body alone; an acoustic field; docs/scene-files.md), in 2-D or 3-D"};
  add_general_options(app);
  app.add_option("scene-file", o.scene, "the scene file (TOML; examples/scenes/ has one per built-in scene)")
      ->required()->check(config_file_path())->transform(existing_file_made_absolute())->group("Scene");
  app.add_option("--end-time", o.end_time, "simulated time, instead of the file's [run] end_time [s]")
      ->check(positive_up_to(1e6))->group("Run");
  app.add_flag("--check", o.check, "read the scene, build its particles and probes, describe them and stop")
      ->group("Run");
  app.add_option("--out", o.out, "output directory, instead of the file's [output] out")->check(output_directory())
      ->group("Output");
  app.add_option("--frames", o.frames, "number of .vtp frames to write, instead of the file's [output] frames")
      ->check(whole_in(0, 100000))->group("Output");
  add_export_ppe_option(app, o.export_ppe);
  add_checkpoint_options(app, o.checkpoint);
  if (const auto status = parse_options(app, argc, argv)) return *status;
  try {
    if (scene_file::is_acoustic(o.scene)) return run_acoustic(o, app);
    return scene_file::dimensions_of(o.scene) == 2 ? run<2>(o, app) : run<3>(o, app);
  } catch (const std::exception& e) {
    std::cerr << "error: " << error_message(e) << "\n";
    return 1;
  }
}

namespace {

template <int D>
int run(const Options& o, const CLI::App& app) {
  scene_file::Scene<D> scene = scene_file::read_scene<D>(o.scene);
  if (o.end_time > 0) scene.parameters["end_time_s"] = scene.end_time = o.end_time;
  if (o.frames >= 0) scene.parameters["frame_count"] = scene.frames = o.frames;
  if (!o.out.empty()) scene.out = o.out;
  if constexpr (D == 2)
    if (scene.solid_alone) return run_alone(o, app, scene);
  const mps::SimulationConfig& c = scene.config;
  // read_scene bounded the particle count before making any; the simulation holds the scene's particles.
  SceneState<D> own;
  std::unique_ptr<mps::BasicSimulation<D>> simulation = scene_file::make_simulation(scene, &own.plate);
  mps::BasicSimulation<D>& sim = *simulation;
  const mps::BasicParticles<D>& particles = sim.particles();
  check_run_size(static_cast<double>(particles.size()),
                 scene.end_time / std::min(c.dt_max, c.viscous_number * c.l0 * c.l0 / c.nu),
                 "raise the spacing", "shorten [run] end_time or raise [numerics] dt_max");
  mps::BasicProbeSeries<D> probes = scene_file::read_probes(scene, sim);
  nlohmann::json params = scene.parameters;
  params["solver"] = sim.solver().spec();
  const std::size_t fluid = particles.count(mps::Kind::fluid), wall = particles.count(mps::Kind::wall);
  std::printf("%s (%s), %d-D: %zu particles (%zu fluid, %zu wall, %zu dummy), %zu obstacle(s), %zu probe(s)\n"
              "spacing %g m, dt_max %g s, solver %s, end time %g s; output to %s\n",
              scene.title.c_str(), fs::path(o.scene).filename().string().c_str(), D, particles.size(), fluid, wall,
              particles.size() - fluid - wall, scene.obstacles.size(), probes.probes().size(), c.l0, c.dt_max,
              sim.solver().spec().c_str(), scene.end_time, scene.out.string().c_str());
  if (o.check) return 0;

  const fs::path dir = scene.out;
  Checkpoints checkpoints(o.checkpoint, dir, "run", params, {"/end_time_s"});
  if (!checkpoints.restart())
    clear_outputs(dir, {"frames", "scene.pvd", "summary.json", "last_good.vtp", "config.toml", "solves.csv", "ppe",
                        "checkpoint.cbor", "probes.csv", "scene.toml"});
  sim.template add<BasicSolveLog<D>>(dir, std::set<int>(o.export_ppe.begin(), o.export_ppe.end()), scene.title);
  write_config_and_scene(app, o.scene, dir);
  fs::create_directories(dir / "frames");
  FrameSeries series(dir, "scene", scene.frames, scene.end_time);
  if (!probes.probes().empty()) series.set_probes(std::move(probes));
  double next_report = scene.end_time / 10;
  const std::function<nlohmann::json()> save = [&] { return scene_state(own, series, next_report); };
  if (!restore_scene(checkpoints, sim, own, series, next_report)) series.write_if_due(sim);
  const double end = scene.end_time;
  if (const auto stopped = step_to_end(sim, [&] { sim.step(); }, [&] { return sim.time() >= end - 1e-12; }, end,
                                       end / 10, next_report, series, checkpoints, save, dir, params))
    return *stopped;
  write_solves(dir, sim);
  nlohmann::json counts = {{"fluid", sim.particles().count(mps::Kind::fluid)},
                           {"wall", sim.particles().count(mps::Kind::wall)},
                           {"dummy", sim.particles().count(mps::Kind::dummy)}};
  if (const auto* removed = sim.template find<mps::BasicRemoveEscaped<D>>())
    counts["removed_as_spray"] = removed->removed();
  if (own.plate) {
    counts["inlet_column_count"] = own.plate->columns_added();
    counts["recycled_particles"] = own.plate->particles_removed();
  }
  write_summary(dir, {{"status", "completed"}, {"scene_file", fs::path(o.scene).string()}, {"parameters", params},
                      {"particles", counts}, {"steps", sim.last_step().step}, {"time_s", sim.time()},
                      {"dt_limit", sim.last_step().dt_limit}, {"probes", series.probes()},
                      {"timings", timings_json(sim.times(), sim.last_step().step, sim.particles().size())}});
  std::printf("outputs: %s (ParaView)%s, %s\n", series.path().string().c_str(),
              scene.has_probes ? (", " + (dir / "probes.csv").string()).c_str() : "",
              (dir / "summary.json").string().c_str());
  return 0;
}

// A scene of an elastic body alone: the solid stepped on its own, as `structure` steps its scenes. Writes frames,
// probes.csv, energy.csv, a copy of the scene file and summary.json.
int run_alone(const Options& o, const CLI::App& app, const scene_file::Scene<2>& scene) {
  mps::ElasticSolid solid = scene_file::make_solid(scene);
  check_run_size(static_cast<double>(solid.size()), scene.end_time / solid.dt(), "raise the spacing",
                 "shorten [run] end_time or raise the body's cfl");
  SolidSamples samples(scene_file::read_solid_probes(scene, solid));
  const nlohmann::json& params = scene.parameters;
  std::printf("%s (%s), 2-D: an elastic body alone, %zu moving and %zu clamped particles, %zu probe(s)\n"
              "spacing %g m, dt %g s (c_p %g m/s), end time %g s; output to %s\n",
              scene.title.c_str(), fs::path(o.scene).filename().string().c_str(), solid.moving(),
              solid.size() - solid.moving(), samples.probes.probes().size(), scene.l0, solid.dt(),
              solid.config().material.p_wave_speed(), scene.end_time, scene.out.string().c_str());
  if (o.check) return 0;

  const fs::path dir = scene.out;
  Checkpoints checkpoints(o.checkpoint, dir, "run", params, {"/end_time_s"});
  if (!checkpoints.restart())
    clear_outputs(dir, {"frames", "scene.pvd", "summary.json", "last_good.vtp", "config.toml", "checkpoint.cbor",
                        "probes.csv", "energy.csv", "scene.toml"});
  write_config_and_scene(app, o.scene, dir);
  fs::create_directories(dir / "frames");
  auto write_series = [&] {
    if (!samples.probes.probes().empty()) samples.probes.write_csv(dir / "probes.csv");
    samples.write_energy(dir / "energy.csv");
  };
  Progress progress(scene.end_time, "s");
  double seconds = 0;
  try {
    seconds = run_solid(solid, scene.end_time, scene.frames, dir, "scene", samples, progress, checkpoints);
  } catch (const RunStopped& stop) {
    progress.finish(solid.time(), solid.steps());
    write_series();
    return report_stop(dir, stop, params, solid.steps(), solid.time(), checkpoints);
  } catch (const mps::SimulationError& e) {
    progress.finish(solid.time(), solid.steps());
    std::cerr << "error: " << e.what() << "\n";
    mps::write_vtp(dir / "last_good.vtp", solid_frame_particles(solid), solid.time());
    write_series();
    write_summary(dir, {{"status", "failed"}, {"error", e.what()}, {"scene_file", fs::path(o.scene).string()},
                        {"parameters", params}, {"time_s", solid.time()}, {"steps", solid.steps()}});
    std::cerr << "last good state written to " << (dir / "last_good.vtp").string() << "\n";
    return 1;
  }
  progress.finish(solid.time(), solid.steps());
  write_series();
  write_summary(dir, {{"status", "completed"}, {"scene_file", fs::path(o.scene).string()}, {"parameters", params},
                      {"particles", {{"moving", solid.moving()}, {"clamped", solid.size() - solid.moving()}}},
                      {"steps", solid.steps()}, {"time_s", solid.time()}, {"dt_s", solid.dt()},
                      {"energy_drift_fraction", samples.energy_drift()}, {"probes", samples.probes.describe()},
                      {"timings", {{"total_s", seconds},
                                   {"particle_steps_per_s", seconds > 0 ? static_cast<double>(solid.size()) *
                                                                              solid.steps() / seconds : 0.0}}}});
  std::printf("outputs: %s (ParaView), %s%s\n", (dir / "scene.pvd").string().c_str(),
              samples.probes.probes().empty() ? "" : (dir / "probes.csv").string().append(", ").c_str(),
              (dir / "summary.json").string().c_str());
  return 0;
}

// An acoustic scene: the field stepped against the exact solution, as `acoustic` steps its cases. Writes frames,
// pressure maps, centerline.csv, energy.csv, a copy of the scene file and summary.json.
int run_acoustic(const Options& o, const CLI::App& app) {
  scene_file::AcousticScene scene = scene_file::read_acoustic_scene(o.scene, o.end_time);
  acoustic::AcousticRun& run = scene.run;
  if (o.frames >= 0) scene.parameters["frame_count"] = run.frames = o.frames;
  if (!o.out.empty()) run.dir = o.out;
  const mps::AcousticConfig& c = run.config;
  check_run_size((c.box.x1 - c.box.x0) * (c.box.y1 - c.box.y0) / (c.l0 * c.l0), run.t_end / c.dt(),
                 "raise the spacing or shrink the box", "shorten [run] end_time or raise cfl");
  const auto setup_start = acoustic::Clock::now();
  mps::AcousticSolver solver(c);
  const double setup_s = acoustic::seconds_since(setup_start);
  const double cfl_limit = solver.stable_cfl_estimate();
  std::printf("%s (%s), 2-D acoustics: %zu interior + %zu virtual particles, %zu pulse(s), boundary %s\n"
              "spacing %g m, dt %g s (CFL %g, RK4 stable up to %.3f), end time %g s; output to %s\n",
              scene.title.c_str(), fs::path(o.scene).filename().string().c_str(), solver.interior(),
              solver.particles().size() - solver.interior(), run.sources.size(),
              std::string(mps::to_string(c.boundary)).c_str(), c.l0, c.dt(), c.cfl, cfl_limit, run.t_end,
              run.dir.string().c_str());
  if (o.check) return 0;

  const fs::path dir = run.dir;
  Checkpoints checkpoints(o.checkpoint, dir, "run", scene.parameters, {"/end_time_s"});
  if (!checkpoints.restart())
    clear_outputs(dir, {"frames", "maps", "acoustic.pvd", "centerline.csv", "energy.csv", "summary.json",
                        "last_good.vtp", "config.toml", "checkpoint.cbor", "scene.toml"});
  write_config_and_scene(app, o.scene, dir);
  run.summary_extra = {{"scene_file", fs::path(o.scene).string()}};
  return acoustic::run_acoustic(solver, run, scene.parameters, checkpoints, setup_s, cfl_limit);
}

}  // namespace
