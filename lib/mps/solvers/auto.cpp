// "auto": Jacobi-CG while it converges in few iterations or the unknowns keep changing (a free surface, an inlet:
// an AMG hierarchy would be rebuilt nearly every step), AMG-preconditioned CG with its hierarchy reused once they
// have stayed the same for a few solves and Jacobi needed many iterations. The rule reads only the systems' sizes and
// iteration counts, so a run repeats bitwise; docs/solvers.md has the measurements behind it.
#include <memory>
#include <string>

#include "mps/solvers/registry.hpp"

namespace mps {
namespace {

class AutoSolver final : public LinearSolver {
 public:
  AutoSolver(const SolverOptions& o, const SolverContext& context)
      : switch_iterations_(o.integer("switch_iterations", 0, 100000000)),
        rebuild_iterations_(o.integer("rebuild_iterations", 0, 100000000)),
        steady_solves_(o.integer("steady_solves", 1, 1000000)),
        spec_(o.spec()) {
    const std::string tol = "tol=" + o.values().at("tol");
    // Validated here, passed on as written.
    static_cast<void>(o.number("tol", 1e-16, 1e-1));
    static_cast<void>(o.integer("reuse", 0, 1000000));
    static_cast<void>(o.number("filter", 0.0, 1.0));
    jacobi_ = make_solver("eigen-cg:precond=jacobi," + tol);
    amg_ = make_solver("hypre-pcg:reuse=" + o.values().at("reuse") + ",filter=" + o.values().at("filter") + "," + tol,
                       context);
    distributed_ = context.mpi_comm.has_value();  // Eigen solves one rank's rows only
  }

  SolveReport solve(const CsrMatrix& a, std::span<const double> b, std::span<double> x) override {
    steady_ = a.rows == last_rows_ ? steady_ + 1 : 1;
    last_rows_ = a.rows;
    // Jacobi this slow costs more than a fresh filtered AMG setup and solve (about 150 and 50 SpMVs at 1e5
    // unknowns, docs/solvers.md): AMG from then on, its hierarchy rebuilt whenever the unknowns change.
    always_amg_ = always_amg_ || last_jacobi_iterations_ > rebuild_iterations_;
    if (distributed_ || always_amg_ ||
        (steady_ >= steady_solves_ && (on_amg_ || last_jacobi_iterations_ > switch_iterations_))) {
      on_amg_ = true;
      return amg_->solve(a, b, x);
    }
    on_amg_ = false;
    SolveReport report = jacobi_->solve(a, b, x);
    last_jacobi_iterations_ = report.iterations;
    return report;
  }
  [[nodiscard]] std::string spec() const override { return spec_; }

 private:
  std::unique_ptr<LinearSolver> jacobi_, amg_;
  int switch_iterations_, rebuild_iterations_, steady_solves_;
  std::string spec_;
  bool distributed_ = false, on_amg_ = false, always_amg_ = false;
  int last_rows_ = -1, last_jacobi_iterations_ = 0;
  int steady_ = 0;  // solves in a row, this one included, with the same unknown count
};

}  // namespace

SolverEntry auto_entry() {
  return {"auto",
          "The default: Jacobi-CG (eigen-cg:precond=jacobi) while it needs few iterations or the unknowns change from "
          "step to step; hypre-pcg with its AMG hierarchy reused once the unknowns stay the same and Jacobi needed "
          "more than switch_iterations, or for good once a Jacobi solve needed more than rebuild_iterations. Each "
          "solve's report names the backend it used.",
          {{"tol", "1e-8", "relative residual ||b-Ax||/||b|| to reach, for either backend"},
           {"switch_iterations", "50", "Jacobi iterations above which an unchanged system moves to AMG-PCG"},
           {"rebuild_iterations", "150",
            "Jacobi iterations above which AMG-PCG takes over for good, set up afresh whenever the unknowns change"},
           {"steady_solves", "3", "solves in a row with the same unknown count before AMG-PCG is set up"},
           {"reuse", "20", "hypre-pcg: solves one AMG hierarchy serves while the unknowns stay the same"},
           {"filter", "0.2",
            "hypre-pcg: AMG built on the PPE with couplings below this fraction of the strongest lumped onto the "
            "diagonal (half the solve's cost on the 4.1 l0 stencil)"}},
          [](const SolverOptions& o, const SolverContext& c) { return std::make_unique<AutoSolver>(o, c); },
          /*distributed: hypre-pcg alone on a communicator*/ true};
}

}  // namespace mps
