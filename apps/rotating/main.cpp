// Rotating boundaries (seed 000): Taylor-Couette flow against its exact profile, and the screw channel in the
// moving- and fixed-boundary models. Writes frames (.vtp/.pvd, with the relative velocity), the curves
// (couette.csv, or line1.csv, arc2.csv, barrel_pressure.csv) at each --times entry, and summary.json to --out;
// plot_rotating.py draws them. --model both runs the two channel models into out/moving and out/fixed and
// compares them.
#include <CLI/CLI.hpp>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <numbers>

#include "checkpoints.hpp"
#include "checks.hpp"
#include "console.hpp"
#include "help.hpp"
#include "mps/io/io.hpp"
#include "openmp_wait.hpp"
#include "ranks.hpp"
#include "rotor.hpp"
#include "run_config.hpp"
#include "run_json.hpp"
#include "solve_log.hpp"
#include "solver_cli.hpp"

namespace fs = std::filesystem;
using rotating::Curve;
using Line = rotating::LineSampler::Line;

namespace {

template <int D>
nlohmann::json params_json(const rotating::Params& p, const mps::BasicSimulation<D>& sim,
                           const std::vector<double>& times, double average) {
  const auto& c = sim.config();
  const bool couette = p.scene == rotating::Scene::couette;
  const mps::BasicParticles<D>& s = sim.particles();
  nlohmann::json physics = {"viscosity (explicit)", "wall + 4 dummy layers", "rigid wall motion", "closed-domain PPE gauge",
                            "no gravity"};
  if (p.shifting > 0) physics.push_back("particle shifting");
  nlohmann::json params = {{"scene", rotating::to_string(p.scene)}, {"dimensions", D}, {"model", couette ? "moving" : rotating::to_string(p.model)},
          {"inner_radius_m", p.R1}, {"outer_radius_m", p.R2}, {"span_rad", couette ? 2 * std::numbers::pi : p.span},
          {"omega_rad_per_s", p.omega}, {"sense", couette ? "inner cylinder counter-clockwise" : "channel clockwise"},
          {"rho_kg_per_m3", p.rho}, {"nu_m2_per_s", p.nu}, {"re", p.reynolds()}, {"velocity_scale_m_per_s", p.U()},
          {"across", p.across}, {"dx_m", p.l0()}, {"fluid_particles", s.count(mps::Kind::fluid)},
          {"boundary_particles", s.count(mps::Kind::wall) + s.count(mps::Kind::dummy)},
          {"gamma", p.gamma}, {"gradient", p.gradient == mps::GradientVariant::min_reference ? "min-reference"
                                                                                              : "corrected-min-reference"},
          {"reference_number_density", p.initial_reference ? "initial packing" : "lattice n0"}, {"cfl", c.cfl}, {"viscous_number", c.viscous_number}, {"dt_factor", p.dt_factor}, {"shifting", p.shifting},
          {"times_s", times}, {"average_fraction", average},
          {"simulation_config", mps::config_json(c)}, {"solver", sim.solver().spec()},
          {"initial_guess", c.warm_start ? "previous pressure" : "zero"},
          {"walls", p.mirror ? "mirror velocities on the circles" : "plain (wall velocity)"},
          {"physics_on", physics}};
  if constexpr (D == 3) {
    params["period_z_layers"] = rotating::period_layers(p);
    params["period_z_m"] = rotating::period_layers(p) * p.l0();
  }
  return params;
}

struct Curves {
  double time = 0;
  Curve couette, line1, arc2, barrel;
};

nlohmann::json curve_json(const Curve& c) {
  return {{"axis", mps::pack_array(c.axis)}, {"value", mps::pack_array(c.value)}, {"exact", mps::pack_array(c.exact)},
          {"count", mps::pack_array(c.count)}};
}

Curve curve_from(const nlohmann::json& state) {
  Curve c;
  mps::unpack_array(state, "axis", c.axis);
  mps::unpack_array(state, "value", c.value);
  mps::unpack_array(state, "exact", c.exact);
  mps::unpack_array(state, "count", c.count);
  return c;
}

struct RunResult {
  int status = 0;  // 0 ran to the end; 1 stopped by the guard
  std::vector<Curves> at;
  nlohmann::json summary;
};

// After a run: each curve as CSV (one column per sample time, beside the axis), the checks of the last sample and
// the summary ("completed" until main has made the checks, which need every model's run); returns the summary.
template <int D>
nlohmann::json write_results(const rotating::Params& p, const mps::BasicSimulation<D>& sim, const fs::path& dir,
                             const std::vector<Curves>& at, const nlohmann::json& params, long escaped_max,
                             std::size_t fluid0) {
  const bool couette = p.scene == rotating::Scene::couette;
  auto write = [&](const std::string& file, const std::string& axis, const std::string& name,
                   Curve Curves::*member) {
    std::vector<std::string> header{axis};
    std::vector<std::vector<double>> cols{(at.front().*member).axis};
    for (const Curves& c : at) {
      char h[64];
      std::snprintf(h, sizeof h, "%s_t%.4g", name.c_str(), c.time);
      header.push_back(h);
      cols.push_back((c.*member).value);
      if (couette) {
        std::snprintf(h, sizeof h, "exact_t%.4g", c.time);
        header.push_back(h);
        cols.push_back((c.*member).exact);
      }
    }
    mps::write_csv(dir / file, header, cols);
  };
  if (couette) {
    write("couette.csv", "r", "u_theta", &Curves::couette);
  } else {
    write("line1.csv", "r", "u_theta_rel_over_wR", &Curves::line1);
    write("arc2.csv", "phi_rad", "u_r_rel_over_wR", &Curves::arc2);
    write("barrel_pressure.csv", "phi_rad", "p_minus_mean", &Curves::barrel);
  }
  const int steps = sim.last_step().step;
  const Curves& last = at.back();
  nlohmann::json checks;
  const long escaped = escaped_max;
  const bool count_kept = sim.particles().count(mps::Kind::fluid) == fluid0;
  if (couette) {
    checks = {{"max_abs_error_over_omega_R1", rotating::couette_max_error(last.couette) / p.U()}};
    if constexpr (D == 3) checks["max_axial_speed_over_omega_R1"] = rotating::max_axial_speed(sim) / p.U();
  } else {
    const double prange = rotating::range(last.barrel, 0.4);
    // Over |phi| <= 0.4 rad unless named full span; arc 2's velocities are in omega R2.
    checks = {{"arc2_odd_defect_over_omega_R2", rotating::odd_defect(last.arc2, 0.4)},
              {"arc2_odd_defect_full_span_over_omega_R2", rotating::odd_defect(last.arc2, 0.5 * p.span)},
              {"barrel_pressure_odd_defect_over_range", prange > 0 ? rotating::odd_defect(last.barrel, 0.4) / prange : 0.0},
              {"barrel_pressure_range_pa", prange}};
  }
  checks["max_escaped_fluid_particles"] = escaped;
  checks["fluid_count_kept"] = count_kept;
  const nlohmann::json timings = timings_json(sim.times(), steps, sim.particles().size());
  const nlohmann::json summary = {{"status", "completed"}, {"parameters", params}, {"particles", sim.particles().size()}, {"steps", steps},
                 {"time_s", sim.time()}, {"dt_limit", sim.last_step().dt_limit}, {"checks", checks},
                 {"particle_steps_per_s", timings["particle_steps_per_s"]}, {"timings", timings}};
  write_solves(dir, sim);
  write_summary(dir, summary);
  return summary;
}

// One simulation to the last of `times`, sampling each curve over the last `average` fraction of each time.
template <int D>
RunResult run(const rotating::Params& p, const std::vector<double>& times, double average, int frames,
              const fs::path& dir, const std::set<int>& export_ppe, const CheckpointOptions& checkpoint_options) {
  const bool couette = p.scene == rotating::Scene::couette;
  mps::BasicSimulation<D> sim = [&] {
    if constexpr (D == 2) return rotating::make_simulation(p);
    else return rotating::make_simulation3(p);
  }();
  sim.template add<BasicSolveLog<D>>(dir, export_ppe,
                                     couette ? (D == 3 ? "rotating, Taylor-Couette in 3-D" : "rotating, Taylor-Couette")
                                             : "rotating, screw channel");
  const nlohmann::json params = params_json(p, sim, times, average);
  std::cout << parameter_table(
      "rotating, " + rotating::to_string(p.scene) + (couette ? "" : " (" + params["model"].get<std::string>() + ")") +
          ": " + std::to_string(sim.particles().size()) + " particles (" +
          std::to_string(sim.particles().count(mps::Kind::fluid)) + " fluid)",
      params,
      {{"scene", {"dimensions", "inner_radius_m", "outer_radius_m", "span_rad", "omega_rad_per_s", "nu_m2_per_s", "rho_kg_per_m3",
                  "re", "walls"}},
       {"numerics", {"across", "dx_m", "gamma", "gradient", "cfl", "viscous_number", "dt_factor", "shifting",
                     "reference_number_density"}},
       {"solver", {"solver", "initial_guess"}},
       {"run", {"times_s", "average_fraction"}}});
  Checkpoints checkpoints(checkpoint_options, dir, "rotating", params, {"/times_s"});
  fs::create_directories(dir / "frames");
  mps::PvdSeries series(dir / (rotating::to_string(p.scene) + ".pvd"));
  const double t_end = times.back();
  std::vector<double> ur, vr;
  auto write_frame = [&](int k) {
    char name[40];
    std::snprintf(name, sizeof name, "frames/frame_%04d.vtp", k);
    if constexpr (D == 2) {
      rotating::relative_velocity(p, sim.particles(), ur, vr);
      mps::write_vtp(dir / name, sim.particles(), sim.time(), {.vectors = {{"relative_velocity", {ur, vr}}}});
    } else {
      mps::write_vtp(dir / name, sim.particles(), sim.time());  // couette: the lab frame is the frame of reference
    }
    series.add(sim.time(), dir / name);
  };
  const std::size_t fluid0 = sim.particles().count(mps::Kind::fluid);
  rotating::LineSampler s_couette(p, Line::couette), s_line1(p, Line::line1), s_arc2(p, Line::arc2),
      s_barrel(p, Line::barrel);
  std::vector<rotating::LineSampler*> samplers{&s_couette};
  if (!couette) samplers = {&s_line1, &s_arc2, &s_barrel};
  RunResult out;
  long escaped_max = 0;
  int frame = 0;
  const auto start = std::chrono::steady_clock::now();
  // Everything the loop below carries from step to step, for a checkpoint.
  auto save = [&]() -> nlohmann::json {
    nlohmann::json saved = {{"escaped_max", escaped_max}, {"frame", frame}, {"frames", series.save_state()},
                            {"samplers", nlohmann::json::array()}, {"at", nlohmann::json::array()}};
    for (const auto* s : samplers) saved["samplers"].push_back(s->save_state());
    for (const Curves& c : out.at)
      saved["at"].push_back({{"time", c.time}, {"couette", curve_json(c.couette)}, {"line1", curve_json(c.line1)},
                             {"arc2", curve_json(c.arc2)}, {"barrel", curve_json(c.barrel)}});
    return saved;
  };
  if (const nlohmann::json* restart = checkpoints.restart()) {
    sim.restore(restart->at("simulation"));
    const nlohmann::json& saved = checkpoints.scene();
    escaped_max = saved.at("escaped_max").get<long>();
    frame = saved.at("frame").get<int>();
    series.restore_state(saved.at("frames"));
    for (std::size_t k = 0; k < samplers.size(); ++k) samplers[k]->restore_state(saved.at("samplers").at(k));
    for (const auto& c : saved.at("at"))
      out.at.push_back({c.at("time").get<double>(), curve_from(c.at("couette")), curve_from(c.at("line1")),
                        curve_from(c.at("arc2")), curve_from(c.at("barrel"))});
    std::printf("restarted from %s at step %d, t = %.4g s\n", checkpoint_options.restart.c_str(),
                sim.last_step().step, sim.time());
  } else if (frames > 0) {
    write_frame(frame++);
  }
  Progress progress(t_end, "s");
  try {
    for (std::size_t k = out.at.size(); k < times.size(); ++k) {
      const double t_sample = times[k];
      while (sim.time() < t_sample - 1e-9 * t_end) {
        sim.step();
        progress.update(sim.time(), sim.last_step().step);
        escaped_max = std::max(escaped_max, rotating::escaped_particles(p, sim));
        if (frames > 0 && sim.time() >= t_end * frame / frames - 1e-9 * t_end) write_frame(frame++);
        if (sim.time() > t_sample * (1.0 - average))
          for (auto* s : samplers) s->add(sim);
        checkpoints.after_step(sim, save, progress);
      }
      if (s_couette.samples() + s_line1.samples() == 0)
        for (auto* s : samplers) s->add(sim);
      Curves c{sim.time(), s_couette.result(), s_line1.result(), s_arc2.result(), s_barrel.result()};
      for (auto* s : samplers) s->clear();
      const double wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
      progress.clear();
      if (couette)
        std::printf("t = %6.3f s  step %6d  dt %.2e s (%s)  max |u_theta - exact| = %.3f %% of omega R1  [%.0f s]\n",
                    sim.time(), sim.last_step().step, sim.last_step().dt, sim.last_step().dt_limit.c_str(),
                    100 * rotating::couette_max_error(c.couette) / p.U(), wall);
      else
        std::printf("t = %6.3f s  step %6d  dt %.2e s (%s)  line 1 max %.3f  arc 2 odd defect %.3f  barrel p range "
                    "%.3g  escaped %ld  [%.0f s]\n",
                    sim.time(), sim.last_step().step, sim.last_step().dt, sim.last_step().dt_limit.c_str(),
                    c.line1.value.empty() ? 0.0 : *std::max_element(c.line1.value.begin(), c.line1.value.end()),
                    rotating::odd_defect(c.arc2, 0.4), rotating::range(c.barrel, 0.4), escaped_max, wall);
      out.at.push_back(std::move(c));
    }
  } catch (const RunStopped& stop) {
    progress.finish(sim.time(), sim.last_step().step);
    out.status = report_stop(dir, stop, params, sim, checkpoints);
    return out;
  } catch (const mps::SimulationError& e) {
    progress.finish(sim.time(), sim.last_step().step);
    checkpoints.write(sim, save);  // the last good state, to restart from
    out.status = report_guard_stop(dir, e, params, sim);
    return out;
  }
  progress.finish(sim.time(), sim.last_step().step);
  out.summary = write_results(p, sim, dir, out.at, params, escaped_max, fluid0);
  return out;
}

std::vector<double> parse_times(const std::string& list) {
  std::vector<double> t;
  std::size_t at = 0;
  while (at <= list.size()) {
    const std::size_t comma = std::min(list.find(',', at), list.size());
    const std::string item = list.substr(at, comma - at);
    std::size_t used = 0;
    double v = 0;
    try {
      v = std::stod(item, &used);
    } catch (const std::exception&) {
      used = 0;
    }
    if (used != item.size() || !(v > 0) || !(v <= 1e6) || (!t.empty() && v <= t.back()))
      throw std::invalid_argument("--times must be a comma-separated list of increasing times in (0, 1e6] s, got '" +
                                  list + "'");
    t.push_back(v);
    at = comma + 1;
  }
  return t;
}


// The command line.
struct Options {
  rotating::Params p;
  std::string scene = "channel", model = "moving", times_list, gradient = "corrected-min-reference", walls = "mirror",
              out = "runs/rotating";
  double average = 0.1, tolerance = 0.02, agreement = 0.03, symmetry = 0.1;
  int frames = 10;
  std::vector<int> export_ppe;
  CheckpointOptions checkpoints;
};

void add_options(CLI::App& app, Options& o) {
  add_general_options(app);
  app.add_option("--dim", o.p.dim, "2 | 3 (3: couette only, the annulus extruded along z, periodic in z)")
      ->capture_default_str()->check(CLI::IsMember({2, 3}))->group("Scene");
  app.add_option("--scene", o.scene, "couette | channel")->capture_default_str()->group("Scene");
  app.add_option("--model", o.model, "channel: moving | fixed | both (both runs each into OUT/moving, OUT/fixed and "
                 "compares them)")->capture_default_str()->group("Scene");
  app.add_option("--omega", o.p.omega, "angular speed (couette: inner cylinder ccw; channel: channel cw) [rad/s]")
      ->capture_default_str()->check(positive_up_to(1e4))->group("Scene");
  app.add_option("--nu", o.p.nu, "kinematic viscosity [m^2/s]")->capture_default_str()->check(positive_up_to(1e4))
      ->group("Scene");
  app.add_option("--span", o.p.span, "channel opening angle [rad]")->capture_default_str()->check(positive_up_to(6.3))
      ->group("Scene");
  app.add_option("--walls", o.walls, "circular walls: mirror (mirror velocities across the circle) | plain (wall "
                 "and dummy particles at the wall velocity, seed 000's static particles)")->capture_default_str()
      ->group("Scene");
  app.add_option("--across", o.p.across, "particles across the gap R2 - R1 (0: the scene's default, channel 49 = seed "
                 "000's 3,626 fluid particles, couette 20, in 3-D 10)")->capture_default_str()->check(whole_in(0, 100000))
      ->group("Numerics");
  app.add_option("--gamma", o.p.gamma, "mixed source weight in [0,1] (1: number density only)")
      ->capture_default_str()->check(number_in(0.0, 1.0))->group("Numerics");
  app.add_option("--gradient", o.gradient, "pressure gradient: min-reference | corrected-min-reference (with the "
                 "corrective matrix)")->capture_default_str()->group("Numerics");
  app.add_flag_callback("--lattice-reference", [&o] { o.p.initial_reference = false; },
                        "density source against the square lattice's n0 instead of the initial packing (each wall "
                        "particle's own, the fluid's mean)")->group("Numerics");
  app.add_option("--dt-factor", o.p.dt_factor, "multiplies the CFL and viscous time-step limits (> 1 probes stability)")
      ->capture_default_str()->check(positive_up_to(100))->group("Numerics");
  add_shifting_option(app, o.p.shifting);
  add_solver_options(app, o.p.solver);
  add_cold_start_flag(app, o.p.warm_start);
  app.add_option("--times", o.times_list, "increasing sample times (default: channel 0.05,0.5; couette 0.1,1) [s]")
      ->capture_default_str()->group("Run");
  app.add_option("--average", o.average, "each curve is averaged over the last AVERAGE fraction of its time")
      ->capture_default_str()->check(number_in(0.0, 1.0))->group("Run");
  app.add_option("--tolerance", o.tolerance, "couette: pass if max |u - exact| <= TOLERANCE omega R1")
      ->capture_default_str()->check(positive_up_to(10))->group("Run");
  app.add_option("--agreement", o.agreement, "channel: pass if arc 2 is odd (and, with --model both, the models agree "
                 "on line 1 and arc 2) within AGREEMENT omega R2")->capture_default_str()->check(positive_up_to(10))
      ->group("Run");
  app.add_option("--symmetry", o.symmetry, "channel: pass if the barrel pressure is odd in phi within SYMMETRY of its "
                 "range over |phi| <= 0.4")->capture_default_str()->check(positive_up_to(10))->group("Run");
  app.add_option("--out", o.out, "output directory")->check(output_directory())->capture_default_str()->group("Output");
  app.add_option("--frames", o.frames, "number of .vtp frames to write")->capture_default_str()
      ->check(whole_in(0, 100000))->group("Output");
  add_export_ppe_option(app, o.export_ppe);
  add_checkpoint_options(app, o.checkpoints);
}

// The checks over every model's run: couette against the exact profile; the channel's symmetry and, with both
// models, their agreement (compare.json). Returns whether all pass.
bool judge(const std::vector<std::pair<std::string, RunResult>>& runs, const Options& o,
           const std::vector<double>& times, bool both, const fs::path& dir) {
  const bool couette = o.p.scene == rotating::Scene::couette;
  const nlohmann::json& checks = runs.front().second.summary["checks"];
  bool pass = checks["max_escaped_fluid_particles"].get<long>() == 0 && checks["fluid_count_kept"].get<bool>();
  std::printf("\n");
  if (couette) {
    const double e = checks["max_abs_error_over_omega_R1"];
    // 3-D: the fluid's velocity along the axis, which the exact flow does not have, within the same limit
    const double w = checks.value("max_axial_speed_over_omega_R1", 0.0);
    pass = pass && e <= o.tolerance && w <= o.tolerance;
    std::printf("check: couette%s at t = %.3g s, %g across: max |u_theta - exact| = %.3f %% of omega R1%s (limit %.1f %%), "
                "fluid escaped %ld: %s\n", o.p.dim == 3 ? " in 3-D" : "", times.back(), o.p.across, 100 * e,
                o.p.dim == 3 ? (", max |u_z| = " + std::to_string(100 * w) + " %").c_str() : "", 100 * o.tolerance,
                checks["max_escaped_fluid_particles"].get<long>(), pass ? "PASS" : "FAIL");
  } else {
    nlohmann::json compare;
    for (auto& [m, r] : runs) {
      const nlohmann::json& c = r.summary["checks"];
      pass = pass && c["arc2_odd_defect_over_omega_R2"].get<double>() <= o.agreement &&
             c["barrel_pressure_odd_defect_over_range"].get<double>() <= o.symmetry &&
             c["max_escaped_fluid_particles"].get<long>() == 0;
      std::printf("check: channel (%s) at t = %.3g s: arc 2 odd defect over |phi| <= 0.4 %.4f (limit %.3f), barrel pressure odd defect "
                  "%.3f of its range over |phi| <= 0.4 (limit %.2f), fluid escaped %ld, count kept %s\n",
                  m.c_str(), times.back(), c["arc2_odd_defect_over_omega_R2"].get<double>(), o.agreement,
                  c["barrel_pressure_odd_defect_over_range"].get<double>(), o.symmetry, c["max_escaped_fluid_particles"].get<long>(),
                  c["fluid_count_kept"].get<bool>() ? "yes" : "NO");
    }
    if (both) {
      for (std::size_t k = 0; k < times.size(); ++k) {
        const Curves &a = runs[0].second.at[k], &b = runs[1].second.at[k];
        const double d1 = rotating::max_difference(a.line1, b.line1), d2 = rotating::max_difference(a.arc2, b.arc2);
        compare.push_back({{"time_s", a.time}, {"line1_max_diff", d1}, {"arc2_max_diff", d2}});
        if (k + 1 == times.size()) pass = pass && d1 <= o.agreement && d2 <= o.agreement;
        std::printf("check: moving vs fixed at t = %.3g s: line 1 max diff %.4f, arc 2 max diff %.4f (of omega R2; "
                    "limit %.3f at the last time)\n", a.time, d1, d2, o.agreement);
      }
      mps::write_json(dir / "compare.json", {{"agreement_limit", o.agreement}, {"comparisons", compare}});
    }
  }
  return pass;
}

}  // namespace

int main(int argc, char** argv) {
  prefer_passive_openmp_wait(argv);
  require_one_process(AppRanks(&argc, &argv), "rotating");
  record_run("rotating", argc, argv);
  std::setvbuf(stdout, nullptr, _IOLBF, 0);  // progress lines reach a log file as they are printed
  CLI::App app{"SparseMPS rotating boundaries (seed 000): Taylor-Couette flow against the exact profile, and the "
               "screw channel in the moving- and fixed-boundary models"};
  Options o;
  o.p.across = 0;
  add_options(app, o);
  if (const auto status = parse_options(app, argc, argv)) return *status;

  try {
    rotating::Params& p = o.p;
    p.scene = rotating::parse_scene(o.scene);
    const bool both = o.model == "both";
    if (!both) p.model = rotating::parse_model(o.model);
    if (both && p.scene == rotating::Scene::couette) throw std::invalid_argument("--model both applies to the channel");
    if (o.gradient == "min-reference") p.gradient = mps::GradientVariant::min_reference;
    else if (o.gradient == "corrected-min-reference") p.gradient = mps::GradientVariant::corrected_min_reference;
    else throw std::invalid_argument("--gradient must be min-reference or corrected-min-reference, got '" + o.gradient + "'");
    if (o.walls != "mirror" && o.walls != "plain") throw std::invalid_argument("--walls must be mirror or plain, got '" + o.walls + "'");
    p.mirror = o.walls == "mirror";
    const bool couette = p.scene == rotating::Scene::couette;
    if (p.across == 0) p.across = couette ? (p.dim == 3 ? 10 : 20) : 49;  // 3-D: ten times the layers, two minutes
    if (o.times_list.empty()) o.times_list = couette ? "0.1,1" : "0.05,0.5";
    const std::vector<double> times = parse_times(o.times_list);
    p.validate();
    const double l0 = p.l0(), outer = p.R2 + 6.0 * l0;
    check_run_size(std::numbers::pi * outer * outer / (l0 * l0) * (p.dim == 3 ? rotating::period_layers(p) : 1),
                   times.back() / (p.dt_factor * std::min(0.2 * l0 / (p.omega * p.R2), 0.2 * l0 * l0 / p.nu)),
                   "use fewer --across", "shorten --times or raise --dt-factor");
    const fs::path dir(o.out);
    const bool checkpointing = o.checkpoints.every > 0 || o.checkpoints.wall > 0.0 || !o.checkpoints.restart.empty();
    if (both && checkpointing)
      throw std::invalid_argument("--model both runs two simulations; checkpoint each model's run on its own "
                                  "(--model moving, --model fixed)");
    if (o.checkpoints.restart.empty())  // a restart keeps what the run wrote before its checkpoint
      clear_outputs(dir, {"frames", "couette.pvd", "channel.pvd", "couette.csv", "line1.csv", "arc2.csv",
                          "barrel_pressure.csv", "summary.json", "last_good.vtp", "compare.json", "moving", "fixed",
                          "config.toml", "solves.csv", "ppe", "checkpoint.cbor"});
    write_run_config(app, "rotating", dir);
    std::vector<std::pair<std::string, RunResult>> runs;
    for (const std::string& m : both ? std::vector<std::string>{"moving", "fixed"} : std::vector<std::string>{o.model}) {
      if (!couette) p.model = rotating::parse_model(m);
      const std::set<int> export_steps(o.export_ppe.begin(), o.export_ppe.end());
      runs.emplace_back(m, p.dim == 3 ? run<3>(p, times, o.average, o.frames, dir, export_steps, o.checkpoints)
                                      : run<2>(p, times, o.average, o.frames, both ? dir / m : dir, export_steps,
                                               o.checkpoints));
      if (runs.back().second.status != 0) return runs.back().second.status;
    }
    const bool pass = judge(runs, o, times, both, dir);
    for (auto& [m, r] : runs) {
      r.summary["status"] = pass ? "passed" : "check failed";
      write_summary(both ? dir / m : dir, r.summary);
    }
    std::printf("result: %s; outputs in %s\n", pass ? "PASS" : "FAIL", dir.string().c_str());
    return pass ? 0 : 2;
  } catch (const std::exception& e) {
    std::cerr << "error: " << error_message(e) << "\n";
    return 1;
  }
}
