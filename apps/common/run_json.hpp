#pragma once
// What every app writes beside its outputs: the timing block of summary.json, and the record of a run the
// stability guard stopped.
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <set>
#include <stdexcept>
#include <string>
#include <type_traits>
#include <variant>
#include <vector>
#include <nlohmann/json.hpp>

#include "mps/io/io.hpp"
#include "mps/io/probes.hpp"
#include "mps/step/step.hpp"
#include "mps/version.hpp"
#include "solve_log.hpp"
#include "source_commit.hpp"

// What an app writes as the run goes, after every step: frames at end_time / count intervals, the first at t = 0
// (dir/frames/<stem>_NNNN.vtp, listed in dir/<stem>.pvd; count 0: none), and the user's probes (--probes), sampled
// from the same particles at their own interval into dir/probes.csv, which is written at every frame and when the
// series ends (the run's end, a guard stop or a signal alike).
class FrameSeries {
 public:
  FrameSeries(const std::filesystem::path& dir, const std::string& stem, int count, double end_time)
      : dir_(dir), stem_(stem), count_(count), interval_(count > 0 ? end_time / count : 2 * end_time),
        series_(dir / (stem + ".pvd")) {}
  FrameSeries(const FrameSeries&) = delete;
  FrameSeries& operator=(const FrameSeries&) = delete;
  ~FrameSeries() {
    try {
      write_probes();
    } catch (const std::exception& e) {
      std::fprintf(stderr, "error: %s\n", e.what());
    }
  }
  // Samples `probes` from now on with the frames' particles.
  template <int D>
  void set_probes(mps::BasicProbeSeries<D> probes) {
    probes_ = std::move(probes);
  }
  // Writes the next frame if its time has come, and samples the probes if theirs has.
  template <int D>
  void write_if_due(const mps::BasicSimulation<D>& sim) {
    write_if_due(sim.time(), sim.particles());
  }
  // The same for particles held apart from a simulation (a run on ranks gathers them).
  template <int D>
  void write_if_due(double time, const mps::BasicParticles<D>& particles) {
    auto* probes = std::get_if<mps::BasicProbeSeries<D>>(&probes_);
    if (probes != nullptr) probes->sample(time, particles);
    if (count_ <= 0 || time < next_ * interval_ - 1e-12) return;
    char name[64];
    std::snprintf(name, sizeof name, "frames/%s_%04d.vtp", stem_.c_str(), next_++);
    mps::write_vtp(dir_ / name, particles, time);
    series_.add(time, dir_ / name);
    write_probes();
  }
  [[nodiscard]] const std::filesystem::path& path() const { return series_.path(); }
  // The probes' description for summary.json (null without probes).
  [[nodiscard]] nlohmann::json probes() const {
    return std::visit(
        [](const auto& p) -> nlohmann::json {
          if constexpr (std::is_same_v<std::decay_t<decltype(p)>, std::monostate>) return nullptr;
          else return p.describe();
        },
        probes_);
  }
  // For a checkpoint: the frames written so far and the probes' samples.
  [[nodiscard]] nlohmann::json save_state() const {
    nlohmann::json state = {{"next", next_}, {"series", series_.save_state()}};
    std::visit(
        [&](const auto& p) {
          if constexpr (!std::is_same_v<std::decay_t<decltype(p)>, std::monostate>) state["probes"] = p.save_state();
        },
        probes_);
    return state;
  }
  void restore_state(const nlohmann::json& state) {
    next_ = state.at("next").get<int>();
    series_.restore_state(state.at("series"));
    std::visit(
        [&](auto& p) {
          if constexpr (!std::is_same_v<std::decay_t<decltype(p)>, std::monostate>) {
            if (!state.contains("probes"))
              throw std::runtime_error("checkpoint: the run had no probes; restart it without --probes");
            p.restore_state(state.at("probes"));
          }
        },
        probes_);
  }

 private:
  void write_probes() const {
    std::visit(
        [&](const auto& p) {
          if constexpr (!std::is_same_v<std::decay_t<decltype(p)>, std::monostate>)
            if (!p.rows().empty()) p.write_csv(dir_ / "probes.csv");
        },
        probes_);
  }

  std::filesystem::path dir_;
  std::string stem_;
  int count_, next_ = 0;
  double interval_;
  mps::PvdSeries series_;
  std::variant<std::monostate, mps::ProbeSeries, mps::ProbeSeries3> probes_;
};

// Who made a summary: the app, the library's version and source commit, the command line and the config file beside
// it. Set once at the start of main.
inline nlohmann::json& run_record() {
  static nlohmann::json record = nlohmann::json::object();
  return record;
}
inline void record_run(const std::string& app, int argc, char** argv) {
  run_record() = {{"app", app},
                  {"version", mps::version},
                  {"commit", source_commit},
                  {"command_line", std::vector<std::string>(argv, argv + argc)},
                  {"config", "config.toml"}};
}

// Every app's summary.json. One status vocabulary: "passed" (its check passed, exit 0), "check failed" (exit 2),
// "completed" (a run with no check, exit 0), "failed" (stopped by the guard or an error, exit 1), "stopped" (by
// SIGTERM or SIGINT after writing its checkpoint, exit 128 + the signal); `pass` is true
// exactly when the exit status is 0.
inline void write_summary(const std::filesystem::path& dir, nlohmann::json summary) {
  static const std::set<std::string> vocabulary = {"passed", "check failed", "completed", "failed", "stopped"};
  const std::string status = summary.at("status").get<std::string>();
  if (vocabulary.count(status) == 0) throw std::logic_error("summary status '" + status + "' is not in the vocabulary");
  summary["pass"] = status == "passed" || status == "completed";
  summary["run"] = run_record();
  mps::write_json(dir / "summary.json", summary);
}

inline nlohmann::json timings_json(const mps::PhaseTimes& t, int steps, std::size_t particles) {
  return {{"neighbors_s", t.neighbors}, {"predict_s", t.predict}, {"assemble_s", t.assemble},
          {"solver_setup_s", t.solver_setup}, {"solve_s", t.solve}, {"correct_s", t.correct}, {"total_s", t.total()},
          {"particle_steps_per_s", t.total() > 0 ? static_cast<double>(particles) * steps / t.total() : 0.0}};
}

// The simulation holds the last good state (last_good: its particles, or on ranks their gathering): keep it beside
// the frames, say what went wrong in summary.json and on stderr. Returns the app's exit status.
template <int D>
int report_guard_stop(const std::filesystem::path& dir, const mps::SimulationError& error, const nlohmann::json& params,
                      const mps::BasicSimulation<D>& sim, const mps::BasicParticles<D>* last_good = nullptr) {
  std::cerr << "error: " << error.what() << "\n";  // first: a failed write below must not hide the reason
  try {
    mps::write_vtp(dir / "last_good.vtp", last_good ? *last_good : sim.particles(), sim.time());
    write_solves(dir, sim);
    write_summary(dir, {{"status", "failed"}, {"error", error.what()}, {"parameters", params}, {"time_s", sim.time()},
                        {"steps", sim.last_step().step}});
    std::cerr << "last good state written to " << (dir / "last_good.vtp").string() << "\n";
  } catch (const std::exception& e) {
    std::cerr << "error: the last good state could not be saved: " << e.what() << "\n";
  }
  return 1;
}

// A run on ranks stopped by an error of one rank alone: the others cannot join a gathering of the last good state,
// so this rank records the reason in summary.json; the frames written so far are complete.
template <int D>
void record_failure_alone(const std::filesystem::path& dir, const std::string& error,
                                 const nlohmann::json& params, const mps::BasicSimulation<D>& sim) {
  write_summary(dir, {{"status", "failed"}, {"error", error}, {"parameters", params}, {"time_s", sim.time()},
                      {"steps", sim.last_step().step}});
}
