#pragma once
/// \file
/// What a backend declares to the registry: its keys with defaults, and a factory over validated options.
#include <functional>
#include <initializer_list>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "mps/solvers/solver.hpp"

namespace mps {

/// One key a backend accepts in its spec.
struct SolverKey {
  std::string name;           ///< as written in the spec, e.g. "tol"
  std::string default_value;  ///< the value when the spec leaves the key out
  std::string help;           ///< a line for --list-solvers
};

/// The options of one spec, with defaults filled in; typed getters reject bad values with a message that
/// names the solver, the key and what is allowed.
class SolverOptions {
 public:
  /// The options of solver `solver`: every declared key with its value (the spec's or the default).
  SolverOptions(std::string solver, std::map<std::string, std::string> values)
      : solver_(std::move(solver)), values_(std::move(values)) {}
  [[nodiscard]] double number(const std::string& key, double min, double max) const;  ///< a number in [min, max]
  [[nodiscard]] int integer(const std::string& key, int min, int max) const;  ///< a whole number in [min, max]
  /// One of `allowed`.
  [[nodiscard]] std::string choice(const std::string& key, std::initializer_list<const char*> allowed) const;
  [[nodiscard]] const std::map<std::string, std::string>& values() const { return values_; }  ///< key -> value
  /// "name:key=value,..." with every key, in key order.
  [[nodiscard]] std::string spec() const;

 private:
  [[nodiscard]] const std::string& raw(const std::string& key) const;
  std::string solver_;
  std::map<std::string, std::string> values_;
};

/// A backend as the registry knows it.
struct SolverEntry {
  std::string name;             ///< the spec's name, e.g. "hypre-pcg"
  std::string summary;          ///< a line on when to use it (--list-solvers)
  std::vector<SolverKey> keys;  ///< every key it accepts, with defaults
  /// Builds the solver from validated options.
  std::function<std::unique_ptr<LinearSolver>(const SolverOptions&, const SolverContext&)> make;
  /// Solves with rows spread over the ranks of SolverContext::mpi_comm; make_solver refuses the others a
  /// communicator of more than one rank.
  bool distributed = false;
  /// Takes keys it does not declare as well, passed through to the library behind it (petsc: PETSc's options),
  /// which must then refuse the ones it does not know.
  bool passes_other_keys = false;
};

/// @{ The backends' registry entries, one function per backend file (named beside each); make_solver and
/// describe_solvers list them.
SolverEntry eigen_cg_entry();        // eigen.cpp
SolverEntry eigen_bicgstab_entry();  // eigen.cpp
SolverEntry cholmod_entry();         // cholmod.cpp
SolverEntry hypre_amg_entry();       // hypre.cpp
SolverEntry hypre_pcg_entry();       // hypre.cpp
SolverEntry auto_entry();            // auto.cpp
SolverEntry petsc_entry();           // petsc.cpp
/// @}

/// Every registered backend in listing order, with its keys, defaults and help (what describe_solvers prints, as data
/// for bindings and tools that present the choices themselves).
const std::vector<SolverEntry>& solver_registry();

}  // namespace mps
