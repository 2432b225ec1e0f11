#pragma once
// What every app writes beside its outputs: the timing block of summary.json, and the record of a run the
// stability guard stopped.
#include <filesystem>
#include <iostream>
#include <nlohmann/json.hpp>

#include "mps/io.hpp"
#include "mps/step.hpp"

inline nlohmann::json timings_json(const mps::PhaseTimes& t, int steps, std::size_t particles) {
  return {{"neighbors_s", t.neighbors}, {"predict_s", t.predict}, {"assemble_s", t.assemble},
          {"solver_setup_s", t.solver_setup}, {"solve_s", t.solve}, {"correct_s", t.correct}, {"total_s", t.total()},
          {"particle_steps_per_second", t.total() > 0 ? static_cast<double>(particles) * steps / t.total() : 0.0}};
}

// The simulation holds the last good state: keep it beside the frames, say what went wrong in summary.json
// and on stderr. Returns the app's exit status.
inline int report_guard_stop(const std::filesystem::path& dir, const mps::SimulationError& error,
                             const nlohmann::json& params, const mps::Simulation& sim) {
  std::cerr << "error: " << error.what() << "\n";  // first: a failed write below must not hide the reason
  try {
    mps::write_vtp(dir / "last_good.vtp", sim.particles());
    mps::write_json(dir / "summary.json", {{"status", "failed"}, {"error", error.what()}, {"parameters", params},
                                           {"time_s", sim.time()}, {"steps", sim.last_step().step}});
    std::cerr << "last good state written to " << (dir / "last_good.vtp").string() << "\n";
  } catch (const std::exception& e) {
    std::cerr << "error: the last good state could not be saved: " << e.what() << "\n";
  }
  return 1;
}
