// Acoustic wave propagation on particles (MPS-WP, seed 001): Gaussian pulses in a 100 m x 100 m box with the
// paper's cases, each compared with the exact solution. Writes pressure maps (PNG), centerline.csv, VTK
// frames, energy.csv and summary.json to --out.
#include <CLI/CLI.hpp>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <map>
#include <optional>
#include <sstream>
#include <string>
#include <vector>

#include "checkpoints.hpp"
#include "checks.hpp"
#include "console.hpp"
#include "help.hpp"
#include "mps/acoustics/acoustic.hpp"
#include "mps/io/io.hpp"
#include "mps/step/step.hpp"
#include "openmp_wait.hpp"
#include "ranks.hpp"
#include "png.hpp"
#include "run_config.hpp"
#include "run_json.hpp"

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

namespace {

double seconds_since(Clock::time_point start) { return std::chrono::duration<double>(Clock::now() - start).count(); }

struct Case {
  std::string boundary;
  double end_time;
  std::vector<double> samples, maps;
  double u0x;
  std::string description;
};

const std::map<std::string, Case>& cases() {
  static const std::map<std::string, Case> all = {
      {"free", {"mur", 0.1, {0.05, 0.1}, {0.0, 0.05, 0.1}, 0.0,
                "one pulse at the centre, free-field propagation (seed 001 Fig. 4-5)"}},
      {"hard", {"hard", 0.2, {0.1, 0.15, 0.2}, {0.1, 0.15, 0.2}, 0.0,
                "one pulse at the centre inside reflecting walls, exact solution by images (Fig. 6-7)"}},
      {"mur", {"mur", 0.3, {0.1, 0.15, 0.2, 0.25, 0.3}, {0.1, 0.15, 0.2}, 0.0,
               "one pulse at the centre leaving through Mur absorbing walls (Fig. 8-9)"}},
      {"two-pulse", {"mur", 0.1, {0.05, 0.1}, {0.0, 0.05, 0.1}, 0.0,
                     "two pulses at (-20, 0) and (20, 0) m superposed (Fig. 10-11)"}},
      {"flow", {"mur", 0.1, {0.02, 0.05, 0.1}, {0.01, 0.02, 0.03, 0.1}, 100.0,
                "uniform mean flow along x with a pulse source at the centre repeated at --frequency (Fig. 12-14)"}},
  };
  return all;
}

std::string fmt(double v) {
  std::ostringstream s;
  s << v;
  return s.str();
}

double median(std::vector<double> v) {
  if (v.empty()) return 0.0;
  const auto mid = v.begin() + static_cast<std::ptrdiff_t>(v.size() / 2);
  std::nth_element(v.begin(), mid, v.end());
  return *mid;
}

std::string time_tag(double t) {
  char s[32];
  std::snprintf(s, sizeof s, "%.4f", t);
  return s;
}

// The command line.
struct Options {
  std::string case_name = "free", boundary_name, gradient_name = "mps", weight_name = "classic", out;
  double size = 100.0, half_width = 3.0, amplitude = 1.0, frequency = 200.0, tolerance = 1e-10;
  std::optional<double> end_time, u0;
  std::vector<double> samples, maps;
  int frames = -1;
  bool no_maps = false;
  mps::AcousticConfig config;
  CheckpointOptions checkpoints;
};

void add_options(CLI::App& app, Options& o) {
  add_general_options(app);
  add_two_d_only_option(app, "the acoustic module is 2-D");
  app.add_option("--case", o.case_name, "free | hard | mur | two-pulse | flow")->capture_default_str()->group("Scene");
  app.add_option("--size", o.size, "side of the square box [m]")->capture_default_str()->check(positive_up_to(1e5))
      ->group("Scene");
  app.add_option("--b", o.half_width, "pulse half-width b: dp = eps exp(-ln2 r^2/b^2), at most a quarter of the box [m]")
      ->capture_default_str()->check(positive_up_to(1e5))->group("Scene");
  app.add_option("--amplitude", o.amplitude, "pulse amplitude eps [Pa]")->capture_default_str()
      ->check(number_in(1e-100, 1e100))->group("Scene");
  app.add_option("--c0", o.config.c0, "speed of sound [m/s]")->capture_default_str()->check(positive_up_to(1e5))
      ->group("Scene");
  app.add_option("--rho0", o.config.rho0, "density [kg/m^3]")->capture_default_str()->check(positive_up_to(1e5))
      ->group("Scene");
  app.add_option("--u0", o.u0, "mean flow along x, below c0 (default: 100 for flow, else 0) [m/s]")
      ->check(number_in(-1e5, 1e5))->group("Scene");
  app.add_option("--frequency", o.frequency, "pulse repetition rate of the flow case [Hz]")->capture_default_str()
      ->check(positive_up_to(1e6))->group("Scene");
  app.add_option("--boundary", o.boundary_name,
                 "hard | mur (Mur at every RK4 stage) | mur-step (Mur once per step, as published) (default: the "
                 "case's)")->group("Scene");
  app.add_option("--l0", o.config.l0, "particle spacing [m]")->capture_default_str()->check(positive_up_to(1e3))
      ->group("Numerics");
  app.add_option("--cfl", o.config.cfl, "CFL number c0 dt / l0")->capture_default_str()->check(positive_up_to(100))
      ->group("Numerics");
  app.add_option("--gradient", o.gradient_name, "mps (seed 001) | ls3 (least squares, cubic)")->capture_default_str()
      ->group("Numerics");
  app.add_option("--weight", o.weight_name, "classic (re/r - 1, seed 001) | bounded")->capture_default_str()
      ->group("Numerics");
  app.add_option("--radius", o.config.radius, "kernel radius re [l0]")->capture_default_str()->check(number_in(1.5, 10.0))
      ->group("Numerics");
  app.add_option("--guard-factor", o.config.guard_energy_factor,
                 "stop when the energy exceeds this factor x the largest energy the pulses can carry")
      ->capture_default_str()->check(number_in(1.0, 1e6))->group("Numerics");
  app.add_option("--end-time", o.end_time, "simulated time (default: the case's) [s]")->check(positive_up_to(1e4))
      ->group("Run");
  app.add_option("--samples", o.samples, "times at which error and energy are measured (default: the case's) [s]")
      ->delimiter(',')->check(number_in(0.0, 1e4))->group("Run");
  app.add_option("--tolerance", o.tolerance, "absolute quadrature tolerance of the exact solution [eps]")
      ->capture_default_str()->check(number_in(1e-15, 1e-2))->group("Run");
  app.add_option("--out", o.out, "output directory (default: runs/acoustic/<case>)")->check(output_directory())->group("Output");
  add_checkpoint_options(app, o.checkpoints);
  app.add_option("--maps", o.maps, "times of the pressure-map PNGs (default: the paper's figure times) [s]")
      ->delimiter(',')->check(number_in(0.0, 1e4))->group("Output");
  app.add_flag("--no-maps", o.no_maps, "write no pressure maps (studies)")->group("Output");
  app.add_option("--frames", o.frames, "VTK frames, evenly spaced over the run (default: one at every map time; 0: none)")
      ->check(whole_in(0, 100000))->group("Output");
}

// The run the options describe, checked: the case's boundary, mean flow, end time, sample and map times where no
// option gives them, and the pulses it starts from.
struct Start {
  Case scene;
  mps::AcousticConfig config;
  double t_end;
  std::vector<double> samples, maps;
  bool frames_at_maps, hard, repeated;
  std::vector<mps::GaussianPulse> sources;
  fs::path dir;
};

Start make_start(const Options& o) {
  const auto found = cases().find(o.case_name);
  if (found == cases().end())
    throw std::invalid_argument("unknown --case '" + o.case_name + "'; valid: free, hard, mur, two-pulse, flow");
  const Case& scene = found->second;
  if (!(o.size > 0.0)) throw std::invalid_argument("--size must be positive, got " + fmt(o.size));
  if (!(o.half_width > 0.0 && o.half_width <= o.size / 4))
    throw std::invalid_argument("--b (pulse half-width) must be in (0, size/4 = " + fmt(o.size / 4) + "] m, got " +
                                fmt(o.half_width));
  if (!(o.frequency > 0.0)) throw std::invalid_argument("--frequency must be positive, got " + fmt(o.frequency));
  mps::AcousticConfig config = o.config;
  config.box = {-o.size / 2, -o.size / 2, o.size / 2, o.size / 2};
  config.boundary = mps::parse_acoustic_boundary(o.boundary_name.empty() ? scene.boundary : o.boundary_name);
  config.gradient = mps::parse_acoustic_gradient(o.gradient_name);
  config.weight = mps::parse_weight(o.weight_name);
  config.u0x = o.u0.value_or(scene.u0x);
  const double t_end = o.end_time.value_or(scene.end_time);
  if (!(std::abs(config.u0x) < config.c0))
    throw std::invalid_argument("--u0 must be below the speed of sound " + fmt(config.c0) + " m/s, got " + fmt(config.u0x));
  // A run shorter than one step would report success for nothing.
  if (!(t_end >= config.dt()))
    throw std::invalid_argument("--end-time " + fmt(t_end) + " s is shorter than one step (dt = cfl l0 / c0 = " +
                                fmt(config.dt()) + " s): lengthen --end-time or lower --cfl");
  check_run_size(o.size * o.size / (config.l0 * config.l0), t_end / config.dt(), "raise --l0 or shrink --size",
                 "shorten --end-time or raise --cfl");
  std::vector<double> samples = o.samples, maps = o.maps;
  const bool default_samples = samples.empty();
  if (default_samples) samples = scene.samples;
  if (maps.empty()) maps = scene.maps;
  if (o.no_maps) maps.clear();
  std::erase_if(samples, [&](double t) { return t > t_end + 1e-12; });
  std::erase_if(maps, [&](double t) { return t > t_end + 1e-12; });
  std::sort(samples.begin(), samples.end());
  std::sort(maps.begin(), maps.end());
  if (default_samples &&
      std::find_if(samples.begin(), samples.end(), [&](double t) { return std::abs(t - t_end) < 1e-12; }) == samples.end())
    samples.push_back(t_end);
  const bool frames_at_maps = o.frames < 0;  // default: a VTK frame beside every pressure map
  const bool hard = config.boundary == mps::AcousticBoundary::hard;
  if (hard && config.u0x != 0.0)
    throw std::invalid_argument("--boundary hard with a mean flow has no exact solution here (images need u0 = 0): "
                                "use --boundary mur or --u0 0");
  const fs::path dir(o.out.empty() ? "runs/acoustic/" + o.case_name : o.out);
  const bool repeated = o.case_name == "flow";
  std::vector<mps::GaussianPulse> sources;
  if (o.case_name == "two-pulse")
    sources = {{-20.0, 0.0, o.amplitude, o.half_width, 0.0}, {20.0, 0.0, o.amplitude, o.half_width, 0.0}};
  else
    sources = {{0.0, 0.0, o.amplitude, o.half_width, 0.0}};
  return {scene, config, t_end, samples, maps, frames_at_maps, hard, repeated, sources, dir};
}

// The run's parameters, for the table on the console and summary.json.
nlohmann::json params_json(const Options& o, const Start& start) {
  const mps::AcousticConfig& config = start.config;
  const bool hard = start.hard, repeated = start.repeated;
  return {
      {"case", o.case_name}, {"description", start.scene.description}, {"box_m", {config.box.x0, config.box.y0, config.box.x1, config.box.y1}},
      {"l0_m", config.l0}, {"cfl", config.cfl}, {"dt_s", config.dt()}, {"c0_m_per_s", config.c0}, {"rho0_kg_per_m3", config.rho0},
      {"u0_m_per_s", {config.u0x, config.u0y}}, {"pulse", {{"amplitude_pa", o.amplitude}, {"b_m", o.half_width},
                                                       {"centres_m", [&] { nlohmann::json c = nlohmann::json::array();
                                                                           for (auto& s : start.sources) c.push_back({s.x, s.y});
                                                                           return c; }()}}},
      {"frequency_hz", repeated ? nlohmann::json(o.frequency) : nlohmann::json(nullptr)},
      {"boundary", mps::to_string(config.boundary)}, {"gradient", mps::to_string(config.gradient)},
      {"weight", mps::to_string(config.weight)}, {"radius_l0", config.radius}, {"end_time_s", start.t_end},
      {"samples_s", start.samples}, {"maps_s", start.maps}, {"tolerance_over_eps", o.tolerance},
      {"guard_factor", config.guard_energy_factor},
      {"physics_on", [&] { nlohmann::json on = {"linearised Euler (RK4)",
                                                 hard ? "hard walls (mirrored particles)"
                                                      : config.boundary == mps::AcousticBoundary::mur
                                                            ? "first-order Mur boundary (at every RK4 stage)"
                                                            : "first-order Mur boundary (once per step)"};
                           if (config.u0x != 0.0) on.push_back("uniform mean flow (advective terms)");
                           if (repeated) on.push_back("repeated pulse source");
                           return on; }()},
      {"physics_off", {"pressure Poisson equation", "particle motion", "neighbour rebuilds"}},
      {"definitions", {{"relative_rms_error", "sqrt(sum (dp - dp_exact)^2 / sum dp_exact^2) over the interior particles "
                                              "(centreline: over the row nearest y = 0)"},
                       {"energy", "E = l0^2 sum (dp^2/(2 rho0 c0^2) + rho0 |du|^2/2) over the interior particles [J/m]; "
                                  "energy_fraction = E / sum of the injected pulses' energies"},
                       {"exact", hard ? "free-field Hankel integral summed over wall images"
                                      : "free-field Hankel integral (boundaries ignored), centre moved by u0 t"}}}};
}

// The interior particles (the first n_in), each one's pixel in the pressure maps and the centreline's particles.
struct Lattice {
  std::size_t n_in;
  std::span<const double> xs, ys;
  int nx;
  std::vector<std::size_t> pixel, line;
};

Lattice make_lattice(const mps::AcousticSolver& solver, const mps::AcousticConfig& config, double size) {
  const std::size_t n_in = solver.interior();
  const std::span<const double> xs(solver.particles().x.data(), n_in), ys(solver.particles().y.data(), n_in);
  // Pixel (column, row) of each interior particle: the interior is a cell-centred lattice.
  const int nx = static_cast<int>(std::lround(size / config.l0));
  std::vector<std::size_t> pixel(n_in);
  for (std::size_t i = 0; i < n_in; ++i) {
    const long col = std::lround((xs[i] - config.box.x0) / config.l0 - 0.5);
    const long row = std::lround((ys[i] - config.box.y0) / config.l0 - 0.5);
    pixel[i] = static_cast<std::size_t>(row) * static_cast<std::size_t>(nx) + static_cast<std::size_t>(col);
  }
  // The centreline: the row of particles nearest y = 0 (y = l0/2 on the default lattice).
  double y_line = std::numeric_limits<double>::infinity();
  for (double y : ys)
    if (std::abs(y) < std::abs(y_line) - 1e-12 || (std::abs(std::abs(y) - std::abs(y_line)) < 1e-12 && y > y_line)) y_line = y;
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
void take_sample(const mps::AcousticSolver& solver, const Start& start, const Lattice& lattice, double t,
                 const std::vector<double>& p, const mps::AcousticField& exact, Record& record, Progress& progress) {
  const mps::AcousticConfig& config = start.config;
  std::vector<double> lp, le;
  for (std::size_t i : lattice.line) {
    lp.push_back(p[i]);
    le.push_back(exact.p[i]);
  }
  const double error = mps::relative_rms_error(p, exact.p), line_error = mps::relative_rms_error(lp, le);
  const double exact_energy = mps::acoustic_energy(exact.p, exact.u, exact.v, config.l0 * config.l0, config.c0, config.rho0);
  const double e = solver.energy(), injected = solver.injected_energy();
  double peak = 0.0;
  for (double v : le) peak = std::max(peak, std::abs(v));
  record.sample_log.push_back({{"time_s", t}, {"relative_rms_error", error}, {"centreline_relative_rms_error", line_error},
                               {"energy_fraction", e / injected}, {"exact_in_box_energy_fraction", exact_energy / injected},
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
void write_map(const fs::path& dir, const Lattice& lattice, double t, const std::vector<double>& p, Record& record) {
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
void run(mps::AcousticSolver& solver, const Options& o, const Start& start, const Lattice& lattice, Record& record,
         Progress& progress, Checkpoints& checkpoints) {
  const mps::AcousticConfig& config = start.config;
  const std::vector<double>& samples = start.samples, &maps = start.maps;
  const double t_end = start.t_end;
  const fs::path& dir = start.dir;
  const std::size_t n_in = lattice.n_in;
  std::optional<mps::Rect> walls;
  if (start.hard) walls = config.box;
  for (std::size_t i : lattice.line) record.line_columns[0].push_back(lattice.xs[i]);
  mps::PvdSeries series(dir / "acoustic.pvd");
  std::vector<double> spmv_in(static_cast<std::size_t>(solver.gradient().x.cols), 1.0), spmv_out(n_in);
  int frame = 0;

  auto interior_of = [&](const std::vector<double>& all) { return std::vector<double>(all.begin(), all.begin() + static_cast<std::ptrdiff_t>(n_in)); };
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
    std::printf("restarted from %s at step %d, t = %.4g s\n", o.checkpoints.restart.c_str(), solver.steps(),
                solver.time());
  }
  const double frame_dt = o.frames > 0 ? t_end / std::max(1, o.frames - 1) : 2 * t_end;
  const double period = 1.0 / o.frequency;
  const double half_step = 0.5 * solver.dt();
  while (true) {
    const double t = solver.time();
    const bool sample_now = next_sample < samples.size() && t >= samples[next_sample] - half_step;
    const bool map_now = next_map < maps.size() && t >= maps[next_map] - half_step;
    const bool frame_now = start.frames_at_maps ? map_now : o.frames > 0 && t >= frame * frame_dt - half_step && frame < o.frames;
    if (sample_now || map_now || frame_now) {
      const auto t0 = Clock::now();
      const mps::AcousticField exact = exact_acoustic_field(lattice.xs, lattice.ys, t, solver.pulses(), config.c0,
                                                            config.rho0, config.u0x, config.u0y, walls, o.tolerance);
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
nlohmann::json summarise(const fs::path& dir, const std::string& status, const std::string& error,
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
                                  {"final_fraction", solver.injected_energy() > 0 ? solver.energy() / solver.injected_energy() : 0.0}}}};
  if (!error.empty()) s["error"] = error;
  // Per-step cost in units of one SpMV of the x-gradient matrix, both timed through the run (medians), so that
  // load from other processes on the machine hits numerator and denominator alike.
  const double step_median = median(record.step_times), spmv_median = median(record.spmv_times);
  s["timings"] = {{"setup_s", setup_s}, {"stepping_s", step_s}, {"per_step_s", per_step},
                  {"per_step_median_s", step_median}, {"spmv_median_s", spmv_median},
                  {"per_step_spmv_equivalents", spmv_median > 0 ? step_median / spmv_median : 0.0},
                  {"spmv_sample_count", record.spmv_times.size()}, {"exact_solution_s", record.exact_s},
                  {"particle_steps_per_s", step_s > 0 ? static_cast<double>(n_in) * steps / step_s : 0.0}};
  write_summary(dir, s);
  return s;
}

// After a SimulationError: the last good state, energy.csv so far and a failed summary; returns the exit status.
int report_failure(const mps::SimulationError& e, const fs::path& dir, const mps::AcousticSolver& solver,
                   const nlohmann::json& params, const Record& record, double setup_s, double cfl_limit) {
  mps::Particles p = solver.particles();
  p.p = solver.pressure();
  p.u = solver.velocity_x();
  p.v = solver.velocity_y();
  mps::write_vtp(dir / "last_good.vtp", p, solver.time());
  mps::write_csv(dir / "energy.csv", {"time_s", "energy_fraction"}, {record.energy_t, record.energy_fraction});
  summarise(dir, "failed", e.what(), solver, params, record, setup_s, cfl_limit);
  std::cerr << "error: " << e.what() << "\nlast good state (t = " << solver.time() << " s) written to "
            << (dir / "last_good.vtp").string() << "\n";
  return 1;
}

// After the run: energy.csv, the summary and the timings on the console; returns the exit status.
int report(const fs::path& dir, const mps::AcousticSolver& solver, const nlohmann::json& params, const Record& record,
           double setup_s, double cfl_limit) {
  mps::write_csv(dir / "energy.csv", {"time_s", "energy_fraction"}, {record.energy_t, record.energy_fraction});
  const nlohmann::json s = summarise(dir, "completed", "", solver, params, record, setup_s, cfl_limit);
  const auto& tm = s["timings"];
  std::printf("\n%d steps in %.2f s; median step %.3g ms = %.1f SpMV-equivalents (median gradient SpMV %.3g ms); "
              "setup %.2f s, exact solution %.2f s\n",
              solver.steps(), record.step_s, 1e3 * tm["per_step_median_s"].get<double>(),
              tm["per_step_spmv_equivalents"].get<double>(), 1e3 * tm["spmv_median_s"].get<double>(), setup_s,
              record.exact_s);
  std::printf("outputs: %s\n", dir.string().c_str());
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  prefer_passive_openmp_wait(argv);
  require_one_process(AppRanks(&argc, &argv), "acoustic");
  record_run("acoustic", argc, argv);
  std::setvbuf(stdout, nullptr, _IOLBF, 0);  // progress lines reach a log file as they are printed
  CLI::App app{"SparseMPS acoustics (MPS-WP, seed 001): Gaussian pulses against the exact solution"};
  Options o;
  add_options(app, o);
  if (const auto status = parse_options(app, argc, argv)) return *status;

  try {
    const Start start = make_start(o);
    const mps::AcousticConfig& config = start.config;
    const fs::path& dir = start.dir;
    const auto setup_start = Clock::now();
    mps::AcousticSolver solver(config);
    const double setup_s = seconds_since(setup_start);
    const double cfl_limit = solver.stable_cfl_estimate();
    const nlohmann::json params = params_json(o, start);
    std::cout << parameter_table("acoustic, case " + o.case_name + ": " + start.scene.description, params,
                                 {{"scene", {"boundary", "box_m", "pulse/amplitude_pa", "pulse/b_m", "c0_m_per_s",
                                             "rho0_kg_per_m3", "u0_m_per_s", "frequency_hz"}},
                                  {"numerics", {"l0_m", "cfl", "dt_s", "gradient", "weight", "radius_l0", "guard_factor"}},
                                  {"run", {"end_time_s", "samples_s", "maps_s", "tolerance_over_eps"}}});
    std::printf("particles: %zu interior + %zu virtual; gradient nnz %zu; dt = %.4g s; RK4 stable up to CFL %.3f "
                "(von Neumann estimate), running at %.3f\n",
                solver.interior(), solver.particles().size() - solver.interior(), solver.gradient().x.nnz(), config.dt(),
                cfl_limit, config.cfl);

    Checkpoints checkpoints(o.checkpoints, dir, "acoustic", params, {"/end_time_s"});
    if (!checkpoints.restart())  // a restart keeps what the run wrote before its checkpoint
      clear_outputs(dir, {"frames", "maps", "acoustic.pvd", "centerline.csv", "energy.csv", "summary.json",
                          "last_good.vtp", "config.toml", "checkpoint.cbor"});
    write_run_config(app, "acoustic", dir);
    fs::create_directories(dir / "frames");
    fs::create_directories(dir / "maps");
    const Lattice lattice = make_lattice(solver, config, o.size);
    Record record;
    for (const auto& s : start.sources) solver.add_pulse(s);  // the initial condition
    Progress progress(start.t_end, "s");
    try {
      run(solver, o, start, lattice, record, progress, checkpoints);
    } catch (const RunStopped& stop) {
      progress.finish(solver.time(), solver.steps());
      mps::write_csv(dir / "energy.csv", {"time_s", "energy_fraction"}, {record.energy_t, record.energy_fraction});
      return report_stop(dir, stop, params, solver.steps(), solver.time(), checkpoints);
    } catch (const mps::SimulationError& e) {
      progress.finish(solver.time(), solver.steps());
      return report_failure(e, dir, solver, params, record, setup_s, cfl_limit);
    }
    progress.finish(solver.time(), solver.steps());
    return report(dir, solver, params, record, setup_s, cfl_limit);
  } catch (const std::exception& e) {
    std::cerr << "error: " << error_message(e) << "\n";
    return 1;
  }
}
