// The MPS step on P ranks (mps/parallel/rank_exchange.hpp): apps/dambreak's classic column (2-D) or SPHERIC Test 2
// (--dim 3, docs/dambreak3d.md) at a spacing giving about the requested fluid count (or --l0), built on every rank and
// distributed, stepped `--steps` times after one untimed step (the
// first solve's AMG setup and the first halo). Per step: the slowest rank's wall time (between barriers), its phase
// times, the partition + migration and halo set-up, the halo copies, messages, bytes and migrations, the
// repartitions and the largest load imbalance. One CSV row per run, appended; run it under mpirun for each P:
//
//   OMP_NUM_THREADS=1 mpirun -np 2 bench_distributed_step --fluid 1e5 --out bench/results/distributed_step.csv
//
// --trace FILE writes one row per step (time, load imbalance by particles and by fluid, repartition, migrations,
// the time placing particles): how the load drifts with the cuts kept (--threshold inf) or renewed.
#include <mpi.h>

#include <CLI/CLI.hpp>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <memory>
#include <stdexcept>
#include <string>

#include "box_impact.hpp"
#include "column.hpp"
#include "mpi_bench.hpp"
#include "mps/parallel/rank_exchange.hpp"
#include "mps/step/components.hpp"

namespace {

double slowest(MPI_Comm comm, double seconds) { return reduce(comm, seconds, MPI_MAX, MPI_DOUBLE); }
double total(MPI_Comm comm, double value) { return reduce(comm, value, MPI_SUM, MPI_DOUBLE); }

struct Settings {
  MPI_Comm comm;
  int rank, ranks;
  double fluid, load;
  int steps;
  std::string spec, out, trace;
  mps::DistributedOptions options;
  bool per_rank = false;
};

template <int D>
int measure(mps::BasicSimulation<D>& sim, const mps::BasicRankExchange<D>& exchange, std::size_t scene_size,
            const Settings& set);

int run(int argc, char** argv) {
  Settings set{MPI_COMM_WORLD, 0, 1, 1e5, -1.0, 5, "hypre-pcg:tol=1e-8", "", "", {}};
  MPI_Comm_rank(set.comm, &set.rank);
  MPI_Comm_size(set.comm, &set.ranks);

  CLI::App app("The MPS step on P ranks: per-step phase times, halo volume, messages and migrations");
  int dim = 2;
  double l0 = 0.0;
  app.add_option("--dim", dim, "2: the classic column; 3: SPHERIC Test 2 (a column hitting a box)")
      ->check(CLI::IsMember({2, 3}));
  app.add_option("--fluid", set.fluid, "fluid particles of the dam-break column (about)")->check(CLI::Range(1e2, 1e8));
  app.add_option("--l0", l0, "the spacing instead of --fluid [m]")->check(CLI::PositiveNumber);
  app.add_option("--steps", set.steps, "steps timed, after one untimed")->check(CLI::Range(1, 10000));
  app.add_option("--solver", set.spec, "solver spec (hypre-pcg or hypre-amg on more than one rank)");
  app.add_option("--out", set.out, "CSV file to append the row to (header written when the file is new)");
  app.add_option("--threshold", set.options.rebalance_threshold,
                 "new RCB cuts when the largest rank holds more than this times the mean (1: every step; inf: never)");
  std::vector<double> weights;
  app.add_option("--kind-weights", weights, "the load of a fluid, wall, dummy and ghost particle the cuts balance "
                 "(default: the app's: every kind 1 in 2-D, dambreak::box_impact_kind_weights in 3-D)")->expected(4);
  app.add_option("--migrate-every", set.options.migrate_every,
                 "steps between placements and migrations (1: every step; default the library's)")
      ->check(CLI::Range(1, 1000000));
  app.add_flag("--per-rank", set.per_rank, "print each rank's particles and phase times (to stderr)");
  app.add_option("--trace", set.trace, "CSV file to write one row per step to (imbalance, repartitions, migrations)");
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e);
  }
  if (dim == 3) set.options.kind_weights = dambreak::box_impact_kind_weights;  // the app's
  if (!weights.empty()) std::copy(weights.begin(), weights.end(), set.options.kind_weights.begin());
  set.load = set.rank == 0 ? load_average() : -1.0;
  const int fortran_comm = static_cast<int>(MPI_Comm_c2f(set.comm));

  if (dim == 3) {
    dambreak::Params p = dambreak::box_impact_defaults();
    const dambreak::BoxImpactSize z;
    p.l0 = l0 > 0 ? l0 : std::cbrt(z.column_length * z.tank_width * z.column_height / set.fluid);
    p.solver = set.spec;
    const dambreak::BoxImpactGeometry g = dambreak::box_impact_geometry(p.l0);
    const mps::Particles3 scene = dambreak::make_box_impact_particles(g, p.l0);
    auto exchange = std::make_unique<mps::RankExchange3>(fortran_comm, set.options);
    const mps::RankExchange3& ranks_exchange = *exchange;
    mps::Simulation3 sim(scene, dambreak::box_impact_domain(g, p.l0), dambreak::make_config(p, 3), std::move(exchange));
    dambreak::add_box_impact_components(sim, p, g);
    return measure<3>(sim, ranks_exchange, scene.size(), set);
  }
  // The classic column is a wide and 2a high: a / l0 = sqrt(fluid / 2) particles across.
  dambreak::Params p = dambreak::defaults(dambreak::Column::classic);
  p.l0 = l0 > 0 ? l0 : p.width / std::round(std::sqrt(set.fluid / 2.0));
  p.solver = set.spec;
  const mps::Particles scene = dambreak::make_particles(p);
  const mps::Domain domain = dambreak::make_domain(p, scene);
  auto exchange = std::make_unique<mps::RankExchange>(fortran_comm, set.options);
  const mps::RankExchange& ranks_exchange = *exchange;
  mps::Simulation sim(scene, domain, dambreak::make_config(p), std::move(exchange));
  sim.add<mps::ParticleCollision>(p.collision, p.restitution);
  sim.add<mps::AsymmetrySurface>(p.asymmetry);
  const double ceiling = domain.ymax - 2 * p.l0, top = p.tank_height, length = p.tank_length;
  sim.add<mps::RemoveEscaped>([=](double x, double y) { return y < ceiling && (y < top || (x > 0.0 && x < length)); });
  return measure<2>(sim, ranks_exchange, scene.size(), set);
}

template <int D>
int measure(mps::BasicSimulation<D>& sim, const mps::BasicRankExchange<D>& exchange, std::size_t scene_size,
            const Settings& set) {
  const MPI_Comm comm = set.comm;
  const int rank = set.rank, ranks = set.ranks, steps = set.steps;
  const double fluid = set.fluid, load = set.load;
  const std::string &spec = set.spec, &out = set.out, &trace = set.trace;
  const mps::DistributedOptions& options = set.options;
  std::ofstream trace_csv;
  if (rank == 0 && !trace.empty()) {
    trace_csv.open(trace);
    trace_csv << "ranks,fluid_target,rebalance_threshold,step,time_s,imbalance,fluid_imbalance,repartitioned,"
                 "migrated,place_s,step_s,migrate_every,hierarchy_built,setup_s,solve_s,iterations\n";
  }
  double max_fluid_imbalance = 0.0;
  // The last solve set an AMG hierarchy up (Jacobi has none).
  auto hierarchy_built = [&sim] {
    const mps::SolveReport& solve = sim.last_step().solve;
    return !solve.setup_reused && solve.backend.find("precond=jacobi") == std::string::npos;
  };
  // One row of the trace: this step's imbalance (by particles, as the partition balances, and by fluid alone).
  auto record = [&](const mps::DistributedStepStats& before, double step_seconds) {
    const mps::DistributedStepStats& now = exchange.stats();
    const double fluid_imbalance = mps::load_imbalance(sim.particles().count(mps::Kind::fluid), exchange.comm());
    max_fluid_imbalance = std::max(max_fluid_imbalance, fluid_imbalance);
    const double migrated = total(comm, static_cast<double>(now.migrated - before.migrated));
    const double place = slowest(comm, now.assign_seconds + now.repartition_seconds - before.assign_seconds -
                                           before.repartition_seconds);
    if (trace_csv.is_open())
      trace_csv << ranks << ',' << fluid << ',' << options.rebalance_threshold << ',' << now.steps << ','
                << sim.time() << ',' << now.imbalance << ',' << fluid_imbalance << ','
                << (now.repartitions - before.repartitions) << ',' << migrated << ',' << place << ','
                << step_seconds << ',' << options.migrate_every << ',' << hierarchy_built() << ','
                << sim.last_step().solve.setup_seconds << ',' << sim.last_step().solve.solve_seconds << ','
                << sim.last_step().solve.iterations << '\n';
  };
  {
    const mps::DistributedStepStats before = exchange.stats();
    const double start = MPI_Wtime();
    sim.step();
    record(before, slowest(comm, MPI_Wtime() - start));
  }
  const mps::PhaseTimes t0 = sim.times();
  const mps::DistributedStepStats s0 = exchange.stats();
  double wall = 0.0;
  int hierarchy_builds = 0;  // timed solves that set an AMG hierarchy up (Jacobi has none)
  for (int k = 0; k < steps; ++k) {
    const mps::DistributedStepStats before = exchange.stats();
    MPI_Barrier(comm);
    const double start = MPI_Wtime();
    sim.step();
    const double step_seconds = slowest(comm, MPI_Wtime() - start);
    wall += step_seconds;
    record(before, step_seconds);
    hierarchy_builds += hierarchy_built();
  }
  // The two placements alone on the last step's particles, between barriers, the slowest rank's, best of 5: new RCB
  // cuts, and the assignment of every particle to kept cuts (the step adds one MPI_Allreduce of P counts to either).
  double repartition_alone = 1e300, assign_alone = 1e300;
  {
    mps::RcbPartition partition(exchange.comm());
    for (int k = 0; k < 5; ++k) {
      MPI_Barrier(comm);
      double start = MPI_Wtime();
      (void)partition.repartition(sim.particles());
      repartition_alone = std::min(repartition_alone, slowest(comm, MPI_Wtime() - start));
      MPI_Barrier(comm);
      start = MPI_Wtime();
      (void)partition.assign(sim.particles());
      assign_alone = std::min(assign_alone, slowest(comm, MPI_Wtime() - start));
    }
  }
  const mps::PhaseTimes& t = sim.times();
  // Each rank's own phases: a phase that ends in a collective holds the wait for the slowest rank.
  if (set.per_rank)
    std::fprintf(stderr,
                 "rank %d owns %zu particles, %zu fluid, %zu wall, %zu dummy, %zu ghost: neighbours %.4f, predict "
                 "%.4f, assemble %.4f, AMG setup %.4f, solve %.4f, correct %.4f s per step\n",
                 set.rank, sim.particles().size(), sim.particles().count(mps::Kind::fluid),
                 sim.particles().count(mps::Kind::wall), sim.particles().count(mps::Kind::dummy),
                 sim.particles().count(mps::Kind::ghost),
                 (t.neighbors - t0.neighbors) / steps, (t.predict - t0.predict) / steps,
                 (t.assemble - t0.assemble) / steps, (t.solver_setup - t0.solver_setup) / steps,
                 (t.solve - t0.solve) / steps, (t.correct - t0.correct) / steps);
  const mps::DistributedStepStats& s = exchange.stats();
  const double n = steps;
  const double migrate = slowest(comm, s.migrate_seconds - s0.migrate_seconds) / n;
  const double halo = slowest(comm, s.halo_seconds - s0.halo_seconds) / n;
  const double neighbors = slowest(comm, t.neighbors - t0.neighbors) / n;
  const double predict = slowest(comm, t.predict - t0.predict) / n;
  const double assemble = slowest(comm, t.assemble - t0.assemble) / n;
  const double setup = slowest(comm, t.solver_setup - t0.solver_setup) / n;
  const double solve = slowest(comm, t.solve - t0.solve) / n;
  const double correct = slowest(comm, t.correct - t0.correct) / n;
  const auto copies = static_cast<double>(s.halo_copies - s0.halo_copies) / n;
  const double copies_max = slowest(comm, copies), copies_sum = total(comm, copies);
  const double messages_sum = total(comm, static_cast<double>(s.messages_sent - s0.messages_sent) / n);
  const double bytes_sum = total(comm, static_cast<double>(s.bytes_sent - s0.bytes_sent) / n);
  const double migrated_sum = total(comm, static_cast<double>(s.migrated - s0.migrated) / n);
  const double owned_max = slowest(comm, static_cast<double>(sim.particles().size()));
  const double fluid_count = total(comm, static_cast<double>(sim.particles().count(mps::Kind::fluid)));
  const std::size_t repartitions = s.repartitions - s0.repartitions;
  const std::size_t assignments = (s.placements - s0.placements) - repartitions;
  // Per placement, of the steps that made one: an assignment to the kept boxes, and new cuts.
  const double assign_total = slowest(comm, s.assign_seconds - s0.assign_seconds);
  const double repartition_total = slowest(comm, s.repartition_seconds - s0.repartition_seconds);
  const double assign = assignments ? assign_total / static_cast<double>(assignments) : 0.0;
  const double repartition = repartitions ? repartition_total / static_cast<double>(repartitions) : 0.0;
  if (rank != 0) return 0;

  std::cout << ranks << " rank(s), " << D << "-D, " << scene_size << " particles (" << fluid_count << " fluid), load " << load
            << ": " << wall / n << " s per step (migrate " << migrate << ", halo " << halo << ", neighbours "
            << neighbors << ", predict " << predict << ", assemble " << assemble << ", AMG setup " << setup
            << ", solve " << solve << ", correct " << correct << "); halo copies " << copies_max << " (largest rank), "
            << messages_sum << " messages and " << bytes_sum << " bytes a step, " << migrated_sum
            << " migrated a step, " << sim.last_step().solve.iterations << " iterations; threshold "
            << options.rebalance_threshold << ": " << repartitions << " repartitions (" << repartition
            << " s each), assignment to the kept cuts " << assign << " s, largest imbalance " << s.max_imbalance
            << " (fluid alone " << max_fluid_imbalance << "); migrations every " << options.migrate_every << " steps, "
            << hierarchy_builds << " AMG set-ups in " << steps << " steps; alone, new cuts " << repartition_alone
            << " s, assignment to kept cuts " << assign_alone << " s\n";
  if (!out.empty()) {
    const std::string header =
        "ranks,omp_threads,loadavg_1min,particles,fluid,owned_max,solver,steps,step_s,migrate_s,halo_s,"
        "neighbors_s,predict_s,assemble_s,setup_s,solve_s,correct_s,iterations,halo_copies_max,halo_copies_sum,"
        "messages_per_step,bytes_per_step,migrated_per_step,rebalance_threshold,repartitions,max_imbalance,assign_s,"
        "repartition_s,dimensions,kind_weights,migrate_every,hierarchy_builds";
    const bool fresh = !std::filesystem::exists(out);
    if (!fresh) {
      std::string existing;
      std::getline(std::ifstream(out) >> std::ws, existing);
      if (existing != header)
        throw std::runtime_error(out + " has other columns than this bench writes; give a new file");
    }
    std::ofstream csv(out, std::ios::app);
    if (fresh) csv << header << '\n';
    const char* threads = std::getenv("OMP_NUM_THREADS");
    // The spec quoted as CSV quotes a field (its keys are separated by commas), a quote in it doubled.
    std::string quoted = "\"";
    for (const char c : spec) quoted += c == '"' ? std::string("\"\"") : std::string(1, c);
    quoted += '"';
    csv << ranks << ',' << (threads ? threads : "") << ',' << load << ',' << scene_size << ',' << fluid_count << ','
        << owned_max << ',' << quoted << ',' << steps << ',' << wall / n << ',' << migrate << ',' << halo << ','
        << neighbors << ',' << predict << ',' << assemble << ',' << setup << ',' << solve << ',' << correct << ','
        << sim.last_step().solve.iterations << ',' << copies_max << ',' << copies_sum << ',' << messages_sum << ','
        << bytes_sum << ',' << migrated_sum << ',' << options.rebalance_threshold << ',' << repartitions << ','
        << s.max_imbalance << ',' << assign << ',' << repartition << ',' << D << ',' << options.kind_weights[0] << ' '
        << options.kind_weights[1] << ' ' << options.kind_weights[2] << ' ' << options.kind_weights[3] << ','
        << options.migrate_every << ',' << hierarchy_builds << '\n';
  }
  return 0;
}

}  // namespace

int main(int argc, char** argv) { return run_under_mpi(argc, argv, "bench_distributed_step", run); }
