// The distributed PPE (mps/parallel/distributed.hpp) on P ranks: a square tank with a free surface, built on rank 0, distributed
// by Zoltan RCB, given its halo, its PPE assembled per rank and solved by hypre on the communicator. Times each phase
// (the slowest rank's, between barriers) and records the halo's volume and messages per exchange. One CSV row per
// run, appended; run it under mpirun for each P:
//
//   OMP_NUM_THREADS=1 mpirun -np 2 bench_distributed_ppe --fluid 1e6 --out bench/results/distributed_ppe.csv
#include <mpi.h>

#include <CLI/CLI.hpp>
#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <memory>
#include <sstream>
#include <random>
#include <string>
#include <vector>

#include "mpi_bench.hpp"
#include "mps/boundaries/geometry.hpp"
#include "mps/core/kernel.hpp"
#include "mps/core/neighbors.hpp"
#include "mps/numerics/operators.hpp"
#include "mps/numerics/ppe.hpp"
#include "mps/parallel/distributed.hpp"
#include "mps/solvers/solver.hpp"

namespace {

constexpr double kL0 = 0.01;

// The slowest rank's time of f, all ranks starting together.
template <class F>
double timed(MPI_Comm comm, F&& f) {
  MPI_Barrier(comm);
  const double t0 = MPI_Wtime();
  f();
  double t = MPI_Wtime() - t0;
  MPI_Allreduce(MPI_IN_PLACE, &t, 1, MPI_DOUBLE, MPI_MAX, comm);
  return t;
}


int run(int argc, char** argv) {
  const MPI_Comm comm = MPI_COMM_WORLD;
  const int handle = static_cast<int>(MPI_Comm_c2f(comm));
  int rank = 0, ranks = 1;
  MPI_Comm_rank(comm, &rank);
  MPI_Comm_size(comm, &ranks);

  CLI::App app("The distributed PPE on P ranks: phases timed, halo volume and messages recorded");
  double fluid = 1e5;
  int repeats = 3;
  std::string spec = "hypre-pcg:tol=1e-8", out;
  app.add_option("--fluid", fluid, "fluid particles (a square block, about)")->check(CLI::Range(1e2, 1e8));
  app.add_option("--solver", spec, "solver spec (hypre-pcg or hypre-amg on more than one rank)");
  app.add_option("--repeats", repeats, "solves timed (from zero pressure each); the median is reported")
      ->check(CLI::Range(1, 100));
  app.add_option("--out", out, "CSV file to append the row to (header written when the file is new)");
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e);
  }

  const double load = rank == 0 ? load_average() : -1.0;

  // A square tank: side sqrt(fluid) l0, walls on three sides, the fluid jittered and stirred from a fixed seed.
  const double side = std::round(std::sqrt(fluid)) * kL0;
  const mps::Domain domain{-0.1, side + 0.1, -0.1, 1.2 * side + 0.1};
  mps::Particles p;
  if (rank == 0) {
    mps::fill_rectangle(p, {0, 0, side, side}, kL0, mps::Kind::fluid);
    mps::add_rectangle_walls(p, {0, 0, side, 1.1 * side}, kL0, mps::left | mps::right | mps::bottom, 1, 3);
    std::mt19937 rng(2701);
    std::uniform_real_distribution<double> jitter(-0.05 * kL0, 0.05 * kL0), speed(-0.01, 0.01);
    for (std::size_t i = 0; i < p.size(); ++i) {
      if (p.kind[i] != mps::Kind::fluid) continue;
      p.x[i] += jitter(rng);
      p.y[i] += jitter(rng);
      p.u[i] = speed(rng);
      p.v[i] = speed(rng);
    }
  }
  const long long particles = reduce<long long>(comm, static_cast<long long>(p.size()), MPI_SUM, MPI_LONG_LONG);

  mps::ExchangeStats migration;
  const double t_distribute = timed(comm, [&] { migration = mps::distribute_particles(p, handle); });
  const mps::Kernel lap = mps::make_kernel(4.1, kL0), small = mps::make_kernel(2.1, kL0);
  std::unique_ptr<mps::Halo> halo;
  const double t_halo = timed(comm, [&] { halo = std::make_unique<mps::Halo>(p, domain, lap.re, handle); });
  mps::NeighborList near, close;
  const double t_neighbors = timed(comm, [&] {
    near = mps::find_neighbors(p, domain, lap.re);
    close = mps::restrict_radius(near, p, domain, small.re);
  });
  std::vector<char> surface;
  std::vector<double> source;
  const double t_fields = timed(comm, [&] {
    const std::vector<double> n_small = mps::number_density({p, domain, close, small});
    surface = mps::detect_free_surface(p, n_small, small.n0, 0.97, &close, small.lattice_neighbors, 0.85);
    const std::vector<double> n = mps::number_density({p, domain, near, lap});
    std::vector<double> div(p.size());
    mps::divergence({p, domain, near, lap}, p.u, p.v, div);
    source = mps::mixed_source(n, lap.n0, div, 1000.0, 1e-3, 0.5);
  });
  mps::DistributedPpe ppe;
  const double t_assemble =
      timed(comm, [&] { ppe = mps::assemble_distributed_ppe(*halo, {p, domain, near, lap}, surface, source); });
  // One refresh of a double field: what each exchange of the step moves.
  std::vector<double> field(p.size(), 1.0);
  const double t_refresh = timed(comm, [&] { halo->refresh(std::span<double>(field)); });

  mps::SolverContext context;
  context.mpi_comm = handle;
  const auto solver = mps::make_solver(spec, context);
  std::vector<double> setup, solve, total;
  mps::SolveReport report;
  for (int k = 0; k < repeats; ++k) {
    std::fill(p.p.begin(), p.p.end(), 0.0);
    total.push_back(timed(comm, [&] { report = mps::solve_distributed_ppe(*halo, ppe, *solver, p); }));
    setup.push_back(reduce(comm, report.setup_seconds, MPI_MAX, MPI_DOUBLE));
    solve.push_back(reduce(comm, report.solve_seconds, MPI_MAX, MPI_DOUBLE));
  }
  auto median = [](std::vector<double> v) {
    std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(v.size() / 2), v.end());
    return v[v.size() / 2];
  };

  const auto copies = static_cast<long long>(halo->copies());
  const long long copies_max = reduce(comm, copies, MPI_MAX, MPI_LONG_LONG);
  const long long copies_sum = reduce(comm, copies, MPI_SUM, MPI_LONG_LONG);
  const int messages_max = reduce(comm, halo->last_refresh().messages_sent, MPI_MAX, MPI_INT);
  const int messages_sum = reduce(comm, halo->last_refresh().messages_sent, MPI_SUM, MPI_INT);
  const auto bytes = static_cast<long long>(halo->last_refresh().bytes_sent);
  const long long bytes_sum = reduce(comm, bytes, MPI_SUM, MPI_LONG_LONG);
  const auto owned = static_cast<long long>(halo->owned());
  const long long owned_max = reduce(comm, owned, MPI_MAX, MPI_LONG_LONG);
  const auto rows = static_cast<long long>(ppe.rows());
  const long long rows_max = reduce(comm, rows, MPI_MAX, MPI_LONG_LONG);
  const auto migrated = static_cast<long long>(migration.particles_sent);
  const long long migrated_sum = reduce(comm, migrated, MPI_SUM, MPI_LONG_LONG);

  if (rank == 0) {
    const char* threads = std::getenv("OMP_NUM_THREADS");
    const std::string header =
        "ranks,omp_threads,loadavg_1min,particles,unknowns,owned_max,rows_max,solver,iterations,relative_residual,"
        "distribute_s,halo_setup_s,neighbors_s,fields_s,assemble_s,refresh_s,setup_s,solve_s,ppe_total_s,"
        "halo_copies_max,halo_copies_sum,refresh_messages_max,refresh_messages_sum,refresh_bytes_sum,migrated_sum";
    std::ostringstream row;
    row << ranks << "," << (threads ? threads : "") << "," << load << "," << particles << "," << ppe.global_rows << "," << owned_max
        << "," << rows_max << "," << spec << "," << report.iterations << "," << report.relative_residual << ","
        << t_distribute << "," << t_halo << "," << t_neighbors << "," << t_fields << "," << t_assemble << ","
        << t_refresh << "," << median(setup) << "," << median(solve) << "," << median(total) << "," << copies_max
        << "," << copies_sum << "," << messages_max << "," << messages_sum << "," << bytes_sum << "," << migrated_sum;
    std::cout << header << "\n" << row.str() << std::endl;
    if (!out.empty()) {
      const bool fresh = !std::filesystem::exists(out);
      std::ofstream file(out, std::ios::app);
      if (fresh) file << header << "\n";
      file << row.str() << "\n";
    }
  }
  return 0;
}

}  // namespace

int main(int argc, char** argv) { return run_under_mpi(argc, argv, "bench_distributed_ppe", run); }
