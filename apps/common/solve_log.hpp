#pragma once
// For people who benchmark solvers on real PPEs: every pressure solve of a run as a row of solves.csv, and the
// step's PPE (A and b) written as Matrix Market at the steps --export-ppe names.
#include <CLI/CLI.hpp>
#include <cstdio>
#include <filesystem>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include "mps/io/io.hpp"
#include "mps/step/step.hpp"

template <int D>
class BasicSolveLog final : public mps::BasicStepComponent<D> {
 public:
  using typename mps::BasicStepComponent<D>::StepContext;
  // scene: a few words saying which scene and spacing, written into each exported matrix's header.
  BasicSolveLog(std::filesystem::path dir, std::set<int> export_steps, std::string scene)
      : dir_(std::move(dir)), export_steps_(std::move(export_steps)), scene_(std::move(scene)) {}

  void after_pressure(StepContext& c) override {
    const mps::StepInfo& info = c.sim.last_step();
    const mps::SolveReport& r = info.solve;
    const int step = info.step + 1;
    std::ostringstream row;
    row.precision(17);
    row << step << ',' << c.fields.time << ',' << info.unknowns << ',' << (r.backend.empty() ? "none" : r.backend) << ','
        << r.iterations << ',' << r.relative_residual << ',' << r.setup_seconds << ',' << r.solve_seconds << ','
        << (r.setup_reused ? 1 : 0);
    rows_.push_back(row.str());
    if (export_steps_.count(step) != 0) export_ppe(c, step);
  }

  [[nodiscard]] const std::set<int>& export_steps() const { return export_steps_; }
  // A restarted run's solves.csv lists the solves before its checkpoint too.
  [[nodiscard]] nlohmann::json save_state() const override { return rows_; }
  void restore_state(const nlohmann::json& state) override { rows_ = state.get<std::vector<std::string>>(); }

  // solves.csv: one row per solve, in step order (a step the guard undid keeps its row).
  void write(const std::filesystem::path& dir) const {
    std::string text = "step,time_s,unknowns,backend,iterations,relative_residual,setup_s,solve_s,setup_reused\n";
    for (const std::string& row : rows_) text += row + "\n";
    mps::write_text(dir / "solves.csv", text);
  }

 private:
  void export_ppe(const StepContext& c, int step) const {
    const mps::SimulationConfig& config = c.sim.config();
    const mps::PpeSystem& ppe = c.sim.last_ppe();
    std::ostringstream number;
    number.precision(15);
    auto num = [&](double v) {
      number.str("");
      number << v;
      return number.str();
    };
    const std::vector<std::string> comments = {
        "scene: " + scene_,
        "step " + std::to_string(step) + ", t = " + num(c.fields.time) + " s, dt = " + num(c.fields.dt) + " s",
        "l0 = " + num(config.l0) + " m, Laplacian radius = " + num(config.radius_laplacian) +
            " l0, gamma = " + num(config.gamma) + ", rho = " + num(config.rho) + " kg/m^3",
        "A x = b is the step's pressure Poisson equation: A = -(discrete Laplacian), symmetric positive definite, "
        "x the pressure in Pa, b = -(mixed source) plus the free surface's Dirichlet values",
        "unknowns: wet fluid and wall particles, in particle order; b in " +
            std::string("step_") + pad(step) + "_rhs.mtx"};
    std::filesystem::create_directories(dir_ / "ppe");
    mps::write_matrix_market(dir_ / "ppe" / ("step_" + pad(step) + ".mtx"), ppe.matrix, comments, true);
    mps::write_matrix_market(dir_ / "ppe" / ("step_" + pad(step) + "_rhs.mtx"), ppe.rhs);
  }

  static std::string pad(int step) {
    char text[16];
    std::snprintf(text, sizeof text, "%06d", step);
    return text;
  }

  std::filesystem::path dir_;
  std::set<int> export_steps_;
  std::string scene_;
  std::vector<std::string> rows_;
};

using SolveLog = BasicSolveLog<2>;

// solves.csv of the run's SolveLog, if it has one; a step --export-ppe named that the run never reached is said.
template <int D>
void write_solves(const std::filesystem::path& dir, const mps::BasicSimulation<D>& sim) {
  const auto* log = sim.template find<BasicSolveLog<D>>();
  if (log == nullptr) return;
  log->write(dir);
  std::string missed;
  for (int step : log->export_steps())
    if (step > sim.last_step().step) missed += (missed.empty() ? "" : ",") + std::to_string(step);
  if (!missed.empty())
    std::fprintf(stderr, "warning: --export-ppe %s: the run ended after step %d, so no PPE was written for %s\n",
                 missed.c_str(), sim.last_step().step, missed.find(',') == std::string::npos ? "it" : "them");
}

// --export-ppe STEPS: the steps whose PPE is written to OUT/ppe/ (comma-separated step numbers).
inline CLI::Option* add_export_ppe_option(CLI::App& app, std::vector<int>& steps) {
  return app.add_option("--export-ppe", steps,
                        "write the PPE (A and b, Matrix Market, with the scene, step, l0, radius and gamma in its "
                        "header) of these steps to OUT/ppe/")
      ->delimiter(',')
      ->check(CLI::Range(1, 100000000))
      ->group("Output");
}
