#pragma once
// An acoustic case (MPS-WP, mps::AcousticSolver) stepped to its end against the exact solution, as `acoustic` runs
// its cases and sparsemps-run an [acoustic] scene file: errors and energies at the sample times, centerline.csv, the
// pressure maps (PNG), VTK frames, energy.csv, checkpoints and summary.json. One loop for both, so that a scene file
// gives its app's numbers.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <limits>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "checkpoints.hpp"
#include "console.hpp"
#include "mps/acoustics/acoustic.hpp"
#include "mps/io/io.hpp"
#include "png.hpp"
#include "run_json.hpp"

namespace acoustic {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

inline double seconds_since(Clock::time_point start) {
  return std::chrono::duration<double>(Clock::now() - start).count();
}

// A case as its run needs it: the solver's configuration, the pulses it starts from (and, repeated, fires again at
// `frequency`), its end, the times it is compared with the exact solution (`samples`) and mapped (`maps`), the
// frames (-1: one at every map time), the exact solution's quadrature tolerance [eps], the output folder, and what
// the summary adds (a scene file's name).
struct AcousticRun {
  mps::AcousticConfig config;
  std::vector<mps::GaussianPulse> sources;
  bool repeated = false;
  double frequency = 0;  // [Hz]
  double t_end = 0;
  std::vector<double> samples, maps;
  int frames = -1;
  double tolerance = 1e-10;
  fs::path dir;
  nlohmann::json summary_extra = nlohmann::json::object();
  [[nodiscard]] bool hard() const { return config.boundary == mps::AcousticBoundary::hard; }
};

inline double median(std::vector<double> v) {
  if (v.empty()) return 0.0;
  const auto mid = v.begin() + static_cast<std::ptrdiff_t>(v.size() / 2);
  std::nth_element(v.begin(), mid, v.end());
  return *mid;
}

inline std::string time_tag(double t) {
  char s[32];
  std::snprintf(s, sizeof s, "%.4f", t);
  return s;
}


// The interior particles (the first n_in), each one's pixel in the pressure maps and the centreline's particles.
struct Lattice {
  std::size_t n_in;
  std::span<const double> xs, ys;
  int nx;
  std::vector<std::size_t> pixel, line;
};

inline Lattice make_lattice(const mps::AcousticSolver& solver, const mps::AcousticConfig& config) {
  const std::size_t n_in = solver.interior();
  const std::span<const double> xs(solver.particles().x.data(), n_in), ys(solver.particles().y.data(), n_in);
  // Pixel (column, row) of each interior particle: the interior is a cell-centred lattice.
  const int nx = static_cast<int>(std::lround((config.box.x1 - config.box.x0) / config.l0));
  std::vector<std::size_t> pixel(n_in);
  for (std::size_t i = 0; i < n_in; ++i) {
    const long col = std::lround((xs[i] - config.box.x0) / config.l0 - 0.5);
    const long row = std::lround((ys[i] - config.box.y0) / config.l0 - 0.5);
    pixel[i] = static_cast<std::size_t>(row) * static_cast<std::size_t>(nx) + static_cast<std::size_t>(col);
  }
  // The centreline: the row of particles nearest y = 0 (y = l0/2 on the default lattice).
  double y_line = std::numeric_limits<double>::infinity();
  for (double y : ys)
    if (std::abs(y) < std::abs(y_line) - 1e-12 || (std::abs(std::abs(y) - std::abs(y_line)) < 1e-12 && y > y_line))
      y_line = y;
  std::vector<std::size_t> line;
  for (std::size_t i = 0; i < n_in; ++i)
    if (std::abs(ys[i] - y_line) < 1e-9) line.push_back(i);
  std::sort(line.begin(), line.end(), [&](std::size_t a, std::size_t b) { return xs[a] < xs[b]; });
  return {n_in, xs, ys, nx, pixel, line};
}

// What the run measures: centerline.csv's columns (x, then a measured and an exact column a sample), the samples'
// and maps' entries of the summary, energy.csv's series and the timings.
struct Record {
  std::vector<std::string> line_header{"x_m"};
  std::vector<std::vector<double>> line_columns{1};
  nlohmann::json sample_log = nlohmann::json::array(), map_log = nlohmann::json::array();
  std::vector<double> energy_t, energy_fraction;
  double exact_s = 0.0, step_s = 0.0;
  std::vector<double> step_times, spmv_times;

  [[nodiscard]] nlohmann::json save_state() const {
    nlohmann::json columns = nlohmann::json::array();
    for (const auto& c : line_columns) columns.push_back(mps::pack_array(c));
    return {{"line_header", line_header}, {"line_columns", columns}, {"sample_log", sample_log}, {"map_log", map_log},
            {"energy_t", mps::pack_array(energy_t)}, {"energy_fraction", mps::pack_array(energy_fraction)},
            {"exact_s", exact_s}, {"step_s", step_s}, {"step_times", mps::pack_array(step_times)},
            {"spmv_times", mps::pack_array(spmv_times)}};
  }
  void restore_state(const nlohmann::json& state) {
    line_header = state.at("line_header").get<std::vector<std::string>>();
    line_columns.assign(state.at("line_columns").size(), {});
    for (std::size_t c = 0; c < line_columns.size(); ++c)
      mps::unpack_array(nlohmann::json{{"c", state.at("line_columns")[c]}}, "c", line_columns[c]);
    sample_log = state.at("sample_log");
    map_log = state.at("map_log");
    mps::unpack_array(state, "energy_t", energy_t);
    mps::unpack_array(state, "energy_fraction", energy_fraction);
    exact_s = state.at("exact_s").get<double>();
    step_s = state.at("step_s").get<double>();
    mps::unpack_array(state, "step_times", step_times);
    mps::unpack_array(state, "spmv_times", spmv_times);
  }
};

// A sample time: the errors and energies against the exact field, a line on the console, and the centreline's
// measured and exact pressure added to centerline.csv.
inline void take_sample(const mps::AcousticSolver& solver, const AcousticRun& start, const Lattice& lattice, double t,
                 const std::vector<double>& p, const mps::AcousticField& exact, Record& record, Progress& progress) {
  const mps::AcousticConfig& config = start.config;
  std::vector<double> lp, le;
  for (std::size_t i : lattice.line) {
    lp.push_back(p[i]);
    le.push_back(exact.p[i]);
  }
  const double error = mps::relative_rms_error(p, exact.p), line_error = mps::relative_rms_error(lp, le);
  const double exact_energy =
      mps::acoustic_energy(exact.p, exact.u, exact.v, config.l0 * config.l0, config.c0, config.rho0);
  const double e = solver.energy(), injected = solver.injected_energy();
  double peak = 0.0;
  for (double v : le) peak = std::max(peak, std::abs(v));
  record.sample_log.push_back({{"time_s", t}, {"relative_rms_error", error},
                               {"centreline_relative_rms_error", line_error}, {"energy_fraction", e / injected},
                               {"exact_in_box_energy_fraction", exact_energy / injected},
                               {"centreline_peak_exact_dp_pa", peak}});
  progress.clear();
  std::printf("t = %.4f s  step %5d  rel. RMS error %.3f %% (centreline %.3f %%)  energy %.3f %% of injected "
              "(exact field in box %.3f %%)\n",
              t, solver.steps(), 100 * error, 100 * line_error, 100 * e / injected, 100 * exact_energy / injected);
  record.line_header.push_back("dp_t" + time_tag(t));
  record.line_header.push_back("exact_t" + time_tag(t));
  record.line_columns.push_back(lp);
  record.line_columns.push_back(le);
  mps::write_csv(start.dir / "centerline.csv", record.line_header, record.line_columns);
}

// A map time: the interior's pressure as a PNG, scaled to its largest |dp|.
inline void write_map(const fs::path& dir, const Lattice& lattice, double t, const std::vector<double>& p,
                      Record& record) {
  const std::size_t n_in = lattice.n_in;
  std::vector<double> image(n_in);
  double range = 0.0;
  for (std::size_t i = 0; i < n_in; ++i) {
    image[lattice.pixel[i]] = p[i];
    range = std::max(range, std::abs(p[i]));
  }
  const std::string file = "maps/dp_t" + time_tag(t) + ".png";
  acoustic::write_field_png(dir / file, lattice.nx, static_cast<int>(n_in) / lattice.nx, image, range);
  record.map_log.push_back({{"time_s", t}, {"file", file}, {"range_pa", range}});
}

// Steps to the end, comparing with the exact field at the sample, map and frame times, keeping the energy every tenth
// step and timing the steps and a gradient SpMV, and writing checkpoints when due; a SimulationError goes to the
// caller, and so does RunStopped once a signal's checkpoint is written. A restart continues from its checkpoint.
inline void step_to_end(mps::AcousticSolver& solver, const AcousticRun& start, const Lattice& lattice, Record& record,
         Progress& progress, Checkpoints& checkpoints) {
  const mps::AcousticConfig& config = start.config;
  const std::vector<double>& samples = start.samples, &maps = start.maps;
  const double t_end = start.t_end;
  const fs::path& dir = start.dir;
  const std::size_t n_in = lattice.n_in;
  std::optional<mps::Rect> walls;
  if (start.hard()) walls = config.box;
  for (std::size_t i : lattice.line) record.line_columns[0].push_back(lattice.xs[i]);
  mps::PvdSeries series(dir / "acoustic.pvd");
  std::vector<double> spmv_in(static_cast<std::size_t>(solver.gradient().x.cols), 1.0), spmv_out(n_in);
  int frame = 0;

  auto interior_of = [&](const std::vector<double>& all) {
    return std::vector<double>(all.begin(), all.begin() + static_cast<std::ptrdiff_t>(n_in));
  };
  auto write_frame = [&](const std::vector<double>& exact_p) {
    mps::Particles p = solver.particles();
    p.p = solver.pressure();
    p.u = solver.velocity_x();
    p.v = solver.velocity_y();
    std::vector<double> exact_all(p.size(), 0.0);
    std::copy(exact_p.begin(), exact_p.end(), exact_all.begin());
    char name[48];
    std::snprintf(name, sizeof name, "frames/acoustic_%04d.vtp", frame++);
    mps::write_vtp(dir / name, p, solver.time(), {.scalars = {{"exact_pressure", exact_all}}});
    series.add(solver.time(), dir / name);
  };

  std::size_t next_sample = 0, next_map = 0, next_pulse = 1;
  auto save = [&]() -> nlohmann::json {
    return {{"record", record.save_state()}, {"frame", frame}, {"frames", series.save_state()},
            {"next_sample", next_sample}, {"next_map", next_map}, {"next_pulse", next_pulse}};
  };
  auto save_solver = [&] { return solver.save_state(); };
  if (const nlohmann::json* restart = checkpoints.restart()) {
    solver.restore_state(restart->at("simulation"));
    const nlohmann::json& saved = checkpoints.scene();
    record.restore_state(saved.at("record"));
    frame = saved.at("frame").get<int>();
    series.restore_state(saved.at("frames"));
    next_sample = saved.at("next_sample").get<std::size_t>();
    next_map = saved.at("next_map").get<std::size_t>();
    next_pulse = saved.at("next_pulse").get<std::size_t>();
    std::printf("restarted at step %d, t = %.4g s\n", solver.steps(), solver.time());
  }
  const int frames = start.frames;
  const double frame_dt = frames > 0 ? t_end / std::max(1, frames - 1) : 2 * t_end;
  const double period = 1.0 / start.frequency;
  const double half_step = 0.5 * solver.dt();
  while (true) {
    const double t = solver.time();
    const bool sample_now = next_sample < samples.size() && t >= samples[next_sample] - half_step;
    const bool map_now = next_map < maps.size() && t >= maps[next_map] - half_step;
    const bool frame_now = frames < 0 ? map_now : frames > 0 && t >= frame * frame_dt - half_step && frame < frames;
    if (sample_now || map_now || frame_now) {
      const auto t0 = Clock::now();
      const mps::AcousticField exact = exact_acoustic_field(lattice.xs, lattice.ys, t, solver.pulses(), config.c0,
                                                            config.rho0, config.u0x, config.u0y, walls,
                                                            start.tolerance);
      record.exact_s += seconds_since(t0);
      const std::vector<double> p = interior_of(solver.pressure());
      if (sample_now) {
        take_sample(solver, start, lattice, t, p, exact, record, progress);
        ++next_sample;
      }
      if (map_now) {
        write_map(dir, lattice, t, p, record);
        ++next_map;
      }
      if (frame_now) write_frame(exact.p);
    }
    if (t >= t_end - half_step) break;
    // The flow case's source fires again every period (after this time's outputs, so that a sample never
    // sees a pulse that has not propagated yet).
    if (start.repeated && t >= next_pulse * period - half_step) {
      for (const auto& s : start.sources) solver.add_pulse(s);
      ++next_pulse;
    }
    const auto t0 = Clock::now();
    try {
      solver.step();
    } catch (const mps::SimulationError&) {
      checkpoints.write(save_solver, save);  // the last good state, to restart from
      throw;
    }
    record.step_times.push_back(seconds_since(t0));
    record.step_s += record.step_times.back();
    progress.update(solver.time(), solver.steps());  // after the step's timing: printing is not the step's cost
    if (solver.steps() % 20 == 1) {
      const auto t1 = Clock::now();
      solver.gradient().x.multiply(spmv_in, spmv_out);
      record.spmv_times.push_back(seconds_since(t1));
    }
    if (solver.steps() % 10 == 0) {
      record.energy_t.push_back(solver.time());
      record.energy_fraction.push_back(solver.energy() / solver.injected_energy());
    }
    // Nothing is kept from an earlier step's matrix: every step continues bitwise.
    checkpoints.after_step(solver.steps(), solver.time(), true, false, save_solver, save, progress);
  }
}

// summary.json: the status (and error), the parameters, samples, maps, energy and timings; returns what it wrote.
inline nlohmann::json summarise(const AcousticRun& run, const std::string& status, const std::string& error,
                                const mps::AcousticSolver& solver, const nlohmann::json& params, const Record& record,
                                double setup_s, double cfl_limit) {
  const std::size_t n_in = solver.interior();
  const double step_s = record.step_s;
  const int steps = solver.steps();
  const double per_step = steps > 0 ? step_s / steps : 0.0;
  nlohmann::json s = {{"status", status}, {"parameters", params}, {"time_s", solver.time()}, {"steps", steps},
                      {"particles", {{"interior", n_in}, {"virtual", solver.particles().size() - n_in}}},
                      {"gradient_nonzeros", solver.gradient().x.nnz()}, {"stable_cfl", cfl_limit},
                      {"samples", record.sample_log}, {"maps", record.map_log},
                      {"energy", {{"injected_j_per_m", solver.injected_energy()},
                                  {"final_fraction", solver.injected_energy() > 0
                                                         ? solver.energy() / solver.injected_energy()
                                                         : 0.0}}}};
  if (!error.empty()) s["error"] = error;
  // Per-step cost in units of one SpMV of the x-gradient matrix, both timed through the run (medians), so that
  // load from other processes on the machine hits numerator and denominator alike.
  const double step_median = median(record.step_times), spmv_median = median(record.spmv_times);
  s["timings"] = {{"setup_s", setup_s}, {"stepping_s", step_s}, {"per_step_s", per_step},
                  {"per_step_median_s", step_median}, {"spmv_median_s", spmv_median},
                  {"per_step_spmv_equivalents", spmv_median > 0 ? step_median / spmv_median : 0.0},
                  {"spmv_sample_count", record.spmv_times.size()}, {"exact_solution_s", record.exact_s},
                  {"particle_steps_per_s", step_s > 0 ? static_cast<double>(n_in) * steps / step_s : 0.0}};
  s.update(run.summary_extra);
  write_summary(run.dir, s);
  return s;
}

// After a SimulationError: the last good state, energy.csv so far and a failed summary; returns the exit status.
inline int report_failure(const mps::SimulationError& e, const AcousticRun& run, const mps::AcousticSolver& solver,
                          const nlohmann::json& params, const Record& record, double setup_s, double cfl_limit) {
  const fs::path& dir = run.dir;
  mps::Particles p = solver.particles();
  p.p = solver.pressure();
  p.u = solver.velocity_x();
  p.v = solver.velocity_y();
  mps::write_vtp(dir / "last_good.vtp", p, solver.time());
  mps::write_csv(dir / "energy.csv", {"time_s", "energy_fraction"}, {record.energy_t, record.energy_fraction});
  summarise(run, "failed", e.what(), solver, params, record, setup_s, cfl_limit);
  std::cerr << "error: " << e.what() << "\nlast good state (t = " << solver.time() << " s) written to "
            << (dir / "last_good.vtp").string() << "\n";
  return 1;
}

// After the run: energy.csv, the summary and the timings on the console; returns the exit status.
inline int report(const AcousticRun& run, const mps::AcousticSolver& solver, const nlohmann::json& params,
                  const Record& record, double setup_s, double cfl_limit) {
  const fs::path& dir = run.dir;
  mps::write_csv(dir / "energy.csv", {"time_s", "energy_fraction"}, {record.energy_t, record.energy_fraction});
  const nlohmann::json s = summarise(run, "completed", "", solver, params, record, setup_s, cfl_limit);
  const auto& tm = s["timings"];
  std::printf("\n%d steps in %.2f s; median step %.3g ms = %.1f SpMV-equivalents (median gradient SpMV %.3g ms); "
              "setup %.2f s, exact solution %.2f s\n",
              solver.steps(), record.step_s, 1e3 * tm["per_step_median_s"].get<double>(),
              tm["per_step_spmv_equivalents"].get<double>(), 1e3 * tm["spmv_median_s"].get<double>(), setup_s,
              record.exact_s);
  std::printf("outputs: %s\n", dir.string().c_str());
  return 0;
}


// Steps `run` from its pulses (or from the checkpoint to restart from) to its end into run.dir, whose outputs the
// caller has cleared; returns the exit status: 0, 1 after a blow-up (its last good state written), 128 + the signal
// after a stop's checkpoint.
inline int run_acoustic(mps::AcousticSolver& solver, const AcousticRun& run, const nlohmann::json& params,
                        Checkpoints& checkpoints, double setup_s, double cfl_limit) {
  fs::create_directories(run.dir / "frames");
  fs::create_directories(run.dir / "maps");
  const Lattice lattice = make_lattice(solver, run.config);
  Record record;
  for (const auto& s : run.sources) solver.add_pulse(s);  // the initial condition
  Progress progress(run.t_end, "s");
  try {
    step_to_end(solver, run, lattice, record, progress, checkpoints);
  } catch (const RunStopped& stop) {
    progress.finish(solver.time(), solver.steps());
    mps::write_csv(run.dir / "energy.csv", {"time_s", "energy_fraction"}, {record.energy_t, record.energy_fraction});
    return report_stop(run.dir, stop, params, solver.steps(), solver.time(), checkpoints);
  } catch (const mps::SimulationError& e) {
    progress.finish(solver.time(), solver.steps());
    return report_failure(e, run, solver, params, record, setup_s, cfl_limit);
  }
  progress.finish(solver.time(), solver.steps());
  return report(run, solver, params, record, setup_s, cfl_limit);
}

}  // namespace acoustic
