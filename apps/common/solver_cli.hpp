#pragma once
// The solver options every app and benchmark offers: --solver SPEC and --list-solvers (prints each solver
// with its keys and defaults, then exits 0).
#include <CLI/CLI.hpp>
#include <iostream>
#include <string>

#include "checks.hpp"
#include "mps/solvers/solver.hpp"
#include "mps/step/config.hpp"

inline void add_list_solvers_flag(CLI::App& app) {
  app.add_flag_callback(
      "--list-solvers",
      [] {
        std::cout << mps::describe_solvers();
        throw CLI::Success();
      },
      "print the available solvers with their keys and defaults, and exit")
      ->configurable(false)
      ->group("Solver");
}

// --cold-start: every pressure solve from a zero guess instead of the previous step's pressure
// (SimulationConfig::warm_start = false), the classic baseline. A flag that sets false, not a negated flag: CLI11
// writes a negated flag's state into config.toml so that reading it back loses the setting.
inline CLI::Option* add_cold_start_flag(CLI::App& app, bool& warm_start) {
  return app.add_flag_callback(
      "--cold-start", [&warm_start] { warm_start = false; },
      "start each pressure solve from zeros instead of the previous step's pressure (the classic baseline)")
      ->group("Solver");
}

// default_by_scene: the default depends on other options, said in these words, and `shifting` holds a negative
// sentinel until given (no default is written into config.toml).
inline CLI::Option* add_shifting_option(CLI::App& app, double& shifting, const std::string& default_by_scene = "") {
  CLI::Option* o = app.add_option("--shifting", shifting, "particle shifting coefficient A: fluid moves down the "
                                  "particle concentration gradient by A l0 |u|max dt per step, its velocity carried "
                                  "along (0: off)" + default_by_scene);
  if (default_by_scene.empty()) o->capture_default_str();
  return o->check(number_in(0.0, 10.0))->group("Numerics");
}

// --pressure-treatment: Khayyer & Gotoh's treatments of the projection by name (mps::set_pressure_treatment), a bad
// name refused with the library's message.
// `default_by_scene`: the default's words where it depends on other options (then no default string is shown or
// written to config.toml).
inline CLI::Option* add_pressure_treatment_option(CLI::App& app, std::string& names,
                                                  const std::string& default_by_scene = "") {
  CLI::Option* o = app.add_option("--pressure-treatment", names,
                        "Khayyer & Gotoh's treatments of the projection, joined by '+': hs (higher-order source), hl "
                        "(higher-order Laplacian), ecs (error-compensating source), cfs (continuous free surface: every "
                        "fluid particle an unknown), gc (corrected gradient), ds (dynamic stabilisation of close pairs); or "
                        "none (docs/pressure.md)" + default_by_scene);
  if (default_by_scene.empty()) o->capture_default_str();
  return o->check([](const std::string& given) {
        mps::SimulationConfig c;
        try {
          mps::set_pressure_treatment(c, given);
        } catch (const std::invalid_argument& e) {
          return std::string(e.what());
        }
        return std::string();
      })
      ->group("Numerics");
}

inline CLI::Option* add_solver_options(CLI::App& app, std::string& spec) {
  add_list_solvers_flag(app);
  return app.add_option("--solver", spec, "linear solver spec name[:key=value,...] (see --list-solvers)")
      ->capture_default_str()
      ->group("Solver");
}
