#pragma once
// What the library hands the PETSc module (petsc_ksp.cpp, opened by mps/solvers/petsc.cpp at the first petsc
// solver): the spec's numbers, already checked, and PETSc's options as written. Private to the two; the module
// uses headers only, so that it needs none of the library's symbols.
#include <map>
#include <optional>
#include <string>

#include "mps/solvers/solver.hpp"

namespace mps::petsc_module {

struct Request {
  double tol = 1e-8;
  int max_iter = 10000;
  int reuse = 0;
  std::map<std::string, std::string> options;  // PETSc's, without their dash: ksp_type, pc_type, ...
  std::string spec;                             // the whole spec, for messages and spec()
  std::optional<int> mpi_comm;                  // SolverContext::mpi_comm
};

// The module's one entry point: a solver that takes inputs the library has already checked (structure, sizes,
// finite values, diagonals, symmetry for CG). Throws std::invalid_argument for options PETSc refuses.
using Make = LinearSolver* (*)(const Request&);
inline constexpr const char* kMakeSymbol = "sparsemps_petsc_make";

}  // namespace mps::petsc_module
