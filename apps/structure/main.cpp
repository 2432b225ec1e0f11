// Elastic structures (seed 003 §2.2): the oscillating plate of Gray, Monaghan & Swift (2001) against the plane-strain
// elastic solution of the same plate, and Turek & Hron's CSM3 flag under gravity against its reference. Writes
// tip.csv, energy.csv, frames (.vtp/.pvd) and summary.json to --out.
#include <CLI/CLI.hpp>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <omp.h>

#include "checkpoints.hpp"
#include "checks.hpp"
#include "console.hpp"
#include "data_dir.hpp"
#include "help.hpp"
#include "mps/core/particles.hpp"
#include "mps/io/io.hpp"
#include "openmp_wait.hpp"
#include "ranks.hpp"
#include "run_config.hpp"
#include "run_json.hpp"
#include "scenes.hpp"
#include "solid_run.hpp"

namespace fs = std::filesystem;

namespace {

double relative(double value, double reference) { return std::abs(value - reference) / std::abs(reference); }

// The command line.
struct Options {
  std::string scene_name = "plate", model_name = "svk", out = "runs/structure",
              data = default_data_dir("structures", STRUCTURE_DATA_DIR);
  // 0: what the spacing reaches (Start::period_tolerance ...).
  double dx = 0, end_time = 0, sample_interval = 0, period_tolerance = 0, amplitude_tolerance = 0;
  double csm3_tolerance = 0;
  int frames = 20;
  mps::ElasticConfig config;
  CheckpointOptions checkpoints;
};

void add_options(CLI::App& app, Options& o) {
  add_general_options(app);
  add_two_d_only_option(app, "the elastic solid is 2-D");
  app.add_option("--scene", o.scene_name, "plate: Gray, Monaghan & Swift's clamped plate (L = 0.2 m, H = 0.02 m) set "
                 "swinging by its first mode; csm3: Turek & Hron's flag on a cylinder bending under gravity")
      ->capture_default_str()->check(CLI::IsMember({"plate", "csm3"}))->group("Scene");
  app.add_option("--model", o.model_name, "plate's material law: svk (St. Venant-Kirchhoff) | linear (small strain); "
                 "csm3 is svk by definition")->capture_default_str()->check(CLI::IsMember({"svk", "linear"}))
      ->group("Scene");
  app.add_option("--data", o.data, "folder holding turek_hron_csm3_tip_displacement.csv")->capture_default_str()
      ->group("Scene");
  app.add_option("--dx", o.dx, "particle spacing; must divide the thickness 0.02 m (and the plate's 0.2 m) (default: "
                 "0.002 = H/10) [m]")->check(positive_up_to(0.02))
      ->group("Numerics");
  app.add_option("--radius", o.config.radius, "kernel support (Wendland C2) [l0]")
      ->capture_default_str()->check(number_in(2.0, 5.0))->group("Numerics");
  app.add_option("--hourglass", o.config.hourglass, "alpha of the hourglass energy that holds zero-energy (zigzag) modes "
                 "(0: off)")->capture_default_str()->check(number_in(0.0, 100.0))->group("Numerics");
  app.add_option("--cfl", o.config.cfl, "time step: dt = CFL dx / c_p, c_p the p-wave speed")
      ->capture_default_str()->check(positive_up_to(2.0))->group("Numerics");
  app.add_option("--end-time", o.end_time, "simulated time (default: 5 reference periods, 1.276 s, for the plate; 4 s "
                 "for csm3) [s]")->check(positive_up_to(100.0))->group("Run");
  app.add_option("--sample-interval", o.sample_interval, "time between tip samples (default: 0.5 ms plate, 5 ms csm3, "
                 "the reference's own step) [s]")->check(positive_up_to(1.0))->group("Run");
  app.add_option("--period-tolerance", o.period_tolerance, "plate: pass if the period is within this of the reference "
                 "(default: what the spacing reaches, 0.02 x dx / (H/20): 0.04 at H/10)")
      ->check(positive_up_to(10))->group("Run");
  app.add_option("--amplitude-tolerance", o.amplitude_tolerance, "plate: pass if the amplitude is within this "
                 "(default: 0.025 x dx / (H/20): 0.05 at H/10)")->check(positive_up_to(10))->group("Run");
  app.add_option("--csm3-tolerance", o.csm3_tolerance, "csm3: pass if the tip's u_y mean, amplitude and frequency are "
                 "each within this of the reference over the same time (default: 0.02 x dx / (H/20): 0.04 at H/10)")
      ->check(positive_up_to(10))->group("Run");
  app.add_option("--out", o.out, "output directory")->check(output_directory())->capture_default_str()->group("Output");
  add_checkpoint_options(app, o.checkpoints);
  app.add_option("--frames", o.frames, "number of .vtp frames to write")->capture_default_str()
      ->check(whole_in(0, 100000))->group("Output");
}

// The scene the options describe: the plate's or the flag's body, material, spacing, end time and sample interval
// (the scene's defaults where no option gives them), the point sampled and, for csm3, the reference.
struct Start {
  bool plate_scene;
  structure::Plate plate;
  structure::Flag flag;
  mps::ElasticConfig config;
  mps::ElasticBody body;
  double dx, end_time, sample_interval, probe_x, probe_y;
  std::vector<std::vector<double>> reference;  // csm3: t, u_x and u_y of the tip
  // The checks' tolerances: the options', or what the spacing reaches. Both scenes converge at first order to their
  // targets at H/20 (docs/structures.md: the plate's period 1.41 % there, csm3's figures 1.80 % at most), so a
  // coarser default is held to the targets scaled by the spacing.
  double period_tolerance, amplitude_tolerance, csm3_tolerance;
};

Start make_start(const Options& o) {
  Start start{o.scene_name == "plate", {}, {}, o.config, {}, o.dx, o.end_time, o.sample_interval, 0, 0, {}, 0, 0, 0};
  const bool plate_scene = start.plate_scene;
  const structure::Plate& plate = start.plate;
  const structure::Flag& flag = start.flag;
  mps::ElasticConfig& config = start.config;
  double &dx = start.dx, &end_time = start.end_time, &sample_interval = start.sample_interval;
  mps::ElasticBody& body = start.body;
  std::vector<std::vector<double>>& reference = start.reference;
  config.cfl_option = "--cfl";  // the guard's message names this app's option
  if (plate_scene) {
    config.material = plate.material(mps::parse_elastic_model(o.model_name));
    dx = dx > 0 ? dx : 0.002;
    end_time = end_time > 0 ? end_time : 5 * structure::PlateReference::period;
    sample_interval = sample_interval > 0 ? sample_interval : 5e-4;
    body = structure::plate_body(plate, dx, config.radius);
  } else {
    if (o.model_name != "svk") throw std::invalid_argument("csm3 is defined with St. Venant-Kirchhoff: drop --model");
    config.material = structure::Flag::material();
    config.gravity_y = -flag.gravity;
    dx = dx > 0 ? dx : 0.002;
    end_time = end_time > 0 ? end_time : 4.0;
    sample_interval = sample_interval > 0 ? sample_interval : 5e-3;
    body = structure::flag_body(flag, dx, config.radius);
  }
  const double dt = config.cfl * dx / config.material.p_wave_speed();
  check_run_size(static_cast<double>(body.size()), end_time / dt, "raise --dx", "shorten --end-time or raise --cfl");
  if (!plate_scene) reference = structure::read_csv_columns((fs::path(o.data) / "turek_hron_csm3_tip_displacement.csv").string(), 3);
  const double coarseness = dx / (0.02 / 20);  // the spacing over H/20, H = 0.02 m for both bodies
  start.period_tolerance = o.period_tolerance > 0 ? o.period_tolerance : 0.02 * coarseness;
  start.amplitude_tolerance = o.amplitude_tolerance > 0 ? o.amplitude_tolerance : 0.025 * coarseness;
  start.csm3_tolerance = o.csm3_tolerance > 0 ? o.csm3_tolerance : 0.02 * coarseness;
  start.probe_x = plate_scene ? plate.length : flag.tip_x;
  start.probe_y = plate_scene ? 0.0 : flag.cy;
  return start;
}

// The plate starts swinging in its first mode; the flag starts at rest.
void set_initial_velocity(mps::ElasticSolid& solid, const Start& start) {
  if (start.plate_scene) {
    std::vector<double> u(solid.size(), 0.0), v(solid.size(), 0.0);
    for (std::size_t i = 0; i < solid.moving(); ++i)
      v[i] = structure::plate_initial_velocity(start.plate, start.config.material, solid.reference_x()[i]);
    solid.set_velocity(u, v);
  }
}

// The run's parameters, for the table on the console and summary.json.
nlohmann::json params_json(const Options& o, const Start& start, const mps::ElasticSolid& solid) {
  const mps::ElasticConfig& config = start.config;
  const bool plate_scene = start.plate_scene;
  return {
      {"scene", o.scene_name}, {"dx_m", start.dx}, {"model", mps::to_string(config.material.model)},
      {"density_kg_per_m3", config.material.density}, {"modulus_pa", config.material.youngs_modulus},
      {"poisson", config.material.poisson_ratio}, {"plane", "strain"},
      {"kernel", "Wendland C2, corrected gradient (reference configuration)"}, {"radius_l0", config.radius},
      {"hourglass", config.hourglass}, {"cfl", config.cfl}, {"stable_cfl", solid.stable_cfl()}, {"dt_s", solid.dt()},
      {"p_wave_speed_m_per_s", config.material.p_wave_speed()},
      {"gravity_m_per_s2", {config.gravity_x, config.gravity_y}}, {"integrator", "velocity Verlet"},
      {"end_time_s", start.end_time}, {"sample_interval_s", start.sample_interval},
      {"probe_m", {start.probe_x, start.probe_y}},
      {"clamp", plate_scene ? "lattice continued to x < 0, as deep as the kernel radius, held at rest"
                            : "lattice continued into the cylinder along the flag's thickness, kernel radius deep, held"},
      {"velocity_factor", plate_scene ? start.plate.velocity_factor : 0.0},
      {"guard_energy_fraction", config.guard_energy_fraction}, {"data", o.data}};
}

// tip.csv's columns: the time and the tip's displacement at each of the probe's samples.
struct Tip {
  std::vector<double> t, ux, uy;
};
Tip tip_of(const SolidSamples& s) {
  Tip tip;
  for (const std::vector<double>& row : s.probes.rows()) {
    tip.t.push_back(row[0]);
    tip.ux.push_back(row[1]);
    tip.uy.push_back(row[2]);
  }
  return tip;
}
void write_tip(const fs::path& dir, const SolidSamples& s) {
  const Tip tip = tip_of(s);
  mps::write_csv(dir / "tip.csv", {"t", "ux", "uy"}, {tip.t, tip.ux, tip.uy});
}

// The plate's period and amplitude against the reference's; returns whether both are within their tolerances.
bool check_plate(const Tip& s, double drift, const Start& start, nlohmann::json& checks) {
  using R = structure::PlateReference;
  const std::vector<double>& t = s.t, &uy = s.uy;
  const double period = structure::zero_crossing_period(t, uy);
  double amplitude = 0, first_max = 0;
  bool first_found = false;
  for (std::size_t k = 0; k < uy.size(); ++k) {
    amplitude = std::max(amplitude, std::abs(uy[k]));
    if (!first_found && k + 1 < uy.size() && uy[k] > 0 && uy[k + 1] < uy[k]) {
      first_max = uy[k];
      first_found = true;
    }
  }
  const double e_period = relative(period, R::period), e_amplitude = relative(amplitude, R::amplitude);
  const bool pass = e_period <= start.period_tolerance && e_amplitude <= start.amplitude_tolerance;
  // A figure the run is too short to give (no period before two upward crossings) is left out, not written NaN.
  if (std::isfinite(period)) checks.update({{"period_s", period}, {"period_error", e_period}});
  if (first_found) checks["first_max_m"] = first_max;
  checks.update({{"period_reference_s", R::period}, {"amplitude_m", amplitude},
                 {"amplitude_reference_m", R::amplitude}, {"amplitude_error", e_amplitude},
                 {"first_max_reference_m", R::first_max}, {"period_euler_bernoulli_s", R::euler_bernoulli_period},
                 {"period_tolerance", start.period_tolerance}, {"amplitude_tolerance", start.amplitude_tolerance}});
  char period_text[96];
  if (std::isfinite(period))
    std::snprintf(period_text, sizeof period_text, "period %.5f s (reference %.5f s, error %.2f %%)", period,
                  R::period, 100 * e_period);
  else
    std::snprintf(period_text, sizeof period_text, "no period yet (the run ends before two upward crossings)");
  char max_text[48] = "no maximum yet";
  if (first_found) std::snprintf(max_text, sizeof max_text, "first maximum %.5f m", first_max);
  std::printf("\nplate tip: %s, amplitude %.5f m (reference %.5f m, error %.2f %%), %s; energy drift %.3f %% of "
              "the largest kinetic + strain energy: %s\n",
              period_text, amplitude, R::amplitude, 100 * e_amplitude,
              max_text,
              100 * drift, pass ? "PASS" : "FAIL");
  return pass;
}

// CSM3: the tip's oscillation against the reference's over the same time; returns whether the mean, amplitude and
// frequency of u_y are each within the tolerance.
bool check_csm3(const Tip& s, const std::vector<std::vector<double>>& reference, double drift,
                double csm3_tolerance, nlohmann::json& checks) {
  const std::vector<double>& t = s.t, &ux = s.ux, &uy = s.uy;
  // The reference over the same time as the run, read out the same way.
  std::vector<double> rt, rux, ruy;
  for (std::size_t k = 0; k < reference[0].size() && reference[0][k] <= t.back() + 1e-9; ++k) {
    rt.push_back(reference[0][k]);
    rux.push_back(reference[1][k]);
    ruy.push_back(reference[2][k]);
  }
  const auto run_y = structure::oscillation(t, uy), ref_y = structure::oscillation(rt, ruy);
  const auto run_x = structure::oscillation(t, ux), ref_x = structure::oscillation(rt, rux);
  const double em = relative(run_y.mean, ref_y.mean), ea = relative(run_y.amplitude, ref_y.amplitude);
  const double ef = relative(run_y.frequency, ref_y.frequency);
  bool pass = em <= csm3_tolerance && ea <= csm3_tolerance && ef <= csm3_tolerance;
  auto osc = [](const structure::Oscillation& o) {  // a frequency needs two minima
    nlohmann::json j{{"mean_m", o.mean}, {"amplitude_m", o.amplitude}, {"minima_count", o.minima}};
    if (o.minima >= 2) j["frequency_hz"] = o.frequency;
    return j;
  };
  checks.update({{"uy", osc(run_y)}, {"uy_reference", osc(ref_y)}, {"ux", osc(run_x)}, {"ux_reference", osc(ref_x)},
                 {"uy_mean_error", em}, {"uy_amplitude_error", ea},
                 {"ux_mean_error", relative(run_x.mean, ref_x.mean)},
                 {"ux_amplitude_error", relative(run_x.amplitude, ref_x.amplitude)},
                 {"tolerance", csm3_tolerance}, {"compared_up_to_s", t.back()}});
  if (run_y.minima >= 2 && ref_y.minima >= 2) checks["uy_frequency_error"] = ef;
  else pass = false;  // too short a run to check the frequency
  std::printf("\ncsm3 tip u_y: mean %.3f mm (reference %.3f), amplitude %.3f mm (%.3f): errors %.2f / %.2f %%; ",
              1e3 * run_y.mean, 1e3 * ref_y.mean, 1e3 * run_y.amplitude, 1e3 * ref_y.amplitude, 100 * em, 100 * ea);
  if (checks.contains("uy_frequency_error"))
    std::printf("frequency %.4f Hz (%.4f): error %.2f %%; ", run_y.frequency, ref_y.frequency, 100 * ef);
  else
    std::printf("frequency: too short a run (two minima needed); ");
  std::printf("u_x mean %.3f mm (%.3f), amplitude %.3f mm (%.3f); energy drift %.3f %%: %s\n", 1e3 * run_x.mean,
              1e3 * ref_x.mean, 1e3 * run_x.amplitude, 1e3 * ref_x.amplitude, 100 * drift, pass ? "PASS" : "FAIL");
  return pass;
}

// After a SimulationError: the last good state, tip.csv so far and a failed summary; returns the exit status.
int report_failure(const mps::SimulationError& e, const fs::path& dir, const mps::ElasticSolid& solid,
                   const SolidSamples& s, const nlohmann::json& params) {
  std::cerr << "error: " << e.what() << "\n";
  mps::write_vtp(dir / "last_good.vtp", solid_frame_particles(solid), solid.time());
  write_tip(dir, s);
  write_summary(dir, {{"status", "failed"}, {"error", e.what()}, {"parameters", params},
                                         {"time_s", solid.time()}, {"steps", solid.steps()}});
  std::cerr << "last good state written to " << (dir / "last_good.vtp").string() << "\n";
  return 1;
}

// After the run: tip.csv, energy.csv, the checks, the cost of a step and the summary; returns the exit status.
int report(const fs::path& dir, const mps::ElasticSolid& solid, const Start& start,
           const SolidSamples& s, const nlohmann::json& params, double seconds) {
  write_tip(dir, s);
  s.write_energy(dir / "energy.csv");
  const double drift = s.energy_drift();
  nlohmann::json checks{{"energy_drift_fraction", drift}};
  const Tip tip = tip_of(s);
  const bool pass = start.plate_scene ? check_plate(tip, drift, start, checks)
                                      : check_csm3(tip, start.reference, drift, start.csm3_tolerance, checks);
  const double steps_per_s = solid.steps() / seconds;
  // The cost of a step in products of one gradient matrix (moving rows x all columns) with a vector, timed here.
  double spmv_s = 0;
  {
    const auto& g = solid.fit().gradient.x;
    std::vector<double> in(static_cast<std::size_t>(g.cols), 1e-3), result(static_cast<std::size_t>(g.rows));
    int reps = 0;
    const auto t0 = std::chrono::steady_clock::now();
    do {
      g.multiply(in, result);
      in[static_cast<std::size_t>(reps) % in.size()] += result[0] * 1e-30;  // keeps the loop from being folded away
      ++reps;
      spmv_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    } while (spmv_s < 0.2 || reps < 10);
    spmv_s /= reps;
  }
  const double spmv_per_step = seconds / solid.steps() / spmv_s;
  write_summary(dir,
                  {{"status", pass ? "passed" : "check failed"}, {"parameters", params},
                   {"particles", {{"moving", solid.moving()}, {"clamped", solid.size() - solid.moving()}}},
                   {"steps", solid.steps()}, {"time_s", solid.time()}, {"checks", checks},
                   {"timings", {{"total_s", seconds}, {"steps_per_s", steps_per_s},
                                {"particle_steps_per_s", steps_per_s * static_cast<double>(solid.size())},
                                {"gradient_nonzeros", solid.fit().gradient.x.nnz()},
                                {"spmv_s", spmv_s}, {"per_step_spmv_equivalents", spmv_per_step},
                                {"threads", omp_get_max_threads()}}}});
  std::printf("%d steps in %.2f s (%.3g particle-steps/s, %.1f gradient SpMVs a step); outputs: tip.csv, energy.csv, structure.pvd, summary.json "
              "in %s\n", solid.steps(), seconds, steps_per_s * static_cast<double>(solid.size()), spmv_per_step,
              dir.string().c_str());
  return pass ? 0 : 2;
}

}  // namespace

int main(int argc, char** argv) {
  prefer_passive_openmp_wait(argv);
  require_one_process(AppRanks(&argc, &argv), "structure");
  record_run("structure", argc, argv);
  std::setvbuf(stdout, nullptr, _IOLBF, 0);
  CLI::App app{"SparseMPS elastic structures (seed 003 §2.2): total-Lagrangian particle solid; the oscillating plate "
               "against its plane-strain elastic solution, Turek & Hron's CSM3 flag against its reference"};
  Options o;
  add_options(app, o);
  if (const auto status = parse_options(app, argc, argv)) return *status;

  try {
    const Start start = make_start(o);
    mps::ElasticSolid solid(start.body, start.config);
    set_initial_velocity(solid, start);
    const nlohmann::json params = params_json(o, start, solid);
    std::cout << parameter_table(
        "structure, " + o.scene_name + ": " + std::to_string(solid.moving()) + " moving and " +
            std::to_string(solid.size() - solid.moving()) + " clamped particles",
        params,
        {{"scene", {"model", "density_kg_per_m3", "modulus_pa", "poisson", "p_wave_speed_m_per_s", "gravity_m_per_s2",
                    "probe_m"}},
         {"numerics", {"dx_m", "radius_l0", "hourglass", "cfl", "stable_cfl", "dt_s"}},
         {"run", {"end_time_s", "sample_interval_s"}}});

    const fs::path dir(o.out);
    Checkpoints checkpoints(o.checkpoints, dir, "structure", params, {"/end_time_s"});
    if (!checkpoints.restart())  // a restart keeps what the run wrote before its checkpoint
      clear_outputs(dir, {"frames", "structure.pvd", "tip.csv", "energy.csv", "summary.json", "last_good.vtp",
                          "config.toml", "checkpoint.cbor"});
    write_run_config(app, "structure", dir);
    fs::create_directories(dir / "frames");
    SolidSamples samples(mps::ProbeSeries(start.sample_interval));
    samples.probes.add(mps::displacement_probe("tip", {{start.probe_x, start.probe_y}}, solid));
    Progress progress(start.end_time, "s");
    double seconds = 0;
    try {
      seconds = run_solid(solid, start.end_time, o.frames, dir, "structure", samples, progress, checkpoints);
    } catch (const RunStopped& stop) {
      progress.finish(solid.time(), solid.steps());
      write_tip(dir, samples);
      return report_stop(dir, stop, params, solid.steps(), solid.time(), checkpoints);
    } catch (const mps::SimulationError& e) {
      progress.finish(solid.time(), solid.steps());
      return report_failure(e, dir, solid, samples, params);
    }
    progress.finish(solid.time(), solid.steps());
    return report(dir, solid, start, samples, params, seconds);
  } catch (const std::exception& e) {
    std::cerr << "error: " << error_message(e) << "\n";
    return 1;
  }
}
