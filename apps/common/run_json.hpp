#pragma once
// The timing block every app's summary.json carries.
#include <nlohmann/json.hpp>

#include "mps/step.hpp"

inline nlohmann::json timings_json(const mps::PhaseTimes& t, int steps, std::size_t particles) {
  return {{"neighbors_s", t.neighbors}, {"predict_s", t.predict}, {"assemble_s", t.assemble},
          {"solver_setup_s", t.solver_setup}, {"solve_s", t.solve}, {"correct_s", t.correct}, {"total_s", t.total()},
          {"particle_steps_per_second", t.total() > 0 ? static_cast<double>(particles) * steps / t.total() : 0.0}};
}
