#pragma once
// What a backend declares to the registry: its keys with defaults, and a factory over validated options.
#include <functional>
#include <initializer_list>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "mps/solvers/solver.hpp"

namespace mps {

struct SolverKey {
  std::string name;
  std::string default_value;
  std::string help;
};

// The options of one spec, with defaults filled in; typed getters reject bad values with a message that
// names the solver, the key and what is allowed.
class SolverOptions {
 public:
  SolverOptions(std::string solver, std::map<std::string, std::string> values)
      : solver_(std::move(solver)), values_(std::move(values)) {}
  [[nodiscard]] double number(const std::string& key, double min, double max) const;
  [[nodiscard]] int integer(const std::string& key, int min, int max) const;
  [[nodiscard]] std::string choice(const std::string& key, std::initializer_list<const char*> allowed) const;
  [[nodiscard]] const std::map<std::string, std::string>& values() const { return values_; }
  // "name:key=value,..." with every key, in key order.
  [[nodiscard]] std::string spec() const;

 private:
  [[nodiscard]] const std::string& raw(const std::string& key) const;
  std::string solver_;
  std::map<std::string, std::string> values_;
};

struct SolverEntry {
  std::string name;
  std::string summary;
  std::vector<SolverKey> keys;
  std::function<std::unique_ptr<LinearSolver>(const SolverOptions&, const SolverContext&)> make;
};

// One function per backend file; the registry lists them.
SolverEntry eigen_cg_entry();        // eigen.cpp
SolverEntry eigen_bicgstab_entry();  // eigen.cpp
SolverEntry cholmod_entry();         // cholmod.cpp
SolverEntry hypre_amg_entry();       // hypre.cpp
SolverEntry hypre_pcg_entry();       // hypre.cpp
SolverEntry auto_entry();            // auto.cpp

// Every registered backend in listing order, with its keys, defaults and help (what describe_solvers prints, as data
// for bindings and tools that present the choices themselves).
const std::vector<SolverEntry>& solver_registry();

}  // namespace mps
