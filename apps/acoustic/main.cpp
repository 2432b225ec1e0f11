// Acoustic wave propagation on particles (MPS-WP, seed 001): Gaussian pulses in a 100 m x 100 m box with the
// paper's cases, each compared with the exact solution. Writes pressure maps (PNG), centerline.csv, VTK
// frames, energy.csv and summary.json to --out, through the loop a scene file's run shares (acoustic_run.hpp).
#include <CLI/CLI.hpp>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <map>
#include <optional>
#include <sstream>
#include <string>
#include <vector>

#include "acoustic_run.hpp"
#include "checkpoints.hpp"
#include "checks.hpp"
#include "console.hpp"
#include "help.hpp"
#include "mps/acoustics/acoustic.hpp"
#include "openmp_wait.hpp"
#include "ranks.hpp"
#include "run_config.hpp"
#include "run_json.hpp"

namespace fs = std::filesystem;
using acoustic::Clock;

namespace {

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
struct Start : acoustic::AcousticRun {
  Case scene;
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
  Start start;
  start.scene = scene;
  start.config = config;
  start.sources = sources;
  start.repeated = repeated;
  start.frequency = o.frequency;
  start.t_end = t_end;
  start.samples = samples;
  start.maps = maps;
  start.frames = o.frames;
  start.tolerance = o.tolerance;
  start.dir = dir;
  return start;
}

// The run's parameters, for the table on the console and summary.json.
nlohmann::json params_json(const Options& o, const Start& start) {
  const mps::AcousticConfig& config = start.config;
  const bool hard = start.hard(), repeated = start.repeated;
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
    const double setup_s = acoustic::seconds_since(setup_start);
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
    return acoustic::run_acoustic(solver, start, params, checkpoints, setup_s, cfl_limit);
  } catch (const std::exception& e) {
    std::cerr << "error: " << error_message(e) << "\n";
    return 1;
  }
}
