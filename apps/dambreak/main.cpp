// Dam break (seed 003 §2.1): a water column collapses in a tank with an open top. The classic column's surge front is
// compared with Martin & Moyce (1952) and Koshizuka & Oka (1996); the seed column's downstream-wall pressure with
// Buchner (2002). Writes frames (.vtp/.pvd), front.csv, level.csv, pressure.csv and summary.json to --out. Under
// `mpirun -np P` the scene runs on P ranks (docs/scaling.md) and rank 0 writes the same outputs.
#include <CLI/CLI.hpp>
#include <algorithm>
#include <array>
#include <tuple>
#include <cstdio>
#include <filesystem>
#include <functional>
#include <iostream>
#include <optional>

#include "box_impact.hpp"
#include "checkpoints.hpp"
#include "checks.hpp"
#include "column.hpp"
#include "console.hpp"
#include "data_dir.hpp"
#include "help.hpp"
#include "mps/io/io.hpp"
#include "openmp_wait.hpp"
#include "probe_file.hpp"
#include "ranks.hpp"
#include "run_config.hpp"
#include "run_json.hpp"
#include "solve_log.hpp"
#include "solver_cli.hpp"

namespace fs = std::filesystem;

namespace {

template <int D>
nlohmann::json params_json(const dambreak::Params& p, const mps::BasicSimulation<D>& sim, const std::string& data,
                           int ranks) {
  const auto& c = sim.config();
  std::vector<std::string> physics{"gravity", "viscosity (explicit)", "free surface", "hydrostatic split",
                                   "spray removal"};
  if (p.asymmetry > 0) physics.emplace_back("free surface by neighbour asymmetry");
  if (p.collision > 0) physics.emplace_back("particle collisions");
  if (c.stabilisation_distance > 0) physics.emplace_back("dynamic stabilisation of close pairs");
  if (p.wet_walls) physics.emplace_back("walls wetted by the liquid's interior");
  if (p.shifting > 0) physics.emplace_back("particle shifting (along the free surface near it)");
  return {{"scene", "dam break"}, {"column", dambreak::to_string(p.column)},
          {"column_width_m", p.width}, {"column_height_m", p.height}, {"tank_length_m", p.tank_length},
          {"tank_height_m", p.tank_height}, {"dx_m", p.l0}, {"gamma", p.gamma},
          {"gradient", mps::to_string(c.pressure_gradient)}, {"pressure_treatment", mps::pressure_treatment(c)}, {"cfl", p.cfl}, {"asymmetry", p.asymmetry},
          {"asymmetry_interior_density_over_n0", p.asymmetry_interior_density},
          {"collision_l0", p.collision}, {"restitution", p.restitution},
          {"stabilisation_distance_l0", c.stabilisation_distance}, {"shifting", p.shifting},
          {"shifting_along_free_surface", true}, {"wet_walls", p.wet_walls},
          {"dt_max_s", c.dt_max}, {"end_time_s", p.end_time}, {"g_m_per_s2", p.g}, {"rho_kg_per_m3", c.rho},
          {"nu_m2_per_s", c.nu},
          {"beta", c.beta}, {"theta", c.theta},
          {"simulation_config", mps::config_json(c)}, {"solver", sim.solver().spec()},
          {"warm_start", c.warm_start},
          {"level_probes_from_downstream_wall_H", p.level_probes}, {"pressure_probes_H", p.pressure_probes},
          {"pressure_patch_radius_l0", p.pressure_patch}, {"pressure_sensor_height_H", p.sensor_height}, {"data", data},
          {"physics_on", physics},
          {"wall_layers", 1}, {"dummy_layers", 4}, {"ranks", ranks}};
}


// The classic column's front checks' tolerances (check_front).
struct FrontTolerances {
  double speed = 0.03, shape = 0.02;
};

// SPHERIC Test 2's checks (check_box_impact): what the default spacing reaches (docs/dambreak3d.md).
struct BoxImpactTolerances {
  double arrival = 0.2, peak = 0.3, height = 0.05;
};

// The command line.
struct Options {
  std::string column_name, gradient = "min-reference", out = "runs/dambreak",
              data = default_data_dir("dambreak", DAMBREAK_DATA_DIR);
  double dx = 0, end_time = 0, tank_length = 0;
  int dim = 2;
  FrontTolerances front;
  BoxImpactTolerances box;
  int frames = 20;
  std::string particles_file, write_particles, probes;
  std::vector<int> export_ppe;
  CheckpointOptions checkpoints;
  double interior_density = -1.0;  // the asymmetry test's; negative: the scene's default
  double shifting = -1.0;          // negative: the scene's default
  // Negative or empty: the scene's default (the 2-D columns run without collisions since the dynamic stabilisation; the
  // 3-D dam break keeps what it was validated with).
  double collision = -1.0, asymmetry = -1.0;
  std::string pressure_treatment;
  dambreak::Params p;
};

void add_options(CLI::App& app, Options& o) {
  add_general_options(app);
  app.add_option("--dim", o.dim, "2: the classic and seed columns and particle files; 3: SPHERIC Test 2, a column hitting "
                 "a box (--column spheric2, docs/dambreak3d.md), and 3-D particle files")
      ->capture_default_str()->check(CLI::IsMember({2, 3}))->group("Scene");
  app.add_option("--particles", o.particles_file,
                 "run the scene of a particle file instead of --column (CSV: x, y, kind and optionally u, v, p, group, "
                 "with --dim 3 also z and optionally w; or a .vtp frame; docs/particle-files.md): the tank from its "
                 "walls, the water from its fluid, the spacing --dx or the file's")
      ->transform(existing_file_made_absolute())->group("Scene");
  // No default string: a run from --particles then writes no column into config.toml, and its replay is no conflict.
  app.add_option("--column", o.column_name,
                 "classic (the default): a = 0.146 m wide, 2a high, tank 4a wide (surge-front data); seed: 2 m wide, "
                 "H = 1 m high, tank 5.366 m x 3 m (Buchner's wall pressure); spheric2 (3-D, the default with --dim 3): "
                 "SPHERIC Test 2's 1.228 m x 1 m x 0.55 m column hitting a box; not with --particles")
      ->check(CLI::IsMember({"classic", "seed", "spheric2"}))->group("Scene");
  app.add_option("--tank-length", o.tank_length, "classic: the tank's length in units of the column's width a "
                 "(default 8: the front never meets the far wall before T = 3.5)")
      ->check(number_in(1.5, 100.0))->group("Scene");
  app.add_option("--data", o.data, "folder of the experimental data (mm_data_1.txt, mm_data_2.txt, ko_data.txt, "
                 "buchner_exp_data.txt)")->capture_default_str()->group("Scene");
  app.add_option("--dx", o.dx, "particle spacing (default: a/40 for classic, H/25 for seed, the seed's own is 0.02; "
                             "0.04 for spheric2; with --particles, the file's) [m]")
      ->check(positive_up_to(1.0))->group("Numerics");
  app.add_option("--gamma", o.p.gamma, "mixed source weight in [0,1] (1: number density only)")
      ->capture_default_str()->check(number_in(0.0, 1.0))->group("Numerics");
  app.add_option("--gradient", o.gradient, "pressure gradient: min-reference (Koshizuka's, repulsive) | plain | corrected "
                 "(the corrective matrix) | corrected-min-reference")
      ->capture_default_str()->check(CLI::IsMember({"min-reference", "plain", "corrected", "corrected-min-reference"}))
      ->group("Numerics");
  add_pressure_treatment_option(app, o.pressure_treatment, " (default: hs+ds in 2-D, hs with --dim 3)");
  app.add_option("--cfl", o.p.cfl, "time step: dt <= CFL l0 / |u|max")->capture_default_str()->check(positive_up_to(10))
      ->group("Numerics");
  // No default strings: the defaults depend on --dim.
  app.add_option("--collision", o.collision, "close pairs collide: two particles nearer than this that approach each "
                 "other keep only --restitution of their approach speed (0: off; default: 0 in 2-D, 0.8 with --dim 3) "
                 "[l0]")
      ->check(number_in(0.0, 0.99))->group("Numerics");
  app.add_option("--stabilisation-distance", o.p.stabilisation_distance, "with ds in --pressure-treatment: the "
                 "corrector puts pairs nearer than this back at it (dynamic stabilisation) [l0]")
      ->capture_default_str()->check(number_in(0.01, 0.99))->group("Numerics");
  app.add_option("--restitution", o.p.restitution, "restitution of a collision")
      ->capture_default_str()->check(number_in(0.0, 1.0))->group("Numerics");
  app.add_option("--asymmetry", o.asymmetry, "free surface also where the neighbours lie one-sided: above this "
                 "fraction of a flat surface's asymmetry (0: the density test alone; default: 0 in 2-D, 0.9 with --dim 3)")
      ->check(number_in(0.0, 10.0))->group("Numerics");
  // No default string: the default depends on --dim.
  app.add_option("--asymmetry-interior-density", o.interior_density,
                 "... but not fluid at or above this number density, which has a full kernel however one-sided (fluid "
                 "pressed onto a wall) (default: 1 with --dim 3, 0 in 2-D; 0: no limit) [n0]")
      ->check(number_in(0.0, 10.0))->group("Numerics");
  app.add_flag("--wet-walls", o.p.wet_walls, "wall particles next to fluid that is not free surface carry pressure even "
               "where their number density calls them dry (mps::WetWalls)")->group("Numerics");
  app.add_option("--sensor-height", o.p.sensor_height,
                 "each wall pressure probe averages the fluid and wall particles within 2 l0 of the wall line over this "
                 "height, the same at every spacing (0.15 H: the experiment's 90 mm sensor on a 0.6 m column); 0: over "
                 "a disc of radius 2 l0 [H]")
      ->capture_default_str()->check(number_in(0.0, 1.0))->group("Run");
  add_shifting_option(app, o.shifting, " (default: 0.5 in 2-D, 0 with --dim 3, where it compressed the water)");
  add_solver_options(app, o.p.solver);
  add_cold_start_flag(app, o.p.warm_start);
  app.add_option("--end-time", o.end_time, "simulated time (default: T = 3.5 for classic, t sqrt(g/H) = 7 for seed, 0.7 s "
                 "for spheric2, the first impact) [s]")
      ->check(positive_up_to(1e4))->group("Run");
  app.add_option("--front-speed-tolerance", o.front.speed,
                 "classic: pass if the front's developed speed (a line over T in [1.5, 3.5]) is within this relative "
                 "error of both Martin & Moyce series' fitted the same way ...")
      ->capture_default_str()->check(positive_up_to(10))->group("Run");
  app.add_option("--front-shape-tolerance", o.front.shape,
                 "... and, delayed by one fitted time offset, within this relative error of the larger column's series "
                 "(a = 2.25 in) at every point up to T = 3.5")
      ->capture_default_str()->check(positive_up_to(10))->group("Run");
  app.add_option("--arrival-tolerance", o.box.arrival, "spheric2: pass if P1's impact arrives within this relative "
                 "error of the experiment's ...")->capture_default_str()->check(positive_up_to(10))->group("Run");
  app.add_option("--peak-tolerance", o.box.peak, "... its first peak is within this relative error ...")
      ->capture_default_str()->check(positive_up_to(10))->group("Run");
  app.add_option("--height-tolerance", o.box.height, "... and the heights at H2 and H4 are within this mean absolute "
                 "error over the record's 0-6 s the run covers, in units of the column's height")
      ->capture_default_str()->check(positive_up_to(10))->group("Run");
  app.add_option("--out", o.out, "output directory")->check(output_directory())->capture_default_str()->group("Output");
  app.add_option("--frames", o.frames, "number of .vtp frames to write")->capture_default_str()
      ->check(whole_in(0, 100000))->group("Output");
  add_probes_option(app, o.probes);
  add_export_ppe_option(app, o.export_ppe);
  add_checkpoint_options(app, o.checkpoints);
  app.add_option("--write-particles", o.write_particles,
                 "write the scene's initial particles to this CSV file (a start for --particles) and exit")
      ->check(output_file())->group("Output");
}

// A particle file is the scene: --column beside it would be ignored.
void refuse_column_with_particles(const Options& o) {
  if (!o.particles_file.empty() && !o.column_name.empty())
    throw std::invalid_argument("--column " + o.column_name + " and --particles: the particle file is the scene (its "
                                "tank, water and spacing); give one of them");
}

// The scene's parameters and particles: the column the options describe, or a particle file's scene.
struct Start {
  dambreak::Params p;
  mps::Particles particles;
  std::string column_name, scene_name;
};

Start make_start(const Options& o) {
  Start start{o.p, {}, o.column_name, ""};
  dambreak::Params& p = start.p;
  p.gradient = mps::gradient_variant_from_name(o.gradient);
  if (o.interior_density >= 0) p.asymmetry_interior_density = o.interior_density;
  if (o.shifting >= 0) p.shifting = o.shifting;
  if (o.collision >= 0) p.collision = o.collision;
  if (o.asymmetry >= 0) p.asymmetry = o.asymmetry;
  if (!o.pressure_treatment.empty()) p.pressure_treatment = o.pressure_treatment;
  if (!o.particles_file.empty() && o.tank_length > 0)
    throw std::invalid_argument("--tank-length and --particles: the particle file's walls are the tank; give one of "
                                "them");
  refuse_column_with_particles(o);
  if (start.column_name.empty()) start.column_name = "classic";
  start.scene_name = start.column_name + " column";
  if (o.particles_file.empty()) {
    const dambreak::Column column = dambreak::column_from_name(start.column_name);
    dambreak::take_column_geometry(p, column);
    if (o.tank_length > 0) {
      if (column != dambreak::Column::classic)
        throw std::invalid_argument("--tank-length is the classic column's: the seed column's tank is the experiment's "
                                    "(5.366 H); leave it out or use --column classic");
      p.tank_length = o.tank_length * p.width;
    }
    if (o.end_time > 0) p.end_time = o.end_time;
    p.l0 = o.dx > 0 ? o.dx : dambreak::defaults(column).l0;
    if (p.l0 > dambreak::coarsest_spacing(p))
      throw std::invalid_argument("--dx " + short_number(p.l0) + " m is coarser than the " + start.column_name +
                                  " column takes: at most " + short_number(dambreak::coarsest_spacing(p)) +
                                  " m, four particles across its width and height");
    check_run_size((p.tank_length / p.l0 + 10) * (p.tank_height / p.l0 + 5), dambreak::estimated_steps(p),
                   "raise --dx", "shorten --end-time or raise --dx (the viscous limit dt <= 0.2 dx^2/nu binds at "
                   "small spacings)");
    start.particles = dambreak::make_particles(p);
    return start;
  }
  const bool frame = fs::path(o.particles_file).extension() == ".vtp";
  dambreak::FileScene file = dambreak::from_particles(
      frame ? mps::read_vtp(o.particles_file) : mps::read_particles_csv(o.particles_file), o.dx, p);
  std::cout << "particles from " << o.particles_file << ": " << file.description << "\n";
  p = file.params;
  p.end_time = o.end_time > 0 ? o.end_time : file.params.end_time;
  start.particles = std::move(file.particles);
  start.column_name = dambreak::to_string(p.column);
  start.scene_name =
      p.column == dambreak::Column::file ? "particles of " + o.particles_file : start.column_name + " column";
  check_run_size(static_cast<double>(start.particles.size()), dambreak::estimated_steps(p),
                 "use a coarser particle file", "shorten --end-time or use a coarser particle file (the viscous "
                 "limit dt <= 0.2 dx^2/nu binds at small spacings)");
  return start;
}

// --write-particles: the scene's particles at rest, with the command that runs them (`dim`: "--dim 3 " in 3-D).
template <int D>
void write_start(const std::string& path, const mps::BasicParticles<D>& particles, double l0, const std::string& scene,
                 const std::string& dim) {
  char spacing[40];
  std::snprintf(spacing, sizeof spacing, "%.17g", l0);
  mps::write_particles_csv(path, particles,
                           {"SparseMPS dam break: the " + scene + " at spacing " + spacing + " m, at rest",
                            "run it with: dambreak " + dim + "--particles THIS-FILE --dx " + std::string(spacing)});
  std::cout << "wrote " << particles.size() << " particles to " << path << "; run them with: dambreak " << dim
            << "--particles " << path << " --dx " << spacing << "\n";
}

// The experiments the runs are compared with (docs/dambreak.md).
struct Experiments {
  dambreak::Table mm1, mm2, ko, buchner;
};

Experiments read_experiments(const std::string& data) {
  const fs::path dir(data);
  Experiments e{dambreak::read_table((dir / "mm_data_1.txt").string()),
                dambreak::read_table((dir / "mm_data_2.txt").string()),
                dambreak::read_table((dir / "ko_data.txt").string()),
                dambreak::read_table((dir / "buchner_exp_data.txt").string())};
  std::sort(e.buchner.begin(), e.buchner.end());  // digitised points, a few out of time order
  return e;
}

// The steps of run() below, from where the run starts or restarts.
template <class Scene>
void steps(Scene& scene, FrameSeries& series, Progress& progress, bool root,
           const std::function<std::string(const Scene&)>& sampled, Checkpoints& checkpoints,
           const std::function<nlohmann::json()>& save, double& next_report) {
  const auto& sim = scene.sim();
  const double end = scene.params().end_time;
  while (!scene.done()) {
    scene.step();
    progress.update(sim.time(), sim.last_step().step);
    series.write_if_due(sim.time(), scene.all_particles());
    if (root && sim.time() >= next_report - 1e-12) {
      const auto& s = sim.last_step();
      progress.clear();
      std::printf("t = %.3f s  step %d  dt %.2e (%s)  unknowns %zu  free surface %zu  %s iterations %d  "
                  "|u|max %.2f m/s  %s\n",
                  s.time, s.step, s.dt, s.dt_limit.c_str(), s.unknowns, s.free_surface, s.solve.backend.c_str(),
                  s.solve.iterations, s.max_speed, sampled(scene).c_str());
      next_report += end / 10;
    }
    checkpoints.after_step(sim, save, progress);
  }
}

// Steps to the end, writing frames and a line every tenth of the run ending with what `sampled` says of the scene
// (the front in 2-D, P1 in 3-D), and checkpoints when due; a SimulationError goes to the caller, and so does
// RunStopped once a signal's checkpoint is written. A restart (--restart) continues from its checkpoint.
template <class Scene>
void run(Scene& scene, FrameSeries& series, Progress& progress, bool root,
         const std::function<std::string(const Scene&)>& sampled, Checkpoints& checkpoints) {
  const auto& sim = scene.sim();
  const double end = scene.params().end_time;
  double next_report = end / 10;
  const std::function<nlohmann::json()> save = [&] { return scene_state(scene, series, next_report); };
  if (!restore_scene(checkpoints, scene.sim(), scene, series, next_report, root))
    series.write_if_due(sim.time(), scene.all_particles());
  try {
    steps(scene, series, progress, root, sampled, checkpoints, save, next_report);
  } catch (const mps::SimulationError&) {
    if (!checkpoints.on_ranks()) checkpoints.write(sim, save);  // the last good state, to restart from
    throw;
  }
}


// The sampled series in the experiments' units: T = t sqrt(2g/a) for the front, t sqrt(g/H) and rho g H for the rest.
struct Series {
  std::vector<double> T, x_over_a, t_hat;
  std::vector<std::vector<double>> levels, pressures;
};

Series write_series(const fs::path& dir, const dambreak::Scene& scene, double rho) {
  const dambreak::Params& p = scene.params();
  const double front_scale = dambreak::front_time_scale(p), scale = std::sqrt(p.g / p.height);
  const double rho_g_h = rho * p.g * p.height;
  Series out{{}, {}, {}, std::vector<std::vector<double>>(p.level_probes.size()),
             std::vector<std::vector<double>>(p.pressure_probes.size())};
  for (const auto& s : scene.samples()) {
    out.T.push_back(s.time * front_scale);
    out.x_over_a.push_back(s.front / p.width);
    out.t_hat.push_back(s.time * scale);
    for (std::size_t k = 0; k < out.levels.size(); ++k) out.levels[k].push_back(s.levels[k] / p.height);
    for (std::size_t k = 0; k < out.pressures.size(); ++k) out.pressures[k].push_back(s.pressures[k] / rho_g_h);
  }
  mps::write_csv(dir / "front.csv", {"T", "x_over_a"}, {out.T, out.x_over_a});
  std::vector<std::string> level_header{"t_sqrt_g_over_H"}, pressure_header{"t_sqrt_g_over_H"};
  std::vector<std::vector<double>> level_columns{out.t_hat}, pressure_columns{out.t_hat};
  for (std::size_t k = 0; k < out.levels.size(); ++k) {
    level_header.push_back("level_over_H_at_" + short_number(p.level_probes[k]) + "H");
    level_columns.push_back(out.levels[k]);
  }
  for (std::size_t k = 0; k < out.pressures.size(); ++k) {
    pressure_header.push_back("p_over_rho_g_H_at_" + short_number(p.pressure_probes[k]) + "H");
    pressure_columns.push_back(out.pressures[k]);
  }
  mps::write_csv(dir / "level.csv", level_header, level_columns);
  mps::write_csv(dir / "pressure.csv", pressure_header, pressure_columns);
  return out;
}

// A figure the run could not give (no experimental point within it, no impact yet) is left out, not written NaN.
void put(nlohmann::json& to, const std::string& key, double v) {
  if (std::isfinite(v)) to[key] = v;
}

// The classic column's checks on its surge front, none of which depends on when the experiments' release began
// (docs/dambreak.md): the developed speed, a line fitted over T in [1.5, 3.5], against each Martin & Moyce series
// fitted the same way; and the front's shape, the largest error left after one time offset fitted to the larger
// column's series. The smaller column's shape is reported: the two series themselves differ by 3.4 % after the best
// offset between them, so no one curve is within 2 % of both.
constexpr double kFrontFitFrom = 1.5, kFrontFitTo = 3.5;

bool check_front(const dambreak::Scene& scene, const Experiments& e, const FrontTolerances& tolerance,
                 nlohmann::json& checks) {
  const auto& samples = scene.samples();
  const dambreak::Params& p = scene.params();
  const double scale = dambreak::front_time_scale(p), end = samples.back().time * scale;
  std::vector<double> T, x;
  for (const auto& s : samples) {
    T.push_back(s.time * scale);
    x.push_back(s.front / p.width);
  }
  const dambreak::FrontLine run = dambreak::fit_front_line(T, x, kFrontFitFrom, std::min(kFrontFitTo, end));
  checks = {{"front_speed_fitted_over_t_sqrt_2g_over_a", {kFrontFitFrom, kFrontFitTo}},
            {"front_speed_tolerance", tolerance.speed}, {"front_shape_tolerance", tolerance.shape}};
  put(checks, "front_speed_over_sqrt_2g_a", run.speed);
  bool pass = end >= kFrontFitTo - 1e-9;
  // A figure the run is too short for is printed as such, not as NaN.
  auto number = [](double v) {
    char text[40] = "none";
    if (std::isfinite(v)) std::snprintf(text, sizeof text, "%.3f", v);
    return std::string(text);
  };
  auto percent = [](double err) {
    char text[40] = "no point";
    if (std::isfinite(err)) std::snprintf(text, sizeof text, "%.2f %%", 100 * err);
    return std::string(text);
  };
  std::printf("\nsurge front to T = %.2f: developed speed %s a per unit T (a line over T in [%.1f, %.1f])\n", end,
              number(run.speed).c_str(), kFrontFitFrom, kFrontFitTo);
  if (!pass) std::printf("the checks need the run to reach T = %.1f (raise --end-time)\n", kFrontFitTo);
  // Per experiment: whether its speed and whether its shape are checked.
  const std::array<std::tuple<const char*, const char*, const dambreak::Table*, bool, bool>, 3> experiments{
      {{"martin_moyce_1", "Martin & Moyce a = 1.125 in", &e.mm1, true, false},
       {"martin_moyce_2", "Martin & Moyce a = 2.25 in", &e.mm2, true, true},
       {"koshizuka_oka", "Koshizuka & Oka", &e.ko, false, false}}};
  for (const auto& [key, name, table, speed_checked, shape_checked] : experiments) {
    std::vector<double> te, xe;
    for (const auto& [t, xx] : *table) {
      te.push_back(t);
      xe.push_back(xx);
    }
    const dambreak::FrontLine line = dambreak::fit_front_line(te, xe, kFrontFitFrom, kFrontFitTo);
    const double speed_error = std::abs(run.speed - line.speed) / line.speed;
    const double raw = dambreak::max_front_error(samples, p, *table, std::min(kFrontFitTo, end));
    const dambreak::FrontOffset offset = dambreak::fit_front_offset(samples, p, *table, std::min(kFrontFitTo, end));
    const std::string k = key;
    put(checks, k + "_front_speed_over_sqrt_2g_a", line.speed);
    put(checks, k + "_front_speed_error", speed_error);
    put(checks, k + "_front_max_error", raw);
    put(checks, k + "_front_offset_t_sqrt_2g_over_a", offset.dT);
    put(checks, k + "_front_offset_max_error", offset.error);
    const bool speed_ok = !speed_checked || speed_error <= tolerance.speed;
    const bool shape_ok = !shape_checked || offset.error <= tolerance.shape;
    pass = pass && speed_ok && shape_ok;
    std::printf("  %s: speed %s (run %s off; %d points)%s, largest error %s, after an offset dT = %s %s%s\n",
                name, number(line.speed).c_str(), percent(speed_error).c_str(), line.points,
                speed_checked ? (speed_ok ? " PASS" : " FAIL") : "", percent(raw).c_str(), number(offset.dT).c_str(),
                percent(offset.error).c_str(), shape_checked ? (shape_ok ? " PASS" : " FAIL") : "");
  }
  std::printf("surge front (speed within %.1f %% of both Martin & Moyce series, shape within %.1f %% of the larger "
              "column's after one offset): %s\n", 100 * tolerance.speed, 100 * tolerance.shape, pass ? "PASS" : "FAIL");
  return pass;
}

// Every wall probe's impact in Buchner's units (arrival, first peak, noise, plateau, second impact); the one at 0.2 H
// beside Buchner's record, which the metrics read the same way.
void check_impact(const Series& series, const dambreak::Params& p, const Experiments& e, nlohmann::json& checks) {
  if (p.column == dambreak::Column::file) return;
  std::vector<double> bt, bp;
  for (const auto& [t, pe] : e.buchner) {
    bt.push_back(t);
    bp.push_back(pe);
  }
  const dambreak::Impact buchner = dambreak::impact(bt, bp);
  auto figures = [](const dambreak::Impact& i, const std::string& suffix, nlohmann::json& to) {
    put(to, "arrival" + suffix + "_t_sqrt_g_over_H", i.arrival);
    put(to, "first_peak" + suffix + "_over_rho_g_H", i.peak);
    put(to, "noise" + suffix + "_over_range", i.noise);
    put(to, "noise_rms" + suffix + "_over_rho_g_H", i.noise_rms);
    put(to, "plateau" + suffix + "_over_rho_g_H", i.plateau);
    put(to, "second_arrival" + suffix + "_t_sqrt_g_over_H", i.second_arrival);
    put(to, "second_peak" + suffix + "_over_rho_g_H", i.second_peak);
  };
  nlohmann::json probes = nlohmann::json::array();
  for (std::size_t k = 0; k < p.pressure_probes.size(); ++k) {
    const dambreak::Impact run = dambreak::impact(series.t_hat, series.pressures[k]);
    // The probe's height is a value, not part of a key: keys hold no dots.
    nlohmann::json at{{"probe_H", p.pressure_probes[k]}, {"arrived", std::isfinite(run.arrival)}};
    figures(run, "", at);
    probes.push_back(at);
    if (std::abs(p.pressure_probes[k] - 0.2) > 1e-12) continue;
    figures(buchner, "_buchner", at);
    const auto [sampled_t, sampled_p] = dambreak::sampled_at(series.t_hat, series.pressures[k], bt);
    const dambreak::Impact sampled = dambreak::impact(sampled_t, sampled_p);
    put(at, "noise_at_buchner_sampling_over_range", sampled.noise);
    put(at, "noise_rms_at_buchner_sampling_over_rho_g_H", sampled.noise_rms);
    checks["impact"] = at;
    if (!std::isfinite(run.arrival)) {
      std::printf("impact at 0.2 H: the pressure there never reached 0.25 rho g H\n");
      continue;
    }
    std::printf("impact at 0.2 H: arrival t sqrt(g/H) = %.3f (Buchner %.3f), first peak %.3f rho g H (Buchner %.3f), "
                "noise %.3f of the range (Buchner %.3f), %.3f rho g H RMS (Buchner %.3f)\n",
                run.arrival, buchner.arrival, run.peak, buchner.peak, run.noise, buchner.noise, run.noise_rms,
                buchner.noise_rms);
    std::printf("  sampled as Buchner's record is (%zu points): noise %.3f of the range, %.3f rho g H RMS\n",
                sampled_t.size(), sampled.noise, sampled.noise_rms);
    if (std::isfinite(run.second_arrival))
      std::printf("second impact at 0.2 H: arrival %.3f (Buchner %.3f), peak %.3f rho g H (Buchner %.3f)\n",
                  run.second_arrival, buchner.second_arrival, run.second_peak, buchner.second_peak);
  }
  checks["wall_probes"] = probes;
}

// Rank 0, after the run: the series, the checks against the experiments and the summary; returns the exit status.
int report(const fs::path& dir, const dambreak::Scene& scene, const Experiments& e, const FrontTolerances& front,
           long removed, long backstop_returns, const nlohmann::json& params, const FrameSeries& frames) {
  const mps::Simulation& sim = scene.sim();
  const dambreak::Params& p = scene.params();
  const Series series = write_series(dir, scene, sim.config().rho);
  nlohmann::json checks;
  const bool pass = p.column != dambreak::Column::classic || check_front(scene, e, front, checks);
  check_impact(series, p, e, checks);
  if (p.column == dambreak::Column::file)
    std::printf("a scene from a particle file: no experiment applies; its front, levels and wall pressure are in "
                "front.csv, level.csv and pressure.csv\n");
  checks["fluid_removed_as_spray_count"] = removed;
  checks["most_fluid_inside_walls_count"] = scene.most_inside_walls();
  checks["deepest_past_wall_line_l0"] = std::max(0.0, scene.deepest_past_wall_line() / p.l0);
  checks["fluid_returned_to_a_face_count"] = backstop_returns;
  write_solves(dir, sim);
  write_summary(dir, {{"status", p.column != dambreak::Column::classic ? "completed" : pass ? "passed" : "check failed"},
                      {"parameters", params},
                      {"particles", {{"fluid", scene.initial_fluid()}, {"total", scene.all_particles().size()}}},
                      {"steps", sim.last_step().step}, {"time_s", sim.time()}, {"checks", checks},
                      {"timings", timings_json(sim.times(), sim.last_step().step, sim.particles().size())}});
  std::printf("spray removed: %ld particles; most fluid particles inside a wall at once: %ld; deepest past a wall "
              "line: %.3f l0; put back on a wall line by the wall backstop: %ld times\n",
              removed, scene.most_inside_walls(), std::max(0.0, scene.deepest_past_wall_line() / p.l0),
              backstop_returns);
  std::printf("outputs: %s (ParaView), front.csv, level.csv, pressure.csv, summary.json in %s\n",
              frames.path().string().c_str(), dir.string().c_str());
  return pass ? 0 : 2;
}

// SPHERIC Test 2 (--dim 3): the column hitting a box, its sensors against the experiment's P1, H2 and H4
// (docs/dambreak3d.md). The impact in the 2-D seed column's units with the column's height 0.55 m: arrival and first
// peak as dambreak::impact reads Buchner's record.
struct BoxImpactFigures {
  dambreak::Impact p1, p1_record;
  double h2_error = 0, h4_error = 0;  // mean absolute error over 0-6 s, in units of the column's height
};

// The sampled series, as written to pressure.csv [Pa] and level.csv [m] (also when the guard stopped the run).
struct BoxImpactSeries {
  std::vector<double> time;
  std::vector<std::vector<double>> pressures, heights;
};

BoxImpactSeries write_box_impact_series(const fs::path& dir, const dambreak::BoxImpact& scene) {
  const dambreak::BoxImpactSensors& sensors = scene.sensors();
  BoxImpactSeries out{{}, std::vector<std::vector<double>>(sensors.pressure.size()),
                      std::vector<std::vector<double>>(sensors.height.size())};
  for (const auto& s : scene.samples()) {
    out.time.push_back(s.time);
    for (std::size_t k = 0; k < out.pressures.size(); ++k) out.pressures[k].push_back(s.pressures[k]);
    for (std::size_t k = 0; k < out.heights.size(); ++k) out.heights[k].push_back(s.heights[k]);
  }
  auto write = [&](const char* file, const std::vector<dambreak::Sensor>& names,
                   const std::vector<std::vector<double>>& series, const char* unit) {
    std::vector<std::string> header{"time_s"};
    std::vector<std::vector<double>> columns{out.time};
    for (std::size_t k = 0; k < series.size(); ++k) {
      header.push_back(names[k].name + unit);
      columns.push_back(series[k]);
    }
    mps::write_csv(dir / file, header, columns);
  };
  write("pressure.csv", sensors.pressure, out.pressures, "_Pa");
  write("level.csv", sensors.height, out.heights, "_m");
  return out;
}

// A pressure series [s, Pa] read as dambreak::impact reads Buchner's, in units of the column's height:
// t sqrt(g/H) and p / (rho g H).
dambreak::Impact impact_in_column_units(const dambreak::BoxImpact& scene, const std::vector<double>& time,
                                       const std::vector<double>& pressure) {
  const dambreak::Params& p = scene.params();
  const double scale = std::sqrt(p.g / p.height), rho_g_h = scene.sim().config().rho * p.g * p.height;
  std::vector<double> t_hat, p_hat;
  for (std::size_t k = 0; k < time.size(); ++k) {
    t_hat.push_back(time[k] * scale);
    p_hat.push_back(pressure[k] / rho_g_h);
  }
  return dambreak::impact(t_hat, p_hat);
}

BoxImpactFigures box_impact_figures(const dambreak::BoxImpact& scene, const dambreak::BoxImpactRecord& record,
                                    const BoxImpactSeries& series) {
  const dambreak::Params& p = scene.params();
  BoxImpactFigures f{impact_in_column_units(scene, series.time, series.pressures[0]),
                     impact_in_column_units(scene, record.time, record.p1), 0, 0};
  auto gauge = [&](const std::string& name) -> const std::vector<double>& {
    for (std::size_t k = 0; k < series.heights.size(); ++k)
      if (scene.sensors().height[k].name == name) return series.heights[k];
    throw std::runtime_error("the sensor file has no gauge " + name + ", which the experiment's record holds");
  };
  f.h2_error = dambreak::mean_absolute_error(series.time, gauge("H2"), record.time, record.h2, 0.0, 6.0) / p.height;
  f.h4_error = dambreak::mean_absolute_error(series.time, gauge("H4"), record.time, record.h4, 0.0, 6.0) / p.height;
  return f;
}

// The 3-D scene's mass and walls into `checks`, printed: fluid conserved (left plus `removed` as spray), none inside a
// wall or a box at any sample; `backstop_returns` reported. Whether both hold.
bool check_walls(const dambreak::BoxImpact& scene, long removed, long backstop_returns, nlohmann::json& checks) {
  const long fluid_left = static_cast<long>(scene.all_particles().count(mps::Kind::fluid));
  const bool conserved = fluid_left + removed == scene.initial_fluid();
  const double deepest = std::max(0.0, scene.deepest_past_wall() / scene.params().l0);
  checks["fluid_removed_as_spray_count"] = removed;
  checks["fluid_conserved"] = conserved;
  checks["most_fluid_inside_walls_count"] = scene.most_inside_walls();
  checks["deepest_past_wall_l0"] = deepest;
  checks["fluid_returned_to_a_face_count"] = backstop_returns;
  const bool ok = scene.most_inside_walls() == 0 && conserved;
  std::printf("spray removed: %ld particles; fluid conserved: %s; most fluid particles inside a wall or the box at once: "
              "%ld (deepest %.2f l0) %s; put back on a face by the wall backstop: %ld times\n", removed,
              conserved ? "yes" : "NO", scene.most_inside_walls(), deepest, ok ? "PASS" : "FAIL", backstop_returns);
  return ok;
}

// On rank 0 alone, after the run: `removed` is the spray over every rank (BoxImpact::removed, collective).
int report_box_impact(const fs::path& dir, const dambreak::BoxImpact& scene, const dambreak::BoxImpactRecord& record,
                      const BoxImpactTolerances& tolerance, long removed, long backstop_returns,
                      const nlohmann::json& params) {
  const mps::Simulation3& sim = scene.sim();
  const dambreak::Params& p = scene.params();
  const BoxImpactSeries series = write_box_impact_series(dir, scene);
  const std::vector<double>& time = series.time;
  const std::vector<std::vector<double>>&pressures = series.pressures, &heights = series.heights;
  const BoxImpactFigures f = box_impact_figures(scene, record, series);
  const double scale = std::sqrt(p.g / p.height), rho_g_h = sim.config().rho * p.g * p.height;
  const double arrival_error = std::abs(f.p1.arrival - f.p1_record.arrival) / f.p1_record.arrival;
  const double peak_error = std::abs(f.p1.peak - f.p1_record.peak) / f.p1_record.peak;
  nlohmann::json checks{{"arrival_tolerance", tolerance.arrival}, {"peak_tolerance", tolerance.peak},
                        {"height_tolerance_over_column_height", tolerance.height},
                        {"pressure_patch_radius_m", scene.patch_radius()}, {"pressure_patch_reach_m", scene.patch_reach()}};
  put(checks, "p1_arrival_s", f.p1.arrival / scale);
  put(checks, "p1_arrival_record_s", f.p1_record.arrival / scale);
  put(checks, "p1_arrival_error", arrival_error);
  put(checks, "p1_first_peak_pa", f.p1.peak * rho_g_h);
  put(checks, "p1_first_peak_record_pa", f.p1_record.peak * rho_g_h);
  put(checks, "p1_first_peak_error", peak_error);
  put(checks, "p1_noise_rms_pa", f.p1.noise_rms * rho_g_h);
  put(checks, "p1_noise_rms_record_pa", f.p1_record.noise_rms * rho_g_h);
  put(checks, "h2_mean_absolute_error_over_column_height", f.h2_error);
  put(checks, "h4_mean_absolute_error_over_column_height", f.h4_error);
  // Every sensor's and gauge's figures, for the experiment's records not given here.
  nlohmann::json sensors = nlohmann::json::array(), gauges = nlohmann::json::array();
  for (std::size_t k = 0; k < pressures.size(); ++k) {
    const dambreak::Impact i = impact_in_column_units(scene, time, pressures[k]);
    nlohmann::json at{{"name", scene.sensors().pressure[k].name}, {"arrived", std::isfinite(i.arrival)},
                      {"largest_pa", *std::max_element(pressures[k].begin(), pressures[k].end())}};
    put(at, "arrival_s", i.arrival / scale);
    put(at, "first_peak_pa", i.peak * rho_g_h);
    sensors.push_back(at);
  }
  for (std::size_t k = 0; k < heights.size(); ++k)
    gauges.push_back({{"name", scene.sensors().height[k].name},
                      {"largest_m", *std::max_element(heights[k].begin(), heights[k].end())}});
  checks["pressure_sensors"] = sensors;
  checks["height_gauges"] = gauges;
  const mps::Particles3& all = scene.all_particles();
  const bool arrival_ok = arrival_error <= tolerance.arrival, peak_ok = peak_error <= tolerance.peak;
  const bool heights_ok = f.h2_error <= tolerance.height && f.h4_error <= tolerance.height;
  // A figure the run is too short for is printed as such, not as NaN.
  auto shown = [](double v, const char* format) {
    char text[40] = "none";
    if (std::isfinite(v)) std::snprintf(text, sizeof text, format, v);
    return std::string(text);
  };
  std::printf("\nP1 (the box's face, lowest sensor): arrival %s s (experiment %.4f, %s %% off) %s; first peak %s Pa "
              "(experiment %.0f, %s %% off) %s\n",
              shown(f.p1.arrival / scale, "%.4f").c_str(), f.p1_record.arrival / scale,
              shown(100 * arrival_error, "%.2f").c_str(), arrival_ok ? "PASS" : "FAIL",
              shown(f.p1.peak * rho_g_h, "%.0f").c_str(), f.p1_record.peak * rho_g_h,
              shown(100 * peak_error, "%.1f").c_str(), peak_ok ? "PASS" : "FAIL");
  std::printf("heights over 0-%.2f s (the record's 0-6 s the run covers), mean absolute error: H2 %.2f %%, H4 %.2f %% "
              "of the column's height %s\n", std::min(6.0, time.back()), 100 * f.h2_error, 100 * f.h4_error,
              heights_ok ? "PASS" : "FAIL");
  const bool walls_ok = check_walls(scene, removed, backstop_returns, checks);
  const bool pass = arrival_ok && peak_ok && heights_ok && walls_ok;
  std::printf("SPHERIC Test 2 (P1 arrival within %.0f %%, first peak within %.0f %%, H2 and H4 within %.0f %%, no fluid "
              "inside a wall): %s\n", 100 * tolerance.arrival, 100 * tolerance.peak, 100 * tolerance.height,
              pass ? "PASS" : "FAIL");
  write_solves(dir, sim);
  write_summary(dir, {{"status", pass ? "passed" : "check failed"}, {"parameters", params},
                      {"particles", {{"fluid", scene.initial_fluid()}, {"total", all.size()}}},
                      {"steps", sim.last_step().step}, {"time_s", sim.time()}, {"checks", checks},
                      {"timings", timings_json(sim.times(), sim.last_step().step, all.size())}});
  std::printf("outputs: frames (ParaView: dambreak.pvd), pressure.csv, level.csv, summary.json in %s\n",
              dir.string().c_str());
  return pass ? 0 : 2;
}

// A 3-D scene from a particle file that is not the experiment: no sensors; its mass and walls checked.
int report_box_impact_file(const fs::path& dir, const dambreak::BoxImpact& scene, long removed, long backstop_returns,
                           long unchecked_obstacle_particles, const nlohmann::json& params) {
  const mps::Simulation3& sim = scene.sim();
  nlohmann::json checks{{"box_obstacles", scene.geometry().boxes.size()},
                        {"obstacle_particles_not_in_boxes", unchecked_obstacle_particles}};
  std::printf("\n");
  const bool walls_ok = check_walls(scene, removed, backstop_returns, checks);
  write_solves(dir, sim);
  const std::size_t total = scene.all_particles().size();
  write_summary(dir, {{"status", walls_ok ? "completed" : "check failed"}, {"parameters", params},
                      {"particles", {{"fluid", scene.initial_fluid()}, {"total", total}}},
                      {"steps", sim.last_step().step}, {"time_s", sim.time()}, {"checks", checks},
                      {"timings", timings_json(sim.times(), sim.last_step().step, total)}});
  std::printf("outputs: frames (ParaView: dambreak.pvd), summary.json in %s\n", dir.string().c_str());
  return walls_ok ? 0 : 2;
}

// Rank 0's outputs before the first step: the folder cleared of an earlier run's, the solve log (and --export-ppe),
// config.toml and the frames' folder.
template <int D>
void start_outputs(const fs::path& dir, const CLI::App& app, const std::vector<int>& export_ppe, const std::string& scene,
                   mps::BasicSimulation<D>& sim, bool restart) {
  if (!restart)  // a restart keeps what the run wrote before its checkpoint
    clear_outputs(dir, {"frames", "dambreak.pvd", "front.csv", "level.csv", "pressure.csv", "summary.json",
                        "last_good.vtp", "config.toml", "solves.csv", "ppe", "checkpoint.cbor", "probes.csv"});
  sim.template add<BasicSolveLog<D>>(dir, std::set<int>(export_ppe.begin(), export_ppe.end()), scene);
  write_run_config(app, "dambreak", dir);
  fs::create_directories(dir / "frames");
}

int run_box_impact(const Options& o, const CLI::App& app, const AppRanks& ranks) {
  if (ranks.distributed() && !o.export_ppe.empty())
    throw std::invalid_argument("--export-ppe writes the PPE of one process; run without mpirun to export it");
  if (o.dim != 3) throw std::invalid_argument("--column spheric2 is the 3-D dam break: add --dim 3");
  if (!o.column_name.empty() && o.column_name != "spheric2")
    throw std::invalid_argument("--dim 3 runs SPHERIC Test 2 (--column spheric2); the " + o.column_name +
                                " column is 2-D: leave out --dim 3");
  refuse_column_with_particles(o);
  // By value, not by count: a replayed config.toml holds every option, the 2-D ones at their defaults.
  const std::pair<const char*, bool> two_d[] = {{"--tank-length", o.tank_length > 0},
                                                {"--sensor-height", o.p.sensor_height != dambreak::Params{}.sensor_height}};
  for (const auto& [name, given] : two_d)
    if (given) throw std::invalid_argument(std::string(name) + " is the 2-D dam break's; leave it out with --dim 3");
  const dambreak::Params base = dambreak::box_impact_defaults();
  dambreak::Params p = o.p;
  p.column = base.column;
  p.width = base.width;
  p.height = base.height;
  p.tank_length = base.tank_length;
  p.tank_height = base.tank_height;
  p.level_probes.clear();
  p.pressure_probes.clear();
  p.gradient = mps::gradient_variant_from_name(o.gradient);
  p.asymmetry_interior_density = o.interior_density >= 0 ? o.interior_density : base.asymmetry_interior_density;
  p.shifting = o.shifting >= 0 ? o.shifting : base.shifting;
  p.collision = o.collision >= 0 ? o.collision : base.collision;
  p.asymmetry = o.asymmetry >= 0 ? o.asymmetry : base.asymmetry;
  p.pressure_treatment = !o.pressure_treatment.empty() ? o.pressure_treatment : base.pressure_treatment;
  p.l0 = o.dx > 0 ? o.dx : base.l0;
  p.end_time = o.end_time > 0 ? o.end_time : base.end_time;
  if (!o.write_particles.empty()) {
    if (ranks.root()) {
      const mps::Particles3 particles = dambreak::make_box_impact_particles(dambreak::box_impact_geometry(p.l0), p.l0);
      write_start(o.write_particles, particles, p.l0, "SPHERIC Test 2 (3-D)", "--dim 3 ");
    }
    return 0;
  }
  // A particle file's scene (the experiment's own particles, or a new one), or the experiment built in.
  std::optional<dambreak::BoxImpactFile> file;
  if (!o.particles_file.empty()) {
    const bool frame = fs::path(o.particles_file).extension() == ".vtp";
    file = dambreak::box_impact_from_particles(
        frame ? mps::read_vtp<3>(o.particles_file) : mps::read_particles_csv<3>(o.particles_file), o.dx, p);
    std::cout << "particles from " << o.particles_file << ": " << file->description << "\n";
    p = file->params;
    check_run_size(static_cast<double>(file->particles.size()), dambreak::estimated_steps(p),
                   "use a coarser particle file", "shorten --end-time or use a coarser particle file");
  } else {
    const dambreak::BoxImpactSize size;
    check_run_size((size.tank_length / p.l0 + 10) * (size.tank_width / p.l0 + 10) * (size.tank_height / p.l0 + 5),
                   dambreak::estimated_steps(p), "raise --dx", "shorten --end-time or raise --dx");
  }
  const bool experiment = !file || file->experiment;
  const fs::path data(o.data);
  dambreak::BoxImpactSensors sensors;
  if (experiment) sensors = dambreak::read_box_impact_sensors((data / "spheric2_sensors.csv").string());
  const std::optional<int> comm = ranks.distributed() ? std::optional<int>(ranks.comm()) : std::nullopt;
  dambreak::BoxImpact scene = file ? dambreak::BoxImpact(p, std::move(sensors), std::move(file->particles),
                                                         file->geometry, comm)
                                   : dambreak::BoxImpact(p, std::move(sensors), comm);
  dambreak::BoxImpactRecord record;
  if (experiment) record = dambreak::read_box_impact_record((data / "spheric2_p1_h2_h4.csv").string());
  const mps::Simulation3& sim = scene.sim();
  const dambreak::BoxImpactGeometry& g = scene.geometry();
  nlohmann::json params = params_json(p, sim, o.data, ranks.size());
  params["dimensions"] = 3;
  params["tank_m"] = {g.tank.x1 - g.tank.x0, g.tank.y1 - g.tank.y0, g.tank.z1 - g.tank.z0};
  params["column_m"] = {g.column.x0, g.column.x1, g.column.z1};
  std::string box_key = "box_m", scene_name = "SPHERIC Test 2";
  if (experiment) {
    const mps::Box& b = g.boxes.front();
    params["box_m"] = {b.x0, b.x1, b.y0, b.y1, b.z1};
  } else {
    box_key = "obstacle_boxes_m";
    params[box_key] = nlohmann::json::array();
    for (const mps::Box& b : g.boxes) params[box_key].push_back({b.x0, b.x1, b.y0, b.y1, b.z0, b.z1});
    params["particle_file"] = o.particles_file;
    scene_name = "particles of " + o.particles_file;
  }
  if (file && experiment) params["particle_file"] = o.particles_file;
  if (!o.probes.empty()) params["probes_file"] = o.probes;
  std::cout << parameter_table(
      "dam break, 3-D, " + scene_name + ": " + std::to_string(scene.all_particles().size()) + " particles (" +
          std::to_string(scene.initial_fluid()) + " fluid)" +
          (ranks.distributed() ? " on " + std::to_string(ranks.size()) + " MPI ranks" : ""),
      params,
      {{"scene", {"tank_m", "column_m", box_key, "g_m_per_s2", "rho_kg_per_m3", "nu_m2_per_s"}},
       {"numerics", {"dx_m", "gamma", "pressure_treatment", "gradient", "cfl", "dt_max_s", "collision_l0", "restitution",
                     "stabilisation_distance_l0", "asymmetry", "asymmetry_interior_density_over_n0", "shifting",
                     "wet_walls"}},
       {"solver", {"solver", "warm_start"}},
       {"run", {"end_time_s"}}});
  const fs::path dir(o.out);
  Checkpoints checkpoints(o.checkpoints, dir, "dambreak", params, {"/end_time_s"},
                          ranks.distributed() ? std::optional<int>(ranks.comm()) : std::nullopt);
  // Rank 0 writes every output; the others step with it and join its gathers.
  FrameSeries series(dir, "dambreak", ranks.root() ? o.frames : 0, p.end_time);
  if (ranks.root()) {
    start_outputs(dir, app, o.export_ppe, "dambreak, " + scene_name, scene.sim(), checkpoints.restart() != nullptr);
  }
  attach_probes(series, o.probes, scene.sim(), ranks.root());
  Progress progress(p.end_time, "s");
  try {
    run<dambreak::BoxImpact>(scene, series, progress, ranks.root(), [](const dambreak::BoxImpact& sc) {
      char text[40] = "";
      if (!sc.samples().back().pressures.empty())
        std::snprintf(text, sizeof text, "P1 %.0f Pa", sc.samples().back().pressures[0]);
      return std::string(text);
    }, checkpoints);
  } catch (const RunStopped& stop) {
    progress.finish(sim.time(), sim.last_step().step);
    if (experiment && ranks.root()) write_box_impact_series(dir, scene);  // the sensors so far
    return report_stop(dir, stop, params, sim, checkpoints);
  } catch (const mps::SimulationError& e) {
    progress.finish(sim.time(), sim.last_step().step);
    // As the 2-D dam break's: the step stops every rank at one stage; the scene's own check may be one rank's alone.
    if (!ranks.every_rank_failed())
      ranks.end_alone(e.what(), [&] { record_failure_alone(dir, e.what(), params, sim); });
    if (!ranks.root()) return 1;
    if (experiment) write_box_impact_series(dir, scene);  // the sensors up to the last good step
    return report_guard_stop(dir, e, params, sim, &scene.all_particles());
  }
  progress.finish(sim.time(), sim.last_step().step);
  const long removed = scene.removed(), backstop_returns = scene.backstop_returns();
  if (!ranks.root()) return 0;
  if (!experiment)
    return report_box_impact_file(dir, scene, removed, backstop_returns, file->unchecked_obstacle_particles, params);
  return report_box_impact(dir, scene, record, o.box, removed, backstop_returns, params);
}

}  // namespace

int main(int argc, char** argv) {
  prefer_passive_openmp_wait(argv);
  const AppRanks ranks(&argc, &argv);
  record_run("dambreak", argc, argv);
  std::setvbuf(stdout, nullptr, _IOLBF, 0);
  CLI::App app{"SparseMPS dam break: a water column collapses in an open tank (seed 003 §2.1); the surge front against "
               "Martin & Moyce, the downstream-wall pressure against Buchner"};
  Options o;
  add_options(app, o);
  if (const auto status = parse_options(app, ranks, argc, argv)) return *status;

  try {
    if (o.dim == 3 || o.column_name == "spheric2") return run_box_impact(o, app, ranks);
    if (ranks.distributed() && !o.export_ppe.empty())
      throw std::invalid_argument("--export-ppe writes the PPE of one process; run without mpirun to export it");
    Start start = make_start(o);
    if (!o.write_particles.empty()) {
      if (ranks.root()) write_start(o.write_particles, start.particles, start.p.l0, start.scene_name, "");
      return 0;
    }
    const Experiments experiments = read_experiments(o.data);
    dambreak::Scene scene(start.p, std::move(start.particles),
                          ranks.distributed() ? std::optional<int>(ranks.comm()) : std::nullopt);
    const mps::Simulation& sim = scene.sim();
    const dambreak::Params& p = scene.params();
    nlohmann::json params = params_json(p, sim, o.data, ranks.size());
    if (!o.particles_file.empty()) params["particle_file"] = o.particles_file;
    if (!o.probes.empty()) params["probes_file"] = o.probes;
    std::cout << parameter_table(
        "dam break, " + start.scene_name + ": " + std::to_string(scene.all_particles().size()) + " particles (" +
            std::to_string(scene.initial_fluid()) + " fluid)" +
            (ranks.distributed() ? " on " + std::to_string(ranks.size()) + " MPI ranks" : ""),
        params,
        {{"scene", {"column_width_m", "column_height_m", "tank_length_m", "tank_height_m", "g_m_per_s2",
                    "rho_kg_per_m3", "nu_m2_per_s"}},
         {"numerics", {"dx_m", "gamma", "pressure_treatment", "gradient", "cfl", "dt_max_s", "collision_l0", "restitution",
                       "stabilisation_distance_l0", "asymmetry", "asymmetry_interior_density_over_n0", "shifting",
                     "wet_walls"}},
         {"solver", {"solver", "warm_start"}},
         {"run", {"end_time_s", "pressure_probes_H", "level_probes_from_downstream_wall_H"}}});
    const fs::path dir(o.out);
    Checkpoints checkpoints(o.checkpoints, dir, "dambreak", params, {"/end_time_s"},
                          ranks.distributed() ? std::optional<int>(ranks.comm()) : std::nullopt);
    // Rank 0 writes every output; the others step with it and join its gathers.
    FrameSeries series(dir, "dambreak", ranks.root() ? o.frames : 0, p.end_time);
    if (ranks.root()) {
      start_outputs(dir, app, o.export_ppe, "dambreak, " + start.scene_name, scene.sim(),
                    checkpoints.restart() != nullptr);
    }
    attach_probes(series, o.probes, scene.sim(), ranks.root());
    Progress progress(p.end_time, "s");
    try {
      run<dambreak::Scene>(scene, series, progress, ranks.root(), [](const dambreak::Scene& sc) {
        char text[40];
        std::snprintf(text, sizeof text, "front %.3f a", sc.samples().back().front / sc.params().width);
        return std::string(text);
      }, checkpoints);
    } catch (const RunStopped& stop) {
      progress.finish(sim.time(), sim.last_step().step);
      if (ranks.root()) write_series(dir, scene, sim.config().rho);  // the front, levels and pressures so far
      return report_stop(dir, stop, params, sim, checkpoints);
    } catch (const mps::SimulationError& e) {
      progress.finish(sim.time(), sim.last_step().step);
      // The step stops every rank at the same stage (the scene's gathering is the last good state); the scene's own
      // check after a step may be one rank's alone.
      if (!ranks.every_rank_failed())
        ranks.end_alone(e.what(), [&] { record_failure_alone(dir, e.what(), params, sim); });
      return ranks.root() ? report_guard_stop(dir, e, params, sim, &scene.all_particles()) : 1;
    }
    progress.finish(sim.time(), sim.last_step().step);
    const long removed = scene.removed(), backstop_returns = scene.backstop_returns();
    if (!ranks.root()) return 0;
    return report(dir, scene, experiments, o.front, removed, backstop_returns, params, series);
  } catch (const std::exception& e) {
    if (!ranks.every_rank_failed()) ranks.end_alone(error_message(e));
    ranks.say_error(error_message(e));
    return 1;
  }
}
