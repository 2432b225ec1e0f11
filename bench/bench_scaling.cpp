// Cost of a time step against the particle count: the periodic body-force Poiseuille channel scaled up (as many
// particles along the channel as across it), run for a few steps per solver backend, with the step's phases
// timed by the library (neighbours, predictor, assembly, solver setup, solve, corrector). The first steps are
// left out (warm-up: first-touch allocation, the first AMG setup). Each run also reports the profile's L2 error
// against the series solution after its steps, so that backends are compared at equal accuracy, and the PPE's
// cost in SpMV-equivalents: setup and solve per step over one product with the last step's matrix.
//
//   bench_scaling --sizes 1e4,1e5,1e6 --solvers "eigen-cg;hypre-pcg:reuse=10" --out bench/results/scaling.csv
#include <omp.h>
#include <sys/resource.h>

#include <CLI/CLI.hpp>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <string>
#include <vector>

#include "channel.hpp"
#include "solver_cli.hpp"

namespace {

struct Row {
  long particles = 0, fluid = 0, unknowns = 0;
  std::string solver, solver_spec;  // as given, and in full with every default
  int steps = 0;
  mps::PhaseTimes per_step;
  bool warm_start = true;
  double iterations = 0, l2_error = 0;
  double peak_rss_mb = 0;  // of the whole process so far: with sizes ascending, this run's
  double spmv_s = 0;       // one product with the last step's PPE matrix (median of 11), the SpMV-equivalent unit
};

double median_spmv_seconds(const mps::CsrMatrix& a) {
  std::vector<double> x(static_cast<std::size_t>(a.cols), 1.0), y(static_cast<std::size_t>(a.rows));
  std::vector<double> seconds;
  for (int k = 0; k < 11; ++k) {
    const auto t0 = std::chrono::steady_clock::now();
    a.multiply(x, y);
    seconds.push_back(std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
  }
  std::nth_element(seconds.begin(), seconds.begin() + 5, seconds.end());
  return seconds[5];
}

double peak_rss_mb() {
  rusage u{};
  getrusage(RUSAGE_SELF, &u);
  return static_cast<double>(u.ru_maxrss) / 1024.0;  // kB on Linux
}

mps::PhaseTimes per_step(const mps::PhaseTimes& end, const mps::PhaseTimes& start, int steps) {
  const double k = 1.0 / steps;
  return {(end.neighbors - start.neighbors) * k, (end.predict - start.predict) * k,
          (end.assemble - start.assemble) * k,   (end.solver_setup - start.solver_setup) * k,
          (end.solve - start.solve) * k,         (end.correct - start.correct) * k};
}

Row run(long size, const std::string& spec, bool warm_start, int warmup, int steps) {
  poiseuille::Params p;
  p.mode = poiseuille::Mode::body_force;
  p.across = std::round(std::sqrt(static_cast<double>(size)));
  p.length_l0 = p.across;
  p.solver = spec;
  p.warm_start = warm_start;
  p.validate();
  mps::Simulation sim = poiseuille::make_simulation(p);
  for (int s = 0; s < warmup; ++s) sim.step();
  const mps::PhaseTimes start = sim.times();
  double iterations = 0;
  for (int s = 0; s < steps; ++s) iterations += sim.step().solve.iterations;
  Row r;
  r.particles = static_cast<long>(sim.particles().size());
  r.fluid = static_cast<long>(sim.particles().count(mps::Kind::fluid));
  r.unknowns = static_cast<long>(sim.last_step().unknowns);
  r.solver = spec;
  r.solver_spec = sim.solver().spec();
  r.steps = steps;
  r.per_step = per_step(sim.times(), start, steps);
  r.warm_start = warm_start;
  r.iterations = iterations / steps;
  r.l2_error = poiseuille::measure_profile(p, sim).l2_error;
  r.peak_rss_mb = peak_rss_mb();
  r.spmv_s = median_spmv_seconds(sim.last_ppe().matrix);
  return r;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"SparseMPS scaling: per-step cost by phase against N, body-force channel, per solver backend"};
  std::vector<double> sizes{1e4, 3e4, 1e5};
  std::vector<std::string> solvers{"eigen-cg", "hypre-pcg:reuse=10"}, cold{"eigen-cg"};
  std::string out = "scaling.csv";
  int warmup = 3, steps = 5;
  double cholmod_limit = 3e5;
  app.add_option("--sizes", sizes, "comma-separated particle counts (fluid, about)")->delimiter(',')->capture_default_str();
  app.add_option("--solvers", solvers, "semicolon-separated solver specs, each run warm-started ('' for none)")
      ->delimiter(';')
      ->capture_default_str();
  app.add_option("--cold", cold, "semicolon-separated solver specs also run from a zero initial guess each step ('' for none)")
      ->delimiter(';')
      ->capture_default_str();
  app.add_option("--warmup", warmup, "steps run before timing")->capture_default_str()->check(CLI::NonNegativeNumber);
  app.add_option("--steps", steps, "steps timed")->capture_default_str()->check(CLI::PositiveNumber);
  app.add_option("--cholmod-limit", cholmod_limit, "largest size given to cholmod (memory grows fastest)")->capture_default_str();
  app.add_option("--out", out, "CSV output")->capture_default_str();
  add_list_solvers_flag(app);
  CLI11_PARSE(app, argc, argv);

  std::vector<std::pair<std::string, bool>> runs;
  for (const std::string& s : solvers)
    if (!s.empty()) runs.emplace_back(s, true);
  for (const std::string& s : cold)
    if (!s.empty()) runs.emplace_back(s, false);
  std::ofstream csv(out);
  if (!csv) {
    std::cerr << "error: cannot write " << out << "\n";
    return 1;
  }
  csv << "particles,fluid,unknowns,solver,warm_start,steps,neighbors_s,predict_s,assemble_s,setup_s,solve_s,"
         "correct_s,total_s,iterations,particle_steps_per_s,l2_error,threads,peak_rss_mb,spmv_s,ppe_spmv_equivalents,"
         "solver_spec\n";
  std::cout << "body-force channel, " << omp_get_max_threads() << " OpenMP threads, " << steps << " timed steps after "
            << warmup << " (seconds per step)\n";
  try {
    for (const double size_wanted : sizes) {
      const long size = std::lround(size_wanted);
      for (const auto& [spec, warm] : runs) {
        if (spec.rfind("cholmod", 0) == 0 && static_cast<double>(size) > cholmod_limit) continue;
        const Row r = run(size, spec, warm, warmup, steps);
        const mps::PhaseTimes& t = r.per_step;
        csv << r.particles << ',' << r.fluid << ',' << r.unknowns << ",\"" << r.solver << "\"," << r.warm_start << ','
            << r.steps << std::setprecision(6) << ',' << t.neighbors << ',' << t.predict << ',' << t.assemble << ','
            << t.solver_setup << ',' << t.solve << ',' << t.correct << ',' << t.total() << ',' << r.iterations << ','
            << static_cast<double>(r.fluid) / t.total() << ',' << r.l2_error << ',' << omp_get_max_threads() << ','
            << r.peak_rss_mb << ',' << r.spmv_s << ',' << (t.solver_setup + t.solve) / r.spmv_s << ",\""
            << r.solver_spec << "\"\n";
        csv.flush();
        std::cout << std::setw(9) << r.fluid << "  " << std::left << std::setw(40)
                  << (r.solver + (r.warm_start ? "" : " (cold)")).substr(0, 40) << std::right << std::fixed
                  << std::setprecision(4) << " neighbours " << t.neighbors << " assembly " << t.assemble << " setup "
                  << t.solver_setup << " solve " << t.solve << " total " << t.total() << std::setprecision(1)
                  << "  iterations " << r.iterations << std::scientific << std::setprecision(3) << "  L2 "
                  << r.l2_error << std::defaultfloat << std::endl;
      }
    }
  } catch (const std::exception& e) {
    std::cerr << "error: " << e.what() << "\n";
    return 1;
  }
  std::cout << "wrote " << out << "\n";
  return 0;
}
