// The MPS step on 1, 2 and 3 ranks (mps/parallel/rank_exchange.hpp) against the same scene run serially in the same
// process, run by ctest under mpirun. Every rank builds the scene; the distributed run's particles are gathered by
// id on rank 0 and compared with rank 0's serial run (mps::Simulation, the same solver spec on MPI_COMM_SELF).
#include <gtest/gtest.h>
#include <mpi.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <functional>
#include <limits>
#include <memory>
#include <random>
#include <stdexcept>
#include <string>
#include <vector>

#include "channel.hpp"
#include "column.hpp"
#include "mpi_test.hpp"
#include "mps/boundaries/geometry.hpp"
#include "mps/core/vec.hpp"
#include "mps/parallel/rank_exchange.hpp"
#include "mps/solvers/solver.hpp"
#include "mps/step/components.hpp"
#include "tank.hpp"

using mpi_test::comm;
using mpi_test::kComm;
using mpi_test::rank;
using mpi_test::ranks;

namespace {

constexpr int kSteps = 100;
// hypre-pcg to a relative residual of 1e-10 each step. A solve's pressure error is at most cond(A) x tol of the
// largest pressure, ~1e-7 for these PPEs (cond(A) up to ~1e3 at these sizes). The velocity correction dt/rho grad(dp)
// then moves a particle by dt^2/rho dp/l0 a step: 2e-9 l0 for the dam break's dt = 6e-4 s and 2,600 Pa. Over 100
// steps that adds to 2e-7 l0, and positions that far apart change pressures by about as much: the bounds are 2e-7
// for both. Measured 1e-11 to 1e-10; a copy left stale breaks them (the free-surface flags: 1e-2 l0; the
// predictor's r*, u* with a viscosity that matters: 2.8e-6 l0).
const std::string kSolver = "hypre-pcg:tol=1e-10";
constexpr double kPositionBound = 2e-7;  // in l0
constexpr double kPressureBound = 2e-7;  // relative to the largest |p| of the serial run


template <int D>
struct BasicScene {
  mps::BasicParticles<D> particles;
  mps::BasicDomain<D> domain;
  mps::SimulationConfig config;
  // The components the scene adds (the dam break's collisions, asymmetry test and spray removal).
  std::function<void(mps::BasicSimulation<D>&, const BasicScene&)> add_components = nullptr;
  double ceiling = 0, top = 0, length = 0;
};
using Scene = BasicScene<2>;

// A 20 x 20 liquid at rest under gravity in a walled tank (apps/hydrostatic's scene, 0.2 m). Positions jittered by 1 %
// of l0 (a fixed seed) so that the PPE has a right-hand side to solve: on the exact lattice the hydrostatic split
// makes it zero and the comparison would be of zeros. Not 5 %: that start's transient amplifies round-off so much
// that the serial run alone, with its particles in cell order instead of id order, moved pressures by 1.4e-5 of the
// largest in 100 steps; the comparison would then measure that sensitivity, not the decomposition.
Scene hydrostatic_tank() {
  tank::Params p;
  p.width = 0.2;
  p.water_height = 0.2;
  p.solver = kSolver;
  Scene s{tank::make_particles(p), tank::make_domain(p), tank::make_config(p)};
  std::mt19937 rng(27);
  std::uniform_real_distribution<double> jitter(-0.01 * p.l0, 0.01 * p.l0);
  for (std::size_t i = 0; i < s.particles.size(); ++i)
    if (s.particles.kind[i] == mps::Kind::fluid) {
      s.particles.x[i] += jitter(rng);
      s.particles.y[i] += jitter(rng);
    }
  return s;
}

// The classic dam break (a = 0.146 m, 20 particles across) as apps/dambreak builds it, shifting included. A large
// viscosity and shifting coefficient make a stale copy after the predictor or the corrector show beyond the bound;
// at water's and the app's they hide within it (measured in docs/scaling.md, "What the comparison catches").
Scene dam_break(double nu, double shifting) {
  dambreak::Params p = dambreak::defaults(dambreak::Column::classic);
  // The tank and spacing of the test's making (4a, a/20): 100 steps in seconds, and the column's particles cross the
  // ranks' cuts within them (in the default 8a tank at a/40 none migrated).
  p.l0 = p.width / 20;
  p.tank_length = 4 * p.width;
  p.solver = kSolver;
  p.shifting = shifting;
  Scene s{dambreak::make_particles(p), {}, dambreak::make_config(p)};
  s.config.nu = nu;
  s.domain = dambreak::make_domain(p, s.particles);
  s.top = p.tank_height;
  s.length = p.tank_length;
  s.ceiling = s.domain.ymax - 2 * p.l0;
  s.add_components = [](mps::Simulation& sim, const Scene& scene) {
    const dambreak::Params d = dambreak::defaults(dambreak::Column::classic);
    if (d.collision > 0) sim.add<mps::ParticleCollision>(d.collision, d.restitution);  // as add_dam_break_components
    if (d.asymmetry > 0) sim.add<mps::AsymmetrySurface>(d.asymmetry);
    const double ceiling = scene.ceiling, top = scene.top, length = scene.length;
    sim.add<mps::RemoveEscaped>([=](double x, double y) { return y < ceiling && (y < top || (x > 0.0 && x < length)); });
  };
  return s;
}

// The inlet channel of apps/poiseuille (pushing plate, ghost pool, outflow buffer, mirror walls), 10 particles across
// and 3 D long: on 3 ranks the cut nearest the plate falls within the kernels' reach of the columns it adds, so their
// copies must be sent within the step (Halo::add_activated). The runs' plates (serial on rank 0, then distributed)
// are kept for their counts.
struct Channel {
  poiseuille::Params params;
  std::shared_ptr<std::vector<std::shared_ptr<mps::PushingPlate>>> plates =
      std::make_shared<std::vector<std::shared_ptr<mps::PushingPlate>>>();
};

Channel inlet_channel_params() {
  Channel c;
  c.params.mode = poiseuille::Mode::inlet;
  c.params.across = 10;
  c.params.length_D = 3;
  c.params.station_D = 1;
  c.params.solver = kSolver;
  return c;
}

Scene inlet_channel(const Channel& channel) {
  const poiseuille::Params& p = channel.params;
  Scene s{poiseuille::make_particles(p), poiseuille::make_domain(p), poiseuille::make_config(p)};
  // Three more ghosts at each of the pool's places behind the plate: their weight brings the first RCB cut within
  // the kernels' reach of the new columns on 3 ranks (about 3 l0 from the plate), while the two parts beside the
  // other cut stay longer than the channel is high (else RCB cuts along the channel and splits the plate).
  const std::size_t scene_size = s.particles.size();
  for (int copy = 0; copy < 3; ++copy)
    for (std::size_t i = 0; i < scene_size; ++i)
      if (s.particles.kind[i] == mps::Kind::ghost)
        s.particles.add(s.particles.x[i], s.particles.y[i], mps::Kind::ghost, 0);
  s.add_components = [p, plates = channel.plates](mps::Simulation& sim, const Scene& scene) {
    plates->push_back(poiseuille::add_components(p, scene.particles, sim));
  };
  return s;
}

struct Comparison {
  double max_position_l0 = 0;     // largest |r - r_serial| / l0 over all particles, at the end
  double max_pressure_rel = 0;    // largest |p - p_serial| / max |p_serial|, at the end
  double largest_pressure = 0;    // max |p_serial| [Pa]
  int steps_with_unequal_dt = 0;  // steps where some rank took another dt than rank 0
  int steps_with_lost_particles = 0;  // steps after which the ranks held other than the scene's count
  std::size_t migrated = 0;       // particles sent between ranks over the run, all ranks
  std::size_t repartitions = 0;   // new cuts at the start of a step (the same count on every rank)
  double max_imbalance = 0;       // the largest rank's particles over the mean, worst step
  double max_kept_imbalance = 0;  // the same had the cuts been kept every step
  int wrong_decisions = 0;        // steps that repartitioned at or below the threshold, or kept the cuts above it
  int steps_placed_off_schedule = 0;    // steps that placed the particles though not due, or did not though due
  int steps_migrated_off_schedule = 0;  // steps between placements that moved particles between ranks
  std::size_t activated_copies = 0;  // copies sent within a step of particles turned from ghosts to fluid, all ranks
  std::size_t ghosts_moved = 0;   // ghosts sent to their box's rank between placements, all ranks
  bool same_ids = false;          // the gathered ids are exactly the serial run's
  int reused_setups = 0;          // solves of the distributed run on a hierarchy kept from an earlier step
  int steps_with_held_rows = 0;   // steps whose PPE held rows not solved for (PpeRows::every_particle)
};

// The serial run (rank 0 only), its particles in id order.
template <int D>
mps::BasicParticles<D> serial_run(const BasicScene<D>& scene) {
  mps::SolverContext self;
  self.mpi_comm = static_cast<int>(MPI_Comm_c2f(MPI_COMM_SELF));
  mps::BasicSimulation<D> serial(scene.particles, scene.domain, scene.config,
                                 mps::make_solver(scene.config.solver, self));
  if (scene.add_components) scene.add_components(serial, scene);
  for (int s = 0; s < kSteps; ++s) serial.step();
  // The serial run reorders its particles by cell; put them back in id order.
  mps::BasicParticles<D> ref = serial.particles();
  std::vector<int> by_id(ref.size());
  for (std::size_t i = 0; i < ref.size(); ++i) by_id[static_cast<std::size_t>(ref.id[i])] = static_cast<int>(i);
  ref.permute(by_id);
  return ref;
}

template <int D>
Comparison run_both(const BasicScene<D>& scene, const mps::BasicParticles<D>& ref, mps::DistributedOptions options = {}) {
  Comparison out;
  auto ranks_exchange = std::make_unique<mps::BasicRankExchange<D>>(comm(), options);
  const mps::BasicRankExchange<D>& exchange = *ranks_exchange;
  mps::BasicSimulation<D> distributed(scene.particles, scene.domain, scene.config, std::move(ranks_exchange));
  if (scene.add_components) scene.add_components(distributed, scene);
  const long long total = static_cast<long long>(scene.particles.size());
  for (int s = 0; s < kSteps; ++s) {
    const std::size_t repartitions = exchange.stats().repartitions, placements = exchange.stats().placements;
    const std::size_t migrated_before = exchange.stats().migrated;
    const mps::StepInfo& info = distributed.step();
    const double dt = info.dt;
    out.reused_setups += info.solve.setup_reused ? 1 : 0;
    long long rows = static_cast<long long>(exchange.own_rows().particle.size());
    MPI_Allreduce(MPI_IN_PLACE, &rows, 1, MPI_LONG_LONG, MPI_SUM, kComm);
    out.steps_with_held_rows += rows > static_cast<long long>(info.unknowns) ? 1 : 0;
    const mps::DistributedStepStats& stats = exchange.stats();
    const bool due = s % options.migrate_every == 0;
    out.steps_placed_off_schedule += (stats.placements > placements) != due;
    out.steps_migrated_off_schedule += !due && stats.migrated != migrated_before;
    if (due) {
      const bool renewed = stats.repartitions > repartitions;
      const bool above = stats.kept_imbalance > options.rebalance_threshold || options.rebalance_threshold <= 1.0;
      out.wrong_decisions += renewed != above || (!renewed && stats.imbalance != stats.kept_imbalance);
      out.max_kept_imbalance = std::max(out.max_kept_imbalance, stats.kept_imbalance);
    }
    double lo = dt, hi = dt;
    MPI_Allreduce(MPI_IN_PLACE, &lo, 1, MPI_DOUBLE, MPI_MIN, kComm);
    MPI_Allreduce(MPI_IN_PLACE, &hi, 1, MPI_DOUBLE, MPI_MAX, kComm);
    out.steps_with_unequal_dt += lo != hi;
    long long held = static_cast<long long>(distributed.particles().size());
    MPI_Allreduce(MPI_IN_PLACE, &held, 1, MPI_LONG_LONG, MPI_SUM, kComm);
    out.steps_with_lost_particles += held != total;
  }
  unsigned long long migrated = exchange.stats().migrated;
  MPI_Allreduce(MPI_IN_PLACE, &migrated, 1, MPI_UNSIGNED_LONG_LONG, MPI_SUM, kComm);
  out.migrated = migrated;
  out.repartitions = exchange.stats().repartitions;
  out.max_imbalance = exchange.stats().max_imbalance;
  unsigned long long activated = exchange.stats().activated_copies;
  MPI_Allreduce(MPI_IN_PLACE, &activated, 1, MPI_UNSIGNED_LONG_LONG, MPI_SUM, kComm);
  out.activated_copies = activated;
  unsigned long long ghosts = exchange.stats().ghosts_moved;
  MPI_Allreduce(MPI_IN_PLACE, &ghosts, 1, MPI_UNSIGNED_LONG_LONG, MPI_SUM, kComm);
  out.ghosts_moved = ghosts;
  const mps::BasicParticles<D> gathered = exchange.gather(distributed.particles());
  if (rank() != 0) return out;
  out.same_ids = gathered.id == ref.id;
  if (!out.same_ids) return out;
  for (std::size_t i = 0; i < ref.size(); ++i) out.largest_pressure = std::max(out.largest_pressure, std::abs(ref.p[i]));
  for (std::size_t i = 0; i < ref.size(); ++i) {
    mps::Vec<D> apart = gathered.position(i);
    for (std::size_t a = 0; a < D; ++a) apart[a] -= ref.position(i)[a];
    out.max_position_l0 = std::max(out.max_position_l0, mps::norm<D>(apart) / scene.config.l0);
    out.max_pressure_rel = std::max(out.max_pressure_rel, std::abs(gathered.p[i] - ref.p[i]) / out.largest_pressure);
  }
  return out;
}

template <int D>
Comparison expect_same_answer(const char* name, const BasicScene<D>& scene, bool particles_cross_cuts,
                              const mps::BasicParticles<D>& ref, mps::DistributedOptions options = {}) {
  const Comparison c = run_both(scene, ref, options);
  EXPECT_EQ(c.steps_with_unequal_dt, 0) << "every rank must take the same dt every step";
  EXPECT_EQ(c.steps_with_lost_particles, 0) << "the ranks together must hold every particle after every step";
  EXPECT_EQ(c.wrong_decisions, 0) << "new cuts exactly when the kept cuts' imbalance exceeds the threshold";
  EXPECT_EQ(c.steps_placed_off_schedule, 0) << "a placement every migrate_every-th step, counted from the first";
  EXPECT_EQ(c.steps_migrated_off_schedule, 0) << "no particle changes rank between placements";
  if (ranks() > 1 && particles_cross_cuts) {
    EXPECT_GT(c.migrated, 0U) << "the scene should move particles between ranks (else migration goes untested)";
  }
  if (rank() != 0) return c;
  EXPECT_TRUE(c.same_ids) << "the gathered particles must be the serial run's, each once, sorted by id";
  if (!c.same_ids) return c;
  std::printf("[ %s on %d ranks, %d steps, migrations every %d, rebalance threshold %g ] max |r - r_serial| = %.3g l0 "
              "(bound %.0e), max |p - p_serial| = %.3g of the largest %.4g Pa (bound %.0e), particles migrated %zu, "
              "repartitions %zu, max imbalance %.4f (%.4f with the cuts kept)\n",
              name, ranks(), kSteps, options.migrate_every, options.rebalance_threshold, c.max_position_l0,
              kPositionBound, c.max_pressure_rel, c.largest_pressure, kPressureBound, c.migrated, c.repartitions,
              c.max_imbalance, c.max_kept_imbalance);
  EXPECT_GT(c.largest_pressure, 0.0);
  EXPECT_LE(c.max_position_l0, kPositionBound);
  EXPECT_LE(c.max_pressure_rel, kPressureBound);
  return c;
}

// Rank 0's serial reference (empty elsewhere).
template <int D>
mps::BasicParticles<D> reference(const BasicScene<D>& scene) {
  return rank() == 0 ? serial_run(scene) : mps::BasicParticles<D>{};
}

// 3-D: a box of liquid at rest (jittered by 1 % of l0, as the 2-D tank), and a dam break: a column 0.1 x 0.2 x 0.2 m
// against one end of a 0.4 x 0.2 m tank, with collisions and the neighbour-asymmetry surface test. l0 = 0.02 m, radii
// 3.1 l0 for the source and the Laplacian.
BasicScene<3> tank_3d(bool dam_break) {
  const double l0 = 0.02, length = dam_break ? 0.4 : 0.2, width = 0.2, height = 0.2;
  BasicScene<3> s;
  mps::fill_box(s.particles, {0, 0, 0, dam_break ? 0.1 : length, width, height}, l0, mps::Kind::fluid);
  mps::add_box_walls(s.particles, {0, 0, 0, length, width, 1.5 * height}, l0,
                     mps::x_low | mps::x_high | mps::y_low | mps::y_high | mps::z_low, 1, 3);
  s.domain = {-0.1, length + 0.1, -0.1, width + 0.1, -0.1, 2 * height};
  s.config.l0 = l0;
  s.config.fz = -9.81;
  s.config.radius_density = s.config.radius_laplacian = 3.1;
  s.config.gamma = 0.01;
  s.config.dt_max = 0.2 * l0 / std::sqrt(2 * 9.81 * height);
  s.config.solver = kSolver;
  if (dam_break)
    s.add_components = [](mps::Simulation3& sim, const BasicScene<3>&) {
      sim.add<mps::ParticleCollision3>(0.8, 0.2);
      sim.add<mps::AsymmetrySurface3>(0.9);
    };
  else {
    std::mt19937 rng(27);
    std::uniform_real_distribution<double> jitter(-0.01 * l0, 0.01 * l0);
    for (std::size_t i = 0; i < s.particles.size(); ++i)
      if (s.particles.kind[i] == mps::Kind::fluid) {
        s.particles.x[i] += jitter(rng);
        s.particles.y[i] += jitter(rng);
        s.particles.z[i] += jitter(rng);
      }
  }
  return s;
}

// The 3-D core on ranks: Zoltan's RCB with three coordinates, 3-D halo boxes, the records of the field list.
TEST(DistributedStep, ThreeDimensionalTankAndDamBreakGiveTheSerialAnswer) {
  for (const bool dam_break : {false, true}) {
    const BasicScene<3> scene = tank_3d(dam_break);
    expect_same_answer(dam_break ? "3-D dam break" : "3-D tank", scene, dam_break, reference(scene));
  }
}

TEST(DistributedStep, HydrostaticTankGivesTheSerialAnswer) {
  const Scene scene = hydrostatic_tank();
  expect_same_answer("hydrostatic tank", scene, false, reference(scene));
}

// The cuts are kept while the imbalance stays at or below the threshold, and renewed when it exceeds it (every step's
// decision is checked in run_both). At 1.05 the dam break's 100 steps on 2 ranks keep the cuts throughout (measured
// 1.0324 at most, at the start; on 3 ranks 1.0508 once); at the default 1.01 a few steps renew them (the count is
// printed); at 1 every step does, as before the cuts were kept. The first two place and migrate every 20th step (the
// default), a particle that crossed a cut staying with its rank in between; the third every step. Every run gives the
// serial answer: neither the partition nor the owner enters the results.
TEST(DistributedStep, DamBreakGivesTheSerialAnswerWithKeptAndWithNewCuts) {
  const Scene scene = dam_break(1e-6, 0.5);
  const mps::Particles ref = reference(scene);
  expect_same_answer("dam break", scene, true, ref);
  mps::DistributedOptions loose;
  loose.rebalance_threshold = 1.05;
  const Comparison kept = expect_same_answer("dam break", scene, true, ref, loose);
  EXPECT_LE(kept.max_imbalance, loose.rebalance_threshold);
  if (ranks() <= 2) {
    EXPECT_EQ(kept.repartitions, 0U) << "below the threshold the cuts are kept (max imbalance " << kept.max_imbalance
                                     << ")";
  }
  mps::DistributedOptions every_step;
  every_step.rebalance_threshold = 1.0;
  every_step.migrate_every = 1;
  const Comparison renewed = expect_same_answer("dam break", scene, true, ref, every_step);
  EXPECT_EQ(renewed.repartitions, static_cast<std::size_t>(kSteps));
}

// A row for every particle on ranks (PpeRows::every_particle, which hypre-pcg with refresh=galerkin and reuse asks for):
// the free surface's particles stand alone in their rows, so the numbering holds between migrations and the kept
// hierarchy is refreshed rather than set up afresh. The serial run keeps its rows the same way. Each rank's held rows
// take their diagonal from its own solved rows, so the matrices differ from the serial one in those rows' scale only.
TEST(DistributedStep, DamBreakWithARowForEveryParticleGivesTheSerialAnswerOnAKeptHierarchy) {
  Scene scene = dam_break(1e-6, 0.5);
  scene.config.solver = "hypre-pcg:reuse=20,filter=0.2,refresh=galerkin,tol=1e-10";
  ASSERT_TRUE(mps::make_solver(scene.config.solver)->wants_fixed_rows());
  const Comparison c = expect_same_answer("dam break, a row for every particle", scene, true, reference(scene));
  if (rank() == 0) std::printf("[ kept hierarchy ] %d of %d solves reused one\n", c.reused_setups, kSteps);
  EXPECT_EQ(c.steps_with_held_rows, kSteps) << "the free surface's particles should be held rows at every step";
  // Set up afresh at the first step and at most every 20th after (reuse=20, the reordering and the placement),
  // and when iterations grow by half: measured 95 of the 100 solves on a kept hierarchy on 1, 2 and 3 ranks.
  EXPECT_GE(c.reused_setups, 85) << "the kept hierarchy should serve while the free surface moves";
}

// Where the exchanges after the predictor and after the corrector matter (see dam_break).
TEST(DistributedStep, ViscousDamBreakWithStrongShiftingGivesTheSerialAnswer) {
  const Scene scene = dam_break(1e-2, 5.0);
  expect_same_answer("viscous dam break (nu = 1e-2, shifting 5)", scene, true, reference(scene));
}

// Ghosts recycled across ranks: the columns come from the pool parked behind the plate (the lowest ids, as serially),
// and each particle leaving through the outlet is counted once, by its owner. Its ghosts reach the pool's rank at the
// next step, though particles migrate every 20th.
TEST(DistributedStep, InletChannelGivesTheSerialAnswer) {
  const Channel channel = inlet_channel_params();
  const Scene scene = inlet_channel(channel);
  const mps::Particles ref = reference(scene);  // rank 0's serial run: its plate first
  const Comparison c = expect_same_answer("inlet channel", scene, true, ref);
  const auto& plates = *channel.plates;
  ASSERT_EQ(plates.size(), rank() == 0 ? 2U : 1U);
  const mps::PushingPlate& plate = *plates.back();
  long long removed = plate.particles_removed();
  MPI_Allreduce(MPI_IN_PLACE, &removed, 1, MPI_LONG_LONG, MPI_SUM, kComm);
  if (rank() == 0)
    std::printf("[ inlet channel on %d ranks ] columns added %d, particles out through the outlet %lld, copies of new "
                "fluid sent within a step %zu, ghosts sent to the pool's rank between placements %zu\n",
                ranks(), plate.columns_added(), removed, c.activated_copies, c.ghosts_moved);
  EXPECT_GE(plate.columns_added(), 10) << "the plate should add a column every 7.5 steps";
  EXPECT_GE(removed, 100) << "the outlet should drain about as much as the plate adds";
  if (ranks() == 3) {
    EXPECT_GT(c.activated_copies, 0U) << "a cut should fall within the halo of the new columns";
  }
  if (ranks() > 1) {
    EXPECT_GT(c.ghosts_moved, 0U) << "between placements the outlet's ghosts must still reach the pool's rank";
  }
  if (rank() != 0) return;
  EXPECT_EQ(plates.front()->columns_added(), plate.columns_added());
  EXPECT_EQ(plates.front()->particles_removed(), removed) << "each particle out counted once over the ranks";
}

// A particle thrown at 1e3 m/s on the last rank after the corrector: that rank's guard trips, and every rank stops
// with its reason and keeps the state before the step.
class KickOnRank : public mps::StepComponent {
 public:
  KickOnRank(int on_rank, int at_step) : on_rank_(on_rank), at_step_(at_step) {}
  void after_corrector(mps::StepContext& c) override {
    if (rank() != on_rank_ || c.sim.last_step().step + 1 != at_step_) return;
    for (std::size_t i = 0; i < c.particles.size(); ++i)
      if (c.particles.kind[i] == mps::Kind::fluid) {
        c.particles.u[i] = 1e3;
        return;
      }
  }

 private:
  int on_rank_, at_step_;
};

TEST(DistributedStep, AGuardTrippedOnOneRankStopsEveryRankWithTheReason) {
  const Scene scene = hydrostatic_tank();
  mps::Simulation sim(scene.particles, scene.domain, scene.config, std::make_unique<mps::RankExchange>(comm()));
  const int target = ranks() - 1;
  sim.add<KickOnRank>(target, 3);
  sim.step();
  sim.step();
  int owns_fluid = sim.particles().count(mps::Kind::fluid) > 0;
  MPI_Bcast(&owns_fluid, 1, MPI_INT, target, kComm);
  ASSERT_TRUE(owns_fluid) << "the kicked rank must own fluid";
  const double time_before = sim.time();
  std::string reason;
  try {
    sim.step();
  } catch (const mps::SimulationError& e) {
    reason = e.what();
  }
  EXPECT_NE(reason.find("rank " + std::to_string(target) + " of " + std::to_string(ranks())), std::string::npos)
      << reason;
  EXPECT_NE(reason.find("velocity blow-up"), std::string::npos) << reason;
  EXPECT_EQ(sim.time(), time_before) << "the failed step is rolled back";
  EXPECT_EQ(sim.last_step().step, 2);
  if (rank() == 0) std::printf("[ guard ] %s\n", reason.c_str());
}

// Failures in the middle of a step, between two exchanges, on one rank: a non-finite position set on the last rank
// after the predictor (its halo copies carry it to the ranks next to it, whose neighbour search may meet it first),
// and an exception thrown on the last rank alone before the source. Every rank must leave the step with the message
// of the first rank that failed (not wait for the failed one forever), roll back, and step on.
class FailOnRank : public mps::StepComponent {
 public:
  FailOnRank(int on_rank, int at_step, bool nan_position) : on_rank_(on_rank), at_step_(at_step), nan_(nan_position) {}
  void after_predictor(mps::StepContext& c) override {
    if (!nan_ || !now(c)) return;
    for (std::size_t i = 0; i < c.sim.owned_particles(); ++i)
      if (c.particles.kind[i] == mps::Kind::fluid) {
        c.particles.x[i] = std::numeric_limits<double>::quiet_NaN();
        done_ = true;
        return;
      }
  }
  void before_source(mps::StepContext& c) override {
    if (nan_ || !now(c)) return;
    done_ = true;
    throw std::runtime_error("the test's failure on rank " + std::to_string(rank()) + " alone");
  }

 private:
  [[nodiscard]] bool now(const mps::StepContext& c) const {
    return rank() == on_rank_ && c.sim.last_step().step + 1 == at_step_ && !done_;
  }
  int on_rank_, at_step_;
  bool nan_, done_ = false;
};

TEST(DistributedStep, AFailureOnOneRankInTheMiddleOfAStepStopsEveryRankWithOneMessage) {
  for (const bool nan_position : {true, false}) {
    const Scene scene = hydrostatic_tank();
    mps::Simulation sim(scene.particles, scene.domain, scene.config, std::make_unique<mps::RankExchange>(comm()));
    const int target = ranks() - 1;
    sim.add<FailOnRank>(target, 2, nan_position);
    sim.step();
    int owns_fluid = sim.particles().count(mps::Kind::fluid) > 0;
    MPI_Bcast(&owns_fluid, 1, MPI_INT, target, kComm);
    ASSERT_TRUE(owns_fluid) << "the target rank must own fluid";
    const mps::Particles before = sim.particles();
    std::string reason;
    const double start = MPI_Wtime();
    try {
      sim.step();
    } catch (const mps::SimulationError& e) {
      reason = e.what();
    }
    const double seconds = MPI_Wtime() - start;
    EXPECT_NE(reason.find(nan_position ? "non-finite position" : "the test's failure on rank " +
                                                                     std::to_string(target) + " alone"),
              std::string::npos)
        << reason;
    EXPECT_NE(reason.find(" of " + std::to_string(ranks()) + " (particle numbers are that rank's)"), std::string::npos)
        << reason;
    std::string on_root = reason;
    int length = static_cast<int>(on_root.size());
    MPI_Bcast(&length, 1, MPI_INT, 0, kComm);
    on_root.resize(static_cast<std::size_t>(length));
    MPI_Bcast(on_root.data(), length, MPI_CHAR, 0, kComm);
    EXPECT_EQ(reason, on_root) << "every rank reports the same failure";
    EXPECT_EQ(sim.last_step().step, 1) << "the failed step is rolled back";
    EXPECT_EQ(sim.particles().x, before.x) << "every rank keeps its particles of before the step";
    EXPECT_EQ(sim.particles().id, before.id);
    EXPECT_EQ(sim.owned_particles(), before.size()) << "no halo copies left behind";
    EXPECT_NO_THROW(sim.step()) << "the rolled-back state steps on (the failure comes once)";
    EXPECT_EQ(sim.last_step().step, 2);
    if (rank() == 0)
      std::printf("[ failure mid-step ] every rank stopped in %.3f s: %s\n", seconds, reason.c_str());
  }
}

TEST(DistributedStep, RefusesWhatDoesNotRunDistributedYet) {
  Scene scene = hydrostatic_tank();
  auto message = [&](const Scene& s) {
    try {
      mps::Simulation sim(s.particles, s.domain, s.config, std::make_unique<mps::RankExchange>(comm()));
    } catch (const std::invalid_argument& e) {
      return std::string(e.what());
    }
    return std::string();
  };
  Scene periodic = scene;
  periodic.domain.periodic_x = true;
  EXPECT_NE(message(periodic).find("periodic domain"), std::string::npos);
  Scene implicit = scene;
  implicit.config.implicit_viscosity = true;
  EXPECT_NE(message(implicit).find("implicit viscosity"), std::string::npos);
  // A component added after construction is refused at the next step, before anything moves.
  {
    mps::Simulation sim(scene.particles, scene.domain, scene.config, std::make_unique<mps::RankExchange>(comm()));
    mps::CellGrid grid(scene.domain, 4.1 * scene.config.l0);
    sim.add<mps::InitialReferenceDensity>(scene.particles, scene.domain, grid, sim.density_kernel());
    std::string refused;
    try {
      sim.step();
    } catch (const std::invalid_argument& e) {
      refused = e.what();
    }
    EXPECT_NE(refused.find("InitialReferenceDensity"), std::string::npos) << refused;
    EXPECT_EQ(sim.last_step().step, 0);
  }
  for (const int every : {0, -3}) {
    mps::DistributedOptions options;
    options.migrate_every = every;
    std::string refused;
    try {
      mps::RankExchange exchange(comm(), options);
    } catch (const std::invalid_argument& e) {
      refused = e.what();
    }
    EXPECT_NE(refused.find("migrate_every is " + std::to_string(every)), std::string::npos) << refused;
  }
  if (ranks() > 1) {
    Scene serial_solver = scene;
    serial_solver.config.solver = "eigen-cg";
    EXPECT_NE(message(serial_solver).find("eigen-cg"), std::string::npos) << message(serial_solver);
  }
}

}  // namespace
