// Checkpoint and restart (docs/restart.md): a run restored from a checkpoint taken at an exact step repeats the
// uninterrupted run bitwise, in 2-D and 3-D, with a free surface, a kept AMG hierarchy and an inlet's recycling; a
// file that is no checkpoint, or one of another scene, is refused with the reason and leaves the run as it was.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <unistd.h>

#include "channel.hpp"
#include "column.hpp"
#include "mps/boundaries/geometry.hpp"
#include "mps/io/io.hpp"
#include "mps/step/components.hpp"
#include "mps/step/step.hpp"

namespace fs = std::filesystem;

namespace {

fs::path scratch(const std::string& name) {
  const fs::path dir = fs::temp_directory_path() / ("sparsemps_restart_" + std::to_string(::getpid()));
  fs::create_directories(dir);
  return dir / name;
}

template <int D>
void expect_same_particles(const mps::BasicParticles<D>& a, const mps::BasicParticles<D>& b) {
  ASSERT_EQ(a.size(), b.size());
  a.for_each_field([&](const char* name, const auto& values) {
    bool equal = false;
    b.for_each_field([&](const char* other, const auto& theirs) {
      if (std::string(name) == other) {
        if constexpr (std::is_same_v<decltype(values), decltype(theirs)>) equal = values == theirs;
      }
    });
    EXPECT_TRUE(equal) << "field " << name << " differs";
  });
}

// A column of water collapsing in a closed tank (free surface, walls), in 2-D or 3-D, with the given solver.
template <int D>
mps::BasicSimulation<D> collapsing_column(const std::string& solver) {
  const double l0 = 0.02;
  mps::BasicParticles<D> p;
  mps::SimulationConfig c;
  c.l0 = l0;
  c.dt_max = 1e-3;
  c.gamma = 0.2;
  c.solver = solver;
  c.reorder_every = 10;
  if constexpr (D == 2) {
    mps::fill_rectangle(p, {0, 0, 0.2, 0.3}, l0, mps::Kind::fluid);
    mps::add_rectangle_walls(p, {0, 0, 0.5, 0.4}, l0, mps::left | mps::right | mps::bottom, 1, 3);
    c.fy = -9.81;
    return mps::Simulation(p, {-0.1, 0.6, -0.1, 0.6}, c);
  } else {
    mps::fill_box(p, {0, 0, 0, 0.12, 0.1, 0.16}, l0, mps::Kind::fluid);
    mps::add_box_walls(p, {0, 0, 0, 0.3, 0.1, 0.2}, l0,
                       mps::x_low | mps::x_high | mps::y_low | mps::y_high | mps::z_low, 1, 3);
    c.fz = -9.81;
    c.radius_density = c.radius_laplacian = 3.1;
    return mps::Simulation3(p, {-0.1, 0.4, -0.1, 0.2, -0.1, 0.3}, c);
  }
}

// Runs `total` steps, checkpointing (through a file) after `at`; a second simulation built alike restores that file
// and runs the rest. Both must end with the same particles and clock, bit for bit.
template <int D>
void expect_bitwise_continuation(const std::string& solver, int at, int total) {
  mps::BasicSimulation<D> whole = collapsing_column<D>(solver);
  const fs::path file = scratch("column" + std::to_string(D) + ".cbor");
  for (int s = 0; s < total; ++s) {
    whole.step();
    if (whole.last_step().step == at) {
      EXPECT_TRUE(whole.checkpoint_exact());
      mps::write_checkpoint(file, whole.checkpoint());
    }
  }
  mps::BasicSimulation<D> resumed = collapsing_column<D>(solver);
  resumed.restore(mps::read_checkpoint(file));
  EXPECT_EQ(resumed.last_step().step, at);
  while (resumed.last_step().step < total) resumed.step();
  expect_same_particles(whole.particles(), resumed.particles());
  EXPECT_EQ(whole.time(), resumed.time());
  EXPECT_EQ(whole.last_step().dt, resumed.last_step().dt);
  EXPECT_EQ(whole.last_step().solve.iterations, resumed.last_step().solve.iterations);
  EXPECT_GT(*std::max_element(whole.particles().p.begin(), whole.particles().p.end()), 500.0);  // a flow, not rest
}

}  // namespace

TEST(Restart, ACollapsingColumnContinuesBitwiseWithTheDefaultSolver) {
  expect_bitwise_continuation<2>("auto", 20, 35);
}

TEST(Restart, AThreeDColumnContinuesBitwise) { expect_bitwise_continuation<3>("auto", 10, 18); }

// A kept AMG hierarchy cannot be saved: a checkpoint is exact where the next step renumbers the unknowns (and so sets
// the hierarchy up afresh anyway); between those steps it says it is not, and a restart from there agrees within the
// solver's tolerance.
TEST(Restart, AKeptAmgHierarchyMakesOnlyTheStepsBeforeAReorderingExact) {
  const std::string solver = "hypre-pcg:reuse=50,tol=1e-10";
  expect_bitwise_continuation<2>(solver, 20, 30);

  mps::Simulation whole = collapsing_column<2>(solver);
  for (int s = 0; s < 13; ++s) whole.step();
  EXPECT_FALSE(whole.checkpoint_exact());
  const nlohmann::json state = whole.checkpoint();
  EXPECT_FALSE(state.at("exact").get<bool>());
  for (int s = 0; s < 5; ++s) whole.step();
  mps::Simulation resumed = collapsing_column<2>(solver);
  resumed.restore(state);
  for (int s = 0; s < 5; ++s) resumed.step();
  double largest = 0.0, difference = 0.0;
  for (std::size_t i = 0; i < whole.particles().size(); ++i) {
    largest = std::max(largest, std::abs(whole.particles().p[i]));
    difference = std::max(difference, std::abs(whole.particles().p[i] - resumed.particles().p[i]));
  }
  EXPECT_GT(difference, 0.0);  // a fresh hierarchy: not the same bits
  EXPECT_LT(difference, 1e-6 * largest);
}

// The inlet channel's plate recycles the outflow into its ghost pool: its counts go into the checkpoint beside the
// simulation's, and the restored channel adds the same columns at the same steps.
TEST(Restart, TheInletChannelRecyclesAsTheUninterruptedRunDoes) {
  poiseuille::Params p;
  p.mode = poiseuille::Mode::inlet;
  p.across = 8;
  p.length_D = 4;
  p.station_D = 2;
  auto build = [&](std::shared_ptr<mps::PushingPlate>& plate) {
    mps::Particles particles = poiseuille::make_particles(p);
    const mps::Particles initial = particles;
    auto sim = std::make_unique<mps::Simulation>(std::move(particles), poiseuille::make_domain(p),
                                                 poiseuille::make_config(p));
    plate = poiseuille::add_components(p, initial, *sim);
    return sim;
  };
  std::shared_ptr<mps::PushingPlate> plate, resumed_plate;
  auto whole = build(plate);
  nlohmann::json saved;
  for (int s = 0; s < 160; ++s) {
    whole->step();
    if (whole->last_step().step == 80) saved = {{"simulation", whole->checkpoint()}, {"plate", plate->save_state()}};
  }
  ASSERT_GT(plate->columns_added(), 4);  // the plate stepped back over the second half
  ASSERT_GT(plate->particles_removed(), 0);
  const fs::path file = scratch("channel.cbor");
  mps::write_checkpoint(file, saved);
  auto resumed = build(resumed_plate);
  const nlohmann::json state = mps::read_checkpoint(file);
  resumed->restore(state.at("simulation"));
  resumed_plate->restore_state(state.at("plate"));
  while (resumed->last_step().step < 160) resumed->step();
  expect_same_particles(whole->particles(), resumed->particles());
  EXPECT_EQ(plate->columns_added(), resumed_plate->columns_added());
  EXPECT_EQ(plate->particles_removed(), resumed_plate->particles_removed());
}

TEST(Restart, FilesThatAreNoCheckpointAreRefusedNamingWhy) {
  auto message = [](const fs::path& path) {
    try {
      (void)mps::read_checkpoint(path);
    } catch (const std::runtime_error& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  EXPECT_NE(message(scratch("absent.cbor")).find("cannot open"), std::string::npos);
  mps::write_text(scratch("text.cbor"), "x,y\n1,2\n");
  EXPECT_NE(message(scratch("text.cbor")).find("not a SparseMPS checkpoint"), std::string::npos);
  mps::write_text(scratch("other.cbor"), "");
  EXPECT_NE(message(scratch("other.cbor")).find("truncated or damaged"), std::string::npos);
  // Valid CBOR of something else, and a checkpoint cut short.
  const std::vector<std::uint8_t> other = nlohmann::json::to_cbor({{"format", "vtk"}});
  std::ofstream(scratch("cbor.cbor"), std::ios::binary)
      .write(reinterpret_cast<const char*>(other.data()), static_cast<std::streamsize>(other.size()));
  EXPECT_NE(message(scratch("cbor.cbor")).find("no \"format\": \"sparsemps-checkpoint\""), std::string::npos);
  mps::Simulation sim = collapsing_column<2>("auto");
  sim.step();
  mps::write_checkpoint(scratch("whole.cbor"), sim.checkpoint());
  const auto size = fs::file_size(scratch("whole.cbor"));
  fs::copy_file(scratch("whole.cbor"), scratch("cut.cbor"), fs::copy_options::overwrite_existing);
  fs::resize_file(scratch("cut.cbor"), size / 2);
  EXPECT_NE(message(scratch("cut.cbor")).find("truncated or damaged"), std::string::npos);
}

TEST(Restart, ACheckpointOfAnotherSceneIsRefusedAndTheRunLeftAsItWas) {
  mps::Simulation sim = collapsing_column<2>("auto");
  for (int s = 0; s < 3; ++s) sim.step();
  const nlohmann::json state = sim.checkpoint();

  // Another dimension.
  mps::Simulation3 three = collapsing_column<3>("auto");
  EXPECT_THROW(
      {
        try {
          three.restore(state);
        } catch (const std::runtime_error& e) {
          EXPECT_NE(std::string(e.what()).find("of a 2-D run; this simulation is 3-D"), std::string::npos) << e.what();
          throw;
        }
      },
      std::runtime_error);

  // Other components: the message lists both, and nothing of the run changed.
  mps::Simulation other = collapsing_column<2>("auto");
  other.add<mps::RemoveEscaped>([](double, double) { return true; });
  other.step();
  const mps::Particles before = other.particles();
  try {
    other.restore(state);
    ADD_FAILURE() << "restored a checkpoint of other components";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("RemoveEscaped"), std::string::npos) << e.what();
  }
  expect_same_particles(before, other.particles());
  EXPECT_EQ(other.last_step().step, 1);

  // A damaged particle field.
  nlohmann::json damaged = state;
  damaged["particles"]["p"] = mps::pack_array(std::vector<int>{1, 2, 3});
  EXPECT_THROW(sim.restore(damaged), std::runtime_error);
  damaged["particles"].erase("p");
  EXPECT_THROW(sim.restore(damaged), std::runtime_error);
  EXPECT_EQ(sim.last_step().step, 3);

  // Mid-step: neither a checkpoint nor a restore.
  sim.advance_to(mps::Stage::assembly);
  EXPECT_THROW((void)sim.checkpoint(), std::logic_error);
  EXPECT_THROW(sim.restore(state), std::logic_error);
}

// A component's counts travel with the checkpoint.
TEST(Restart, ComponentCountsAreRestored) {
  auto build = [] {
    mps::Simulation sim = collapsing_column<2>("auto");
    sim.add<mps::RemoveEscaped>([](double x, double) { return x < 0.15; });  // the surge's front leaves
    return sim;
  };
  mps::Simulation whole = build();
  nlohmann::json state;
  for (int s = 0; s < 60; ++s) {
    whole.step();
    if (s == 39) state = whole.checkpoint();
  }
  mps::Simulation resumed = build();
  resumed.restore(state);
  const long at_checkpoint = resumed.find<mps::RemoveEscaped>()->removed();
  EXPECT_GT(at_checkpoint, 0);
  while (resumed.last_step().step < 60) resumed.step();
  EXPECT_GT(whole.find<mps::RemoveEscaped>()->removed(), at_checkpoint);
  EXPECT_EQ(whole.find<mps::RemoveEscaped>()->removed(), resumed.find<mps::RemoveEscaped>()->removed());
  expect_same_particles(whole.particles(), resumed.particles());
}

// auto's choice between Jacobi-CG and AMG-PCG reads its counts of steady solves: they travel with the checkpoint, so
// the restored run moves to AMG-PCG at the same step (in a periodic channel, whose unknowns hold still).
TEST(Restart, AutoMovesToAmgAtTheSameStepAfterARestart) {
  poiseuille::Params p;
  p.mode = poiseuille::Mode::body_force;
  p.across = 8;
  p.solver = "auto:switch_iterations=0,steady_solves=4";
  mps::Simulation whole = poiseuille::make_simulation(p, std::nullopt);
  nlohmann::json state;
  for (int s = 0; s < 30; ++s) {
    whole.step();
    if (whole.last_step().step == 2) {
      EXPECT_TRUE(whole.checkpoint_exact());  // AMG not set up yet
      state = whole.checkpoint();
    }
  }
  EXPECT_NE(whole.last_step().solve.backend.find("hypre-pcg"), std::string::npos);
  mps::Simulation resumed = poiseuille::make_simulation(p, std::nullopt);
  resumed.restore(state);
  while (resumed.last_step().step < 30) resumed.step();
  expect_same_particles(whole.particles(), resumed.particles());
}
