// Checkpoint and restart on MPI ranks (docs/restart.md), run by ctest under mpirun on 1, 2 and 3 ranks: the classic
// dam break with a kept AMG hierarchy. Restored on as many ranks, the run repeats the uninterrupted one bitwise;
// restored on one process from the ranks' checkpoint, and on the ranks from one process's, it agrees within the
// bounds the distributed step's own tests hold it to against a serial run.
#include <gtest/gtest.h>
#include <mpi.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <memory>
#include <string>
#include <vector>

#include <unistd.h>

#include "column.hpp"
#include "mpi_test.hpp"
#include "mps/io/io.hpp"
#include "mps/parallel/rank_exchange.hpp"
#include "mps/step/components.hpp"

using mpi_test::comm;
using mpi_test::kComm;
using mpi_test::rank;
using mpi_test::ranks;

namespace {

// AMG kept for 50 solves: only the steps before a placement (every 20th) are exact.
const std::string kSolver = "hypre-pcg:reuse=50,tol=1e-10";
constexpr int kCheckpointStep = 20, kSteps = 35;
// As tests/mpi/test_distributed_step.cpp bounds a distributed run against a serial one (there over 100 steps).
constexpr double kPositionBound = 2e-7;  // in l0
constexpr double kPressureBound = 2e-7;  // relative to the largest |p|

dambreak::Params params() {
  dambreak::Params p = dambreak::defaults(dambreak::Column::classic);
  p.l0 = p.width / 20;
  p.tank_length = 4 * p.width;
  p.solver = kSolver;
  return p;
}

// The scene on the ranks (distributed) or on this process alone.
std::unique_ptr<mps::Simulation> build(bool distributed) {
  const dambreak::Params p = params();
  mps::Particles particles = dambreak::make_particles(p);
  const mps::Domain domain = dambreak::make_domain(p, particles);
  mps::SimulationConfig config = dambreak::make_config(p);
  std::unique_ptr<mps::Simulation> sim;
  if (distributed) {
    sim = std::make_unique<mps::Simulation>(std::move(particles), domain, config,
                                            std::make_unique<mps::RankExchange>(comm()));
  } else {
    mps::SolverContext self;
    self.mpi_comm = static_cast<int>(MPI_Comm_c2f(MPI_COMM_SELF));
    sim = std::make_unique<mps::Simulation>(std::move(particles), domain, config, mps::make_solver(kSolver, self));
  }
  const double ceiling = domain.ymax - 2 * p.l0, top = p.tank_height, length = p.tank_length;
  dambreak::add_dam_break_components<2>(*sim, p, [=](const mps::Vec<2>& r) {
    return r[1] < ceiling && (r[1] < top || (r[0] > 0.0 && r[0] < length));
  });
  return sim;
}

// Every particle on rank 0, in id order (empty elsewhere).
mps::Particles gathered(const mps::Simulation& sim) {
  const auto* exchange = dynamic_cast<const mps::RankExchange*>(&sim.exchange());
  mps::Particles all = exchange ? exchange->gather(sim.particles()) : sim.particles();
  std::vector<int> by_id(all.size());
  for (std::size_t i = 0; i < all.size(); ++i) by_id[static_cast<std::size_t>(all.id[i])] = static_cast<int>(i);
  all.permute(by_id);
  return all;
}

std::filesystem::path shared_file(const std::string& name) {
  // One name for every rank: rank 0's process id, broadcast.
  int pid = static_cast<int>(::getpid());
  MPI_Bcast(&pid, 1, MPI_INT, 0, kComm);
  return std::filesystem::temp_directory_path() / ("sparsemps_restart_ranks_" + std::to_string(pid) + "_" + name);
}

// The checkpoint of a run at kCheckpointStep, written by rank 0, and the run's particles at kSteps (on rank 0).
mps::Particles run_with_checkpoint(mps::Simulation& sim, const std::filesystem::path& file) {
  while (sim.last_step().step < kSteps) {
    sim.step();
    if (sim.last_step().step == kCheckpointStep) {
      EXPECT_TRUE(sim.checkpoint_exact());
      const nlohmann::json state = sim.checkpoint();  // collective: rank 0 gets every rank's part
      if (!state.is_null()) mps::write_checkpoint(file, state);
    }
  }
  return gathered(sim);
}

void expect_close(const mps::Particles& run, const mps::Particles& reference, double l0, const char* what) {
  ASSERT_EQ(run.size(), reference.size()) << what;
  EXPECT_EQ(run.id, reference.id) << what;
  double position = 0, pressure = 0, largest = 0;
  for (std::size_t i = 0; i < run.size(); ++i) {
    if (reference.kind[i] == mps::Kind::ghost) continue;
    position = std::max({position, std::abs(run.x[i] - reference.x[i]), std::abs(run.y[i] - reference.y[i])});
    pressure = std::max(pressure, std::abs(run.p[i] - reference.p[i]));
    largest = std::max(largest, std::abs(reference.p[i]));
  }
  std::printf("%s: positions within %.2g l0, pressures within %.2g of the largest\n", what, position / l0,
              pressure / largest);
  EXPECT_LT(position, kPositionBound * l0) << what;
  EXPECT_LT(pressure, kPressureBound * largest) << what;
  EXPECT_GT(largest, 500.0) << what;  // a flow, not water at rest
}

}  // namespace

TEST(RestartOnRanks, AsManyRanksContinueBitwise) {
  const auto file = shared_file("same.cbor");
  auto whole = build(true);
  const mps::Particles uninterrupted = run_with_checkpoint(*whole, file);
  MPI_Barrier(kComm);
  auto resumed = build(true);
  resumed->restore(mps::read_checkpoint(file));  // every rank reads the whole checkpoint and takes its part
  EXPECT_EQ(resumed->last_step().step, kCheckpointStep);
  while (resumed->last_step().step < kSteps) resumed->step();
  const mps::Particles after = gathered(*resumed);
  if (rank() == 0) {
    ASSERT_EQ(after.size(), uninterrupted.size());
    EXPECT_EQ(after.x, uninterrupted.x);
    EXPECT_EQ(after.y, uninterrupted.y);
    EXPECT_EQ(after.u, uninterrupted.u);
    EXPECT_EQ(after.v, uninterrupted.v);
    EXPECT_EQ(after.p, uninterrupted.p);
    EXPECT_EQ(whole->time(), resumed->time());
    std::filesystem::remove(file);
  }
}

// The ranks' checkpoint restored on one process, and one process's on the ranks: the particles are distributed
// afresh, so the sums run in another order, and the runs agree within the distributed step's bounds.
TEST(RestartOnRanks, AnotherRankCountAgreesWithinTheSolversTolerance) {
  const double l0 = params().l0;
  const auto from_ranks = shared_file("ranks.cbor"), from_one = shared_file("one.cbor");
  auto whole = build(true);
  const mps::Particles on_ranks = run_with_checkpoint(*whole, from_ranks);
  mps::Particles serial_whole;
  if (rank() == 0) {
    auto serial = build(false);
    serial_whole = run_with_checkpoint(*serial, from_one);
  }
  MPI_Barrier(kComm);
  if (rank() == 0) {  // P ranks -> 1 process
    auto resumed = build(false);
    resumed->restore(mps::read_checkpoint(from_ranks));
    while (resumed->last_step().step < kSteps) resumed->step();
    expect_close(gathered(*resumed), on_ranks, l0, "restarted on 1 process from the ranks' checkpoint");
  }
  auto resumed = build(true);  // 1 process -> P ranks
  resumed->restore(mps::read_checkpoint(from_one));
  while (resumed->last_step().step < kSteps) resumed->step();
  const mps::Particles after = gathered(*resumed);
  if (rank() == 0) {
    expect_close(after, serial_whole, l0, "restarted on the ranks from one process's checkpoint");
    std::filesystem::remove(from_ranks);
    std::filesystem::remove(from_one);
  }
}
