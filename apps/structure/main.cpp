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

namespace fs = std::filesystem;

namespace {

mps::Particles as_particles(const mps::ElasticSolid& s) {
  mps::Particles p;
  p.reserve(s.size());
  for (std::size_t i = 0; i < s.size(); ++i) {
    const bool moving = i < s.moving();
    p.add(s.x()[i], s.y()[i], moving ? mps::Kind::fluid : mps::Kind::wall, 0, s.u()[i], s.v()[i]);
    // Mean normal stress of the first Piola-Kirchhoff tensor, as a "pressure" to colour by.
    p.p.back() = moving ? -0.5 * (s.stress()[0][i] + s.stress()[3][i]) : 0.0;
  }
  return p;
}

double relative(double value, double reference) { return std::abs(value - reference) / std::abs(reference); }

}  // namespace

int main(int argc, char** argv) {
  prefer_passive_openmp_wait(argv);
  require_one_process(AppRanks(&argc, &argv), "structure");
  record_run("structure", argc, argv);
  std::setvbuf(stdout, nullptr, _IOLBF, 0);
  std::string scene_name = "plate", model_name = "svk", out = "runs/structure",
              data = default_data_dir("structures", STRUCTURE_DATA_DIR);
  double dx = 0, end_time = 0, sample_interval = 0, period_tolerance = 0.02, amplitude_tolerance = 0.05;
  double csm3_tolerance = 0.02;
  int frames = 20;
  mps::ElasticConfig config;
  config.cfl_option = "--cfl";
  CLI::App app{"SparseMPS elastic structures (seed 003 §2.2): total-Lagrangian particle solid; the oscillating plate "
               "against its plane-strain elastic solution, Turek & Hron's CSM3 flag against its reference"};
  add_general_options(app);
  app.add_option("--scene", scene_name, "plate: Gray, Monaghan & Swift's clamped plate (L = 0.2 m, H = 0.02 m) set "
                 "swinging by its first mode; csm3: Turek & Hron's flag on a cylinder bending under gravity")
      ->capture_default_str()->check(CLI::IsMember({"plate", "csm3"}))->group("Scene");
  app.add_option("--model", model_name, "plate's material law: svk (St. Venant-Kirchhoff) | linear (small strain); "
                 "csm3 is svk by definition")->capture_default_str()->check(CLI::IsMember({"svk", "linear"}))
      ->group("Scene");
  app.add_option("--data", data, "folder holding turek_hron_csm3_tip_displacement.csv")->capture_default_str()
      ->group("Scene");
  app.add_option("--dx", dx, "particle spacing; must divide the thickness 0.02 m (and the plate's 0.2 m) (default: "
                 "0.002 = H/10 for the plate, 0.004 = H/5 for csm3) [m]")->check(positive_up_to(0.02))
      ->group("Numerics");
  app.add_option("--radius", config.radius, "kernel support (Wendland C2) [l0]")
      ->capture_default_str()->check(number_in(2.0, 5.0))->group("Numerics");
  app.add_option("--hourglass", config.hourglass, "alpha of the hourglass energy that holds zero-energy (zigzag) modes "
                 "(0: off)")->capture_default_str()->check(number_in(0.0, 100.0))->group("Numerics");
  app.add_option("--cfl", config.cfl, "time step: dt = CFL dx / c_p, c_p the p-wave speed")
      ->capture_default_str()->check(positive_up_to(2.0))->group("Numerics");
  app.add_option("--end-time", end_time, "simulated time (default: 5 reference periods, 1.276 s, for the plate; 4 s "
                 "for csm3) [s]")->check(positive_up_to(100.0))->group("Run");
  app.add_option("--sample-interval", sample_interval, "time between tip samples (default: 0.5 ms plate, 5 ms csm3, "
                 "the reference's own step) [s]")->check(positive_up_to(1.0))->group("Run");
  app.add_option("--period-tolerance", period_tolerance, "plate: pass if the period is within this of the reference")
      ->capture_default_str()->check(positive_up_to(10))->group("Run");
  app.add_option("--amplitude-tolerance", amplitude_tolerance, "plate: pass if the amplitude is within this")
      ->capture_default_str()->check(positive_up_to(10))->group("Run");
  app.add_option("--csm3-tolerance", csm3_tolerance, "csm3: pass if the tip's u_y mean, amplitude and frequency are "
                 "each within this of the reference over the same time")->capture_default_str()
      ->check(positive_up_to(10))->group("Run");
  app.add_option("--out", out, "output directory")->check(output_directory())->capture_default_str()->group("Output");
  app.add_option("--frames", frames, "number of .vtp frames to write")->capture_default_str()
      ->check(whole_in(0, 100000))->group("Output");
  if (const auto status = parse_options(app, argc, argv)) return *status;

  try {
    const bool plate_scene = scene_name == "plate";
    const structure::Plate plate;
    const structure::Flag flag;
    mps::ElasticBody body;
    if (plate_scene) {
      config.material = plate.material(mps::parse_elastic_model(model_name));
      dx = dx > 0 ? dx : 0.002;
      end_time = end_time > 0 ? end_time : 5 * structure::PlateReference::period;
      sample_interval = sample_interval > 0 ? sample_interval : 5e-4;
      body = structure::plate_body(plate, dx, config.radius);
    } else {
      if (model_name != "svk") throw std::invalid_argument("csm3 is defined with St. Venant-Kirchhoff: drop --model");
      config.material = structure::Flag::material();
      config.gravity_y = -flag.gravity;
      dx = dx > 0 ? dx : 0.004;
      end_time = end_time > 0 ? end_time : 4.0;
      sample_interval = sample_interval > 0 ? sample_interval : 5e-3;
      body = structure::flag_body(flag, dx, config.radius);
    }
    const double dt = config.cfl * dx / config.material.p_wave_speed();
    check_run_size(static_cast<double>(body.size()), end_time / dt, "raise --dx", "shorten --end-time or raise --cfl");
    std::vector<std::vector<double>> reference;
    if (!plate_scene) reference = structure::read_csv_columns((fs::path(data) / "turek_hron_csm3_tip_displacement.csv").string(), 3);

    mps::ElasticSolid solid(body, config);
    if (plate_scene) {
      std::vector<double> u(solid.size(), 0.0), v(solid.size(), 0.0);
      for (std::size_t i = 0; i < solid.moving(); ++i)
        v[i] = structure::plate_initial_velocity(plate, config.material, solid.reference_x()[i]);
      solid.set_velocity(u, v);
    }
    const double probe_x = plate_scene ? plate.length : flag.tip_x, probe_y = plate_scene ? 0.0 : flag.cy;
    const nlohmann::json params{
        {"scene", scene_name}, {"dx_m", dx}, {"model", mps::to_string(config.material.model)},
        {"density_kg_per_m3", config.material.density}, {"modulus_pa", config.material.youngs_modulus},
        {"poisson", config.material.poisson_ratio}, {"plane", "strain"},
        {"kernel", "Wendland C2, corrected gradient (reference configuration)"}, {"radius_l0", config.radius},
        {"hourglass", config.hourglass}, {"cfl", config.cfl}, {"stable_cfl", solid.stable_cfl()}, {"dt_s", solid.dt()},
        {"p_wave_speed_m_per_s", config.material.p_wave_speed()},
        {"gravity_m_per_s2", {config.gravity_x, config.gravity_y}}, {"integrator", "velocity Verlet"},
        {"end_time_s", end_time}, {"sample_interval_s", sample_interval}, {"probe_m", {probe_x, probe_y}},
        {"clamp", plate_scene ? "lattice continued to x < 0, as deep as the kernel radius, held at rest"
                              : "lattice continued into the cylinder along the flag's thickness, kernel radius deep, held"},
        {"velocity_factor", plate_scene ? plate.velocity_factor : 0.0},
        {"guard_energy_fraction", config.guard_energy_fraction}, {"data", data}};
    std::cout << parameter_table(
        "structure, " + scene_name + ": " + std::to_string(solid.moving()) + " moving and " +
            std::to_string(solid.size() - solid.moving()) + " clamped particles",
        params,
        {{"scene", {"model", "density_kg_per_m3", "modulus_pa", "poisson", "p_wave_speed_m_per_s", "gravity_m_per_s2",
                    "probe_m"}},
         {"numerics", {"dx_m", "radius_l0", "hourglass", "cfl", "stable_cfl", "dt_s"}},
         {"run", {"end_time_s", "sample_interval_s"}}});

    const fs::path dir(out);
    clear_outputs(dir, {"frames", "structure.pvd", "tip.csv", "energy.csv", "summary.json", "last_good.vtp",
                        "config.toml"});
    write_run_config(app, "structure", dir);
    fs::create_directories(dir / "frames");
    mps::PvdSeries series(dir / "structure.pvd");
    std::vector<double> t, ux, uy, ek, es, eg, et;
    auto sample = [&] {
      const auto d = solid.displacement_at(probe_x, probe_y);
      const auto& e = solid.energy();
      t.push_back(solid.time());
      ux.push_back(d[0]);
      uy.push_back(d[1]);
      ek.push_back(e.kinetic);
      es.push_back(e.strain);
      eg.push_back(e.gravity);
      et.push_back(e.total());
    };
    int next_frame = 0, next_sample = 0;
    auto frame = [&] {
      char name[64];
      std::snprintf(name, sizeof name, "frames/structure_%04d.vtp", next_frame++);
      mps::write_vtp(dir / name, as_particles(solid), solid.time());
      series.add(solid.time(), dir / name);
    };
    const double frame_interval = frames > 0 ? end_time / frames : 2 * end_time;
    sample();
    ++next_sample;
    if (frames > 0) frame();
    const auto start = std::chrono::steady_clock::now();
    Progress progress(end_time, "s");
    try {
      double next_report = end_time / 10;
      while (solid.time() < end_time - 0.5 * solid.dt()) {
        solid.step();
        progress.update(solid.time(), solid.steps());
        if (solid.time() >= next_sample * sample_interval - 0.5 * solid.dt()) {
          sample();
          ++next_sample;
        }
        if (frames > 0 && solid.time() >= next_frame * frame_interval - 0.5 * solid.dt()) frame();
        if (solid.time() >= next_report) {
          progress.clear();
          std::printf("t = %.3f s  step %d  tip (%.5f, %.5f) m  energy: kinetic %.4g strain %.4g gravity %.4g total "
                      "%.6g J/m\n", solid.time(), solid.steps(), ux.back(), uy.back(), ek.back(), es.back(), eg.back(),
                      et.back());
          next_report += end_time / 10;
        }
      }
    } catch (const mps::SimulationError& e) {
      progress.finish(solid.time(), solid.steps());
      std::cerr << "error: " << e.what() << "\n";
      mps::write_vtp(dir / "last_good.vtp", as_particles(solid), solid.time());
      mps::write_csv(dir / "tip.csv", {"t", "ux", "uy"}, {t, ux, uy});
      write_summary(dir, {{"status", "failed"}, {"error", e.what()}, {"parameters", params},
                                             {"time_s", solid.time()}, {"steps", solid.steps()}});
      std::cerr << "last good state written to " << (dir / "last_good.vtp").string() << "\n";
      return 1;
    }
    const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    progress.finish(solid.time(), solid.steps());
    mps::write_csv(dir / "tip.csv", {"t", "ux", "uy"}, {t, ux, uy});
    mps::write_csv(dir / "energy.csv", {"t", "kinetic", "strain", "gravity", "total"}, {t, ek, es, eg, et});

    // Energy drift: the largest |E(t) - E(0)| over the largest kinetic + strain energy of the run.
    double drift = 0, largest = 0;
    for (std::size_t k = 0; k < t.size(); ++k) {
      drift = std::max(drift, std::abs(et[k] - et[0]));
      largest = std::max(largest, ek[k] + es[k]);
    }
    drift = largest > 0 ? drift / largest : 0.0;
    nlohmann::json checks{{"energy_drift_fraction", drift}};
    bool pass = true;
    if (plate_scene) {
      using R = structure::PlateReference;
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
      pass = e_period <= period_tolerance && e_amplitude <= amplitude_tolerance;
      // A figure the run is too short to give (no period before two upward crossings) is left out, not written NaN.
      if (std::isfinite(period)) checks.update({{"period_s", period}, {"period_error", e_period}});
      if (first_found) checks["first_max_m"] = first_max;
      checks.update({{"period_reference_s", R::period}, {"amplitude_m", amplitude},
                     {"amplitude_reference_m", R::amplitude}, {"amplitude_error", e_amplitude},
                     {"first_max_reference_m", R::first_max}, {"period_euler_bernoulli_s", R::euler_bernoulli_period},
                     {"period_tolerance", period_tolerance}, {"amplitude_tolerance", amplitude_tolerance}});
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
    } else {
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
      pass = em <= csm3_tolerance && ea <= csm3_tolerance && ef <= csm3_tolerance;
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
    }
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
  } catch (const std::exception& e) {
    std::cerr << "error: " << error_message(e) << "\n";
    return 1;
  }
}
