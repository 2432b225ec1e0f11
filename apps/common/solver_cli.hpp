#pragma once
// The solver options every app and benchmark offers: --solver SPEC and --list-solvers (prints each solver
// with its keys and defaults, then exits 0).
#include <CLI/CLI.hpp>
#include <iostream>
#include <string>

#include "mps/solvers/solver.hpp"

inline void add_list_solvers_flag(CLI::App& app) {
  app.add_flag_callback(
      "--list-solvers",
      [] {
        std::cout << mps::describe_solvers();
        throw CLI::Success();
      },
      "print the available solvers with their keys and defaults, and exit");
}

inline CLI::Option* add_solver_options(CLI::App& app, std::string& spec) {
  add_list_solvers_flag(app);
  return app.add_option("--solver", spec, "linear solver spec name[:key=value,...] (see --list-solvers)")
      ->capture_default_str();
}
