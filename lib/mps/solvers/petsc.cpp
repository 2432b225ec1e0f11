// The petsc backend: the spec and the input checks here, PETSc itself in a module of its own (petsc_ksp.cpp,
// libsparsemps_petsc.so) opened at the first petsc solver: linked into the library, PETSc and the libraries it needs
// would load with every program, used or not (docs/solvers.md#petsc).
#include <dlfcn.h>
#include <mpi.h>

#include <mutex>

#include "mps/solvers/backend_util.hpp"
#include "mps/solvers/petsc_module.hpp"
#include "mps/solvers/registry.hpp"

namespace mps {
namespace {

using solver_detail::any_rank;

// Beside the library itself (a shared build, in the build tree or installed), else where the build and the install
// put it (a static library inside a program).
std::vector<std::string> module_paths() {
  std::vector<std::string> paths;
  Dl_info info{};
  if (dladdr(reinterpret_cast<void*>(&petsc_entry), &info) != 0 && info.dli_fname != nullptr) {
    const std::string self = info.dli_fname;
    const auto slash = self.rfind('/');
    paths.push_back((slash == std::string::npos ? std::string(".") : self.substr(0, slash)) + "/" +
                    SPARSEMPS_PETSC_MODULE_NAME);
  }
  paths.emplace_back(SPARSEMPS_PETSC_MODULE_BUILD);
  paths.emplace_back(SPARSEMPS_PETSC_MODULE_INSTALL);
  return paths;
}

petsc_module::Make load_module() {
  static std::once_flag once;
  static petsc_module::Make make = nullptr;
  static std::string failure;
  std::call_once(once, [] {
    for (const std::string& path : module_paths()) {
      void* handle = dlopen(path.c_str(), RTLD_NOW | RTLD_LOCAL);  // never closed: its solvers may outlive any owner
      if (handle == nullptr) {
        failure += std::string(failure.empty() ? "" : "; ") + dlerror();
        continue;
      }
      make = reinterpret_cast<petsc_module::Make>(dlsym(handle, petsc_module::kMakeSymbol));
      if (make != nullptr) return;
      failure += "; " + path + " has no " + petsc_module::kMakeSymbol;
    }
  });
  if (make == nullptr)
    throw std::invalid_argument("solver 'petsc': its PETSc module could not be opened (" + failure +
                                "); build the target sparsemps_petsc, which needs Debian's libpetsc-real-dev");
  return make;
}

// The module's solver behind the checks every backend makes, taken on every rank together.
class PetscSolver final : public LinearSolver {
 public:
  PetscSolver(std::unique_ptr<LinearSolver> ksp, bool symmetric, MPI_Comm comm)
      : ksp_(std::move(ksp)), symmetric_(symmetric), comm_(comm) {}

  SolveReport solve(const CsrMatrix& a, std::span<const double> b, std::span<double> x) override {
    SolveReport report;
    report.backend = "petsc";
    const long long rows = a.rows;
    long long total = 0, first_row = 0;
    MPI_Allreduce(&rows, &total, 1, MPI_LONG_LONG, MPI_SUM, comm_);
    MPI_Exscan(&rows, &first_row, 1, MPI_LONG_LONG, MPI_SUM, comm_);
    int rank = 0;
    MPI_Comm_rank(comm_, &rank);
    if (rank == 0) first_row = 0;
    std::string bad;
    try {
      solver_detail::RowScan scan;
      solver_detail::scan_rows("petsc", a, static_cast<int>(first_row), scan, report);
      // CG needs a symmetric positive definite matrix: checked as hypre-pcg checks it (symmetry on one rank, where
      // the whole matrix is here).
      solver_detail::check_diagonal("petsc", a, static_cast<int>(first_row), scan, symmetric_, report);
      if (symmetric_ && a.cols == a.rows && scan.finite && !solver_detail::symmetric(a, scan))
        throw SolverError("petsc: the matrix is not symmetric, which ksp_type=cg needs; use ksp_type=gmres or bcgs "
                          "for a nonsymmetric matrix",
                          report);
      if (b.size() != static_cast<std::size_t>(a.rows) || x.size() != b.size() || a.cols != total)
        throw SolverError("petsc: matrix and vector sizes do not match (each rank passes its block of rows of a "
                          "square matrix, with a.cols the global size)",
                          report);
      if (!scan.finite) throw SolverError("petsc: NaN or Inf in the matrix", report);
      if (!solver_detail::all_finite(b)) throw SolverError("petsc: NaN or Inf in the right-hand side", report);
    } catch (const SolverError& e) {
      bad = e.what();
    }
    if (any_rank(!bad.empty(), comm_))
      throw SolverError(bad.empty() ? "petsc: another rank's block of the matrix or vectors is malformed" : bad,
                        report);
    if (!solver_detail::all_finite(x))
      for (double& v : x) v = 0.0;
    return ksp_->solve(a, b, x);
  }
  [[nodiscard]] std::string spec() const override { return ksp_->spec(); }
  void renumbered() override { ksp_->renumbered(); }
  [[nodiscard]] bool keeps_setup() const override { return ksp_->keeps_setup(); }

 private:
  std::unique_ptr<LinearSolver> ksp_;
  bool symmetric_;
  MPI_Comm comm_;
};

}  // namespace

SolverEntry petsc_entry() {
  return {"petsc",
          "PETSc's KSP (Debian's libpetsc-real): every key besides tol, max_iter and reuse is one of PETSc's options "
          "without its dash, passed through (ksp_type, pc_type, pc_gamg_threshold, mg_levels_ksp_type, "
          "pc_hypre_type, ...): GAMG, hypre through PETSc, ICC/ILU and every Krylov method one key away. On MPI "
          "ranks too.",
          {{"tol", "1e-8", "relative residual to reach (||b-Ax||/||b|| for ksp_type=cg; PETSc's rtol)"},
           {"max_iter", "10000", "iterations before the solve is reported as failed (PETSc's ksp_max_it)"},
           {"reuse", "0",
            "keep the preconditioner for up to N further solves while the unknown count is unchanged "
            "(rebuilt and the solve redone if a reused one fails); 0: set up every solve"},
           {"ksp_type", "cg", "PETSc's Krylov method: cg | gmres | bcgs | minres | preonly | ..."},
           {"pc_type", "gamg", "PETSc's preconditioner: gamg | hypre | icc | ilu | jacobi | sor | cholesky | ..."}},
          [](const SolverOptions& o, const SolverContext& context) -> std::unique_ptr<LinearSolver> {
            petsc_module::Request request;
            request.tol = o.number("tol", 1e-16, 1e-1);
            request.max_iter = o.integer("max_iter", 1, 100000000);
            request.reuse = o.integer("reuse", 0, 1000000);
            for (const auto& [key, value] : o.values())
              if (key != "tol" && key != "max_iter" && key != "reuse") request.options[key] = value;
            request.spec = o.spec();
            request.mpi_comm = context.mpi_comm;
            const MPI_Comm comm = context.mpi_comm ? MPI_Comm_f2c(*context.mpi_comm) : MPI_COMM_SELF;
            std::unique_ptr<LinearSolver> ksp(load_module()(request));
            return std::make_unique<PetscSolver>(std::move(ksp), request.options.at("ksp_type") == "cg", comm);
          },
          /*distributed*/ true, /*passes_other_keys*/ true};
}

}  // namespace mps
