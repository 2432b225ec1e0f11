#pragma once
// Checkpoints for every app (docs/restart.md): --checkpoint-every STEPS and --checkpoint-wall SECONDS write
// OUT/checkpoint.cbor as the run goes, SIGTERM and SIGINT write it and stop the run, a guard stop writes its last good
// state there, and --restart FILE continues a run from one. A checkpoint holds the simulation's state
// (Simulation::checkpoint), the scene's own (its samplers, tables, frame count) and the run's parameters, which a
// restart must repeat.
#include <CLI/CLI.hpp>
#include <chrono>
#include <csignal>
#include <cstdio>
#include <filesystem>
#include <functional>
#include <optional>
#include <set>
#include <stdexcept>
#include <string>
#include <vector>
#include <nlohmann/json.hpp>

#include <mpi.h>

#include "checks.hpp"
#include "console.hpp"
#include "mps/core/state.hpp"
#include "mps/io/io.hpp"
#include "mps/step/step.hpp"
#include "run_json.hpp"

struct CheckpointOptions {
  int every = 0;        // steps between checkpoints (0: none)
  double wall = 0.0;    // wall seconds between checkpoints (0: none)
  std::string restart;  // the checkpoint to continue from
};

inline void add_checkpoint_options(CLI::App& app, CheckpointOptions& o) {
  app.add_option("--checkpoint-every", o.every,
                 "write OUT/checkpoint.cbor every this many steps, at the first step from there that continues "
                 "bitwise (at most reorder_every steps later; 0: only when stopped)")
      ->capture_default_str()->check(whole_in(0, 1e9))->group("Run");
  app.add_option("--checkpoint-wall", o.wall, "... and every this many seconds of wall time (0: not by time) [s]")
      ->capture_default_str()->check(number_in(0.0, 1e9))->group("Run");
  app.add_option("--restart", o.restart,
                 "continue the run a checkpoint holds; give the run's own options again (--end-time, --out and the "
                 "checkpoint options may change)")
      ->group("Run");
}

// A run stopped by SIGTERM or SIGINT after its checkpoint was written: the app reports it and exits 128 + signal.
struct RunStopped {
  int signal;
};

namespace checkpoint_detail {
inline volatile std::sig_atomic_t stop_signal = 0, signals_seen = 0;
// The first signal asks for a checkpoint at the next exact step, the second for one at once; the third ends the
// process as if no handler were there (a run stuck in a long solve).
extern "C" inline void on_stop_signal(int signal) {
  stop_signal = signal;
  signals_seen = signals_seen + 1;
  if (signals_seen >= 3) {
    std::signal(signal, SIG_DFL);
    std::raise(signal);
  }
}
inline const char* signal_name(int signal) {
  return signal == SIGTERM ? "SIGTERM" : signal == SIGINT ? "SIGINT" : "a signal";
}
}  // namespace checkpoint_detail

class Checkpoints {
 public:
  using Clock = std::chrono::steady_clock;

  // `params`: the run's parameters as its summary records them; `may_change`: their flattened keys (JSON pointers,
  // e.g. "/end_time_s") that a restart may give otherwise (the rank count always may). `comm`: the MPI communicator's
  // handle of a run on ranks, whose ranks then agree on every checkpoint and stop; rank 0 writes the file.
  Checkpoints(const CheckpointOptions& o, std::filesystem::path dir, std::string app, nlohmann::json params,
              std::set<std::string> may_change, std::optional<int> comm = std::nullopt)
      : options_(o), path_(std::move(dir) / "checkpoint.cbor"), app_(std::move(app)), params_(std::move(params)),
        comm_(comm), last_write_(Clock::now()) {
    if (comm_) MPI_Comm_rank(MPI_Comm_f2c(*comm_), &rank_);
    may_change.insert("/ranks");
    if (!o.restart.empty()) {
      const nlohmann::json state = mps::read_checkpoint(o.restart);
      const std::string app_of = state.value("app", "");
      if (app_of != app_)
        throw std::invalid_argument("--restart " + o.restart + ": a checkpoint of " +
                                    (app_of.empty() ? "no app" : app_of) + ", not of " + app_);
      check_same_parameters(state.at("parameters"), may_change);
      restart_ = state;
    }
    struct sigaction action {};
    action.sa_handler = checkpoint_detail::on_stop_signal;
    sigemptyset(&action.sa_mask);
    sigaction(SIGTERM, &action, nullptr);
    sigaction(SIGINT, &action, nullptr);
  }

  // The checkpoint --restart names, or nullptr.
  [[nodiscard]] const nlohmann::json* restart() const { return restart_.is_null() ? nullptr : &restart_; }
  [[nodiscard]] const std::filesystem::path& path() const { return path_; }
  [[nodiscard]] bool on_ranks() const { return comm_.has_value(); }
  // The app's own state in the --restart checkpoint: this rank's part when the run had as many ranks, else rank 0's
  // (where an app keeps its samplers and tables).
  [[nodiscard]] const nlohmann::json& scene() const {
    const nlohmann::json& scene = restart_.at("scene");
    if (!scene.is_object() || !scene.contains("parts")) return scene;
    int ranks = 1;
    if (comm_) MPI_Comm_size(MPI_Comm_f2c(*comm_), &ranks);
    const nlohmann::json& parts = scene.at("parts");
    return parts.at(static_cast<int>(parts.size()) == ranks ? static_cast<std::size_t>(rank_) : 0);
  }

  // After each step: writes the checkpoint when one is due and the step continues bitwise (or at once on a second
  // signal, or where reorder_every is 0 and no step would). Throws RunStopped after the write a signal asked for.
  template <int D>
  void after_step(const mps::BasicSimulation<D>& sim, const std::function<nlohmann::json()>& scene,
                  Progress& progress) {
    // Without reorderings no later step would be exact: then the checkpoint is written where it falls due.
    const bool exact = sim.checkpoint_exact();
    after_step(sim.last_step().step, sim.time(), exact, !exact && sim.config().reorder_every > 0,
               [&] { return sim.checkpoint(); }, scene, progress);
  }
  // The same for a stepper of another kind (the acoustic solver): its step count, time, whether a checkpoint now
  // continues bitwise and whether to wait for a step that does, and its state.
  void after_step(int step, double time, bool exact, bool wait, const std::function<nlohmann::json()>& simulation,
                  const std::function<nlohmann::json()>& scene, Progress& progress) {
    using checkpoint_detail::signals_seen;
    if (options_.every > 0 && step % options_.every == 0) due_ = true;
    if (options_.wall > 0.0 && std::chrono::duration<double>(Clock::now() - last_write_).count() >= options_.wall)
      due_ = true;
    // On ranks a signal or the wall clock may reach one rank a step before another: they agree here.
    int flags[3] = {signals_seen > 0 ? 1 : 0, signals_seen > 1 ? 1 : 0, due_ ? 1 : 0};
    if (comm_) MPI_Allreduce(MPI_IN_PLACE, flags, 3, MPI_INT, MPI_MAX, MPI_Comm_f2c(*comm_));
    const bool stopping = flags[0] != 0, at_once = flags[1] != 0;
    due_ = flags[2] != 0;
    if (!due_ && !stopping) return;
    if (wait && !at_once) return;
    const auto start = Clock::now();
    write(simulation, scene);
    const double seconds = std::chrono::duration<double>(Clock::now() - start).count();
    progress.clear();
    if (rank_ == 0)
      std::printf("checkpoint: step %d, t = %.6g s, written to %s (%.1f MB in %.2f s)%s\n", step, time,
                  path_.string().c_str(), static_cast<double>(std::filesystem::file_size(path_)) / 1e6, seconds,
                  exact ? "" : " (not at a step that continues bitwise)");
    if (stopping) throw RunStopped{checkpoint_detail::stop_signal != 0 ? checkpoint_detail::stop_signal : SIGTERM};
  }

  // The state now (a guard stop's last good state, or a checkpoint due).
  // On ranks collective: every rank's state goes to rank 0, which writes the file.
  template <int D>
  void write(const mps::BasicSimulation<D>& sim, const std::function<nlohmann::json()>& scene) {
    write([&] { return sim.checkpoint(); },
          [&] { return sim.exchange().gather_states(scene ? scene() : nlohmann::json()); });
  }
  void write(const std::function<nlohmann::json()>& simulation, const std::function<nlohmann::json()>& scene) {
    nlohmann::json state = simulation(), own = scene ? scene() : nlohmann::json();
    if (rank_ == 0)
      mps::write_checkpoint(path_, {{"app", app_}, {"parameters", params_}, {"simulation", std::move(state)},
                                    {"scene", std::move(own)}});
    due_ = false;
    last_write_ = Clock::now();
  }

 private:
  // A restart repeats the run: any parameter but those it may change must be the checkpointed run's.
  void check_same_parameters(const nlohmann::json& saved, const std::set<std::string>& may_change) const {
    const nlohmann::json before = saved.flatten(), now = params_.flatten();
    std::string differ;
    auto add = [&](const std::string& key) {
      if (may_change.count(key) == 0) differ += (differ.empty() ? "" : ", ") + key;
    };
    for (const auto& [key, value] : before.items())
      if (!now.contains(key) || now.at(key) != value) add(key);
    for (const auto& [key, value] : now.items())
      if (!before.contains(key)) add(key);
    if (!differ.empty())
      throw std::invalid_argument("--restart " + options_.restart + ": the checkpointed run had other parameters (" +
                                  differ + "); give its own options again (its summary.json lists them)");
  }

  CheckpointOptions options_;
  std::filesystem::path path_;
  std::string app_;
  nlohmann::json params_, restart_;
  std::optional<int> comm_;
  int rank_ = 0;
  bool due_ = false;
  Clock::time_point last_write_;
};

// The state dambreak, fsi and hydrostatic keep beside the simulation: the scene's own (its samples), the frames
// written and the time of the next progress line.
template <class Scene>
nlohmann::json scene_state(const Scene& scene, const FrameSeries& series, double next_report) {
  return {{"scene", scene.save_state()}, {"frames", series.save_state()}, {"next_report", next_report}};
}

// With --restart: the simulation and what scene_state() saved taken back (on ranks only rank 0, `root`, takes the
// frames: it writes their index); false without one.
template <class Scene, int D>
bool restore_scene(const Checkpoints& checkpoints, mps::BasicSimulation<D>& sim, Scene& scene, FrameSeries& series,
                   double& next_report, bool root = true) {
  const nlohmann::json* restart = checkpoints.restart();
  if (restart == nullptr) return false;
  sim.restore(restart->at("simulation"));
  const nlohmann::json& saved = checkpoints.scene();
  scene.restore_state(saved.at("scene"));
  if (root) series.restore_state(saved.at("frames"));
  next_report = saved.at("next_report").template get<double>();
  if (root) std::printf("restarted at step %d, t = %.4g s\n", sim.last_step().step, sim.time());
  return true;
}

// A run stopped by a signal: summary.json as far as it got (and solves.csv, for a simulation), and where its checkpoint
// is. Returns the exit status, 128 + the signal, as a shell reports a process the signal ended.
inline int report_stop(const std::filesystem::path& dir, const RunStopped& stop, const nlohmann::json& params,
                       int steps, double time, const Checkpoints& checkpoints) {
  const std::string reason = std::string("stopped by ") + checkpoint_detail::signal_name(stop.signal) + " at step " +
                             std::to_string(steps) + "; continue it with --restart " + checkpoints.path().string();
  std::fprintf(stderr, "%s\n", reason.c_str());
  write_summary(dir, {{"status", "stopped"}, {"error", reason}, {"parameters", params}, {"time_s", time},
                      {"steps", steps}, {"checkpoint", checkpoints.path().string()}});
  return 128 + stop.signal;
}

template <int D>
int report_stop(const std::filesystem::path& dir, const RunStopped& stop, const nlohmann::json& params,
                const mps::BasicSimulation<D>& sim, const Checkpoints& checkpoints) {
  if (!sim.exchange().first_process()) return 128 + stop.signal;  // rank 0 reports for all
  write_solves(dir, sim);
  return report_stop(dir, stop, params, sim.last_step().step, sim.time(), checkpoints);
}

// The loop of a scene that steps one simulation (hydrostatic, run): step() until done(), and after each step the
// progress line, the frames and probes due, a line every `report_every` of simulated time and a checkpoint when due.
// A stop by a signal or by the guard is reported (report_stop, report_guard_stop) and its exit status returned;
// a run that reached its end returns nothing.
template <int D, class Step, class Done>
std::optional<int> step_to_end(mps::BasicSimulation<D>& sim, Step step, Done done, double end_time,
                               double report_every, double& next_report, FrameSeries& series,
                               Checkpoints& checkpoints, const std::function<nlohmann::json()>& save,
                               const std::filesystem::path& dir, const nlohmann::json& params) {
  Progress progress(end_time, "s");
  try {
    while (!done()) {
      step();
      progress.update(sim.time(), sim.last_step().step);
      series.write_if_due(sim);
      if (sim.time() >= next_report - 1e-12) {
        const auto& s = sim.last_step();
        progress.clear();
        std::printf("t = %.3f s  step %d  dt %.2e (%s)  unknowns %zu  %s iterations %d  |u|max %.2e m/s\n",
                    s.time, s.step, s.dt, s.dt_limit.c_str(), s.unknowns, s.solve.backend.c_str(), s.solve.iterations,
                    s.max_speed);
        next_report += report_every;
      }
      checkpoints.after_step(sim, save, progress);
    }
  } catch (const RunStopped& stop) {
    progress.finish(sim.time(), sim.last_step().step);
    return report_stop(dir, stop, params, sim, checkpoints);
  } catch (const mps::SimulationError& e) {
    progress.finish(sim.time(), sim.last_step().step);
    checkpoints.write(sim, save);  // the last good state, to restart from
    return report_guard_stop(dir, e, params, sim);
  }
  progress.finish(sim.time(), sim.last_step().step);
  return std::nullopt;
}
