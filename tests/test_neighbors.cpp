#include <gtest/gtest.h>
#include <omp.h>

#include <algorithm>
#include <iterator>
#include <random>

#include "mps/boundaries/geometry.hpp"
#include "mps/core/neighbors.hpp"

namespace {

mps::Particles random_particles(std::size_t n, const mps::Domain& d, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> ux(d.xmin, d.xmax), uy(d.ymin, d.ymax);
  mps::Particles p;
  for (std::size_t i = 0; i < n; ++i) p.add(ux(rng), uy(rng), i % 7 == 0 ? mps::Kind::wall : mps::Kind::fluid);
  p.kind[5] = mps::Kind::ghost;  // ghosts neither have nor are neighbours
  return p;
}

std::vector<std::vector<int>> brute_force(const mps::Particles& p, const mps::Domain& d, double radius) {
  std::vector<std::vector<int>> out(p.size());
  for (std::size_t i = 0; i < p.size(); ++i) {
    if (p.kind[i] == mps::Kind::ghost) continue;
    for (std::size_t j = 0; j < p.size(); ++j) {
      if (i == j || p.kind[j] == mps::Kind::ghost) continue;
      const auto r = d.displacement(p.x[i], p.y[i], p.x[j], p.y[j]);
      if (r[0] * r[0] + r[1] * r[1] < radius * radius) out[i].push_back(static_cast<int>(j));
    }
  }
  return out;
}

void expect_same_as_brute_force(const mps::Domain& d, double radius, unsigned seed) {
  const mps::Particles p = random_particles(1500, d, seed);
  const mps::NeighborList list = mps::find_neighbors(p, d, radius);
  const auto expected = brute_force(p, d, radius);
  ASSERT_EQ(list.particles(), p.size());
  std::size_t pairs = 0;
  for (std::size_t i = 0; i < p.size(); ++i) {
    const auto got = list.of(i);
    EXPECT_EQ(std::vector<int>(got.begin(), got.end()), expected[i]) << "particle " << i;
    pairs += expected[i].size();
  }
  EXPECT_EQ(list.pairs(), pairs);
  EXPECT_GT(pairs, 10 * p.size());  // the radius really finds neighbours
}

TEST(Neighbors, MatchBruteForceWithoutPeriodicity) { expect_same_as_brute_force({0, 1, 0, 0.7}, 0.08, 1); }

TEST(Neighbors, MatchBruteForceWithPeriodicX) { expect_same_as_brute_force({0, 1, 0, 0.7, true, false}, 0.08, 2); }

TEST(Neighbors, MatchBruteForceWithBothAxesPeriodic) { expect_same_as_brute_force({-1, 0, 2, 2.5, true, true}, 0.1, 3); }

// Each row of cells is scanned only as far as the sphere reaches at its nearest point: in 3-D, over periodic and
// closed axes alike, with particles escaped beyond the closed ones (binned in the edge cells), searching and searched.
TEST(Neighbors, MatchBruteForceIn3DWithPeriodicAxesAndEscapedParticles) {
  mps::BasicDomain<3> d;
  d.xmin = 0, d.xmax = 1, d.ymin = -0.2, d.ymax = 0.5, d.zmin = 0, d.zmax = 0.6;
  d.periodic_x = true, d.periodic_z = true;
  const double radius = 0.1;
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  mps::BasicParticles<3> p;
  for (std::size_t i = 0; i < 6000; ++i) {
    mps::Vec<3> r{d.xmin + unit(rng) * 1.0, d.ymin + unit(rng) * 0.7, d.zmin + unit(rng) * 0.6};
    if (i % 50 == 0) r[1] = i % 100 == 0 ? d.ymin - 0.7 * radius * unit(rng) : d.ymax + 2.5 * radius * unit(rng);
    p.add(r, mps::Kind::fluid);
  }
  const auto list = mps::find_neighbors(p, d, radius);
  std::size_t pairs = 0;
  for (std::size_t i = 0; i < p.size(); ++i) {
    std::vector<int> expected;
    for (std::size_t j = 0; j < p.size(); ++j) {
      const auto r = d.displacement(p.position(i), p.position(j));
      if (i != j && r[0] * r[0] + r[1] * r[1] + r[2] * r[2] < radius * radius) expected.push_back(static_cast<int>(j));
    }
    const auto got = list.of(i);
    ASSERT_EQ(std::vector<int>(got.begin(), got.end()), expected) << "particle " << i;
    pairs += expected.size();
  }
  EXPECT_GT(pairs, 10 * p.size());  // the radius really finds neighbours
}

// The same in 2-D, escaped particles beyond the closed y axis.
TEST(Neighbors, MatchBruteForceWithEscapedParticles) {
  const mps::Domain d{0, 1, 0, 0.7, true, false};
  mps::Particles p = random_particles(1500, d, 12);
  for (std::size_t i = 0; i < p.size(); i += 40) p.y[i] = i % 80 == 0 ? -0.06 * (i % 7) / 7.0 : 0.7 + 0.2 * (i % 3);
  const auto list = mps::find_neighbors(p, d, 0.08);
  const auto expected = brute_force(p, d, 0.08);
  for (std::size_t i = 0; i < p.size(); ++i) {
    const auto got = list.of(i);
    EXPECT_EQ(std::vector<int>(got.begin(), got.end()), expected[i]) << "particle " << i;
  }
}

TEST(Neighbors, OneBinningServesSmallerRadii) {
  const mps::Domain d{0, 1, 0, 1, true, false};
  const mps::Particles p = random_particles(800, d, 4);
  mps::CellGrid grid(d, 0.12);
  grid.bin(p);
  const auto list = grid.neighbors(p, 0.05);
  const auto expected = brute_force(p, d, 0.05);
  for (std::size_t i = 0; i < p.size(); ++i) {
    const auto got = list.of(i);
    EXPECT_EQ(std::vector<int>(got.begin(), got.end()), expected[i]);
  }
  EXPECT_THROW((void)grid.neighbors(p, 0.2), std::invalid_argument);
}

// The search with a fringe: the list and the inner list as without one, the fringe the pairs from the radius to its
// own, and the list widened by it the list at the fringe's radius, with periodic images and a ghost.
TEST(Neighbors, FringeHoldsThePairsBetweenTheRadiiAndWidensTheListToTheOuterOne) {
  const mps::Domain d{0, 1, 0, 0.8, true, false};
  const mps::Particles p = random_particles(1200, d, 6);
  const double radius = 0.08, inner_radius = 0.04, outer = 0.09;
  mps::CellGrid grid(d, radius, outer - radius);
  EXPECT_EQ(grid.cell_size(), outer);
  grid.bin(p);
  mps::NeighborList list, inner, fringe;
  grid.neighbors(p, radius, list, inner_radius, &inner, outer, fringe);
  const auto within = brute_force(p, d, radius), within_inner = brute_force(p, d, inner_radius),
             within_outer = brute_force(p, d, outer);
  std::size_t fringe_pairs = 0;
  for (std::size_t i = 0; i < p.size(); ++i) {
    const auto got = list.of(i), got_inner = inner.of(i), got_fringe = fringe.of(i);
    EXPECT_EQ(std::vector<int>(got.begin(), got.end()), within[i]) << "particle " << i;
    EXPECT_EQ(std::vector<int>(got_inner.begin(), got_inner.end()), within_inner[i]) << "particle " << i;
    std::vector<int> beyond;
    std::set_difference(within_outer[i].begin(), within_outer[i].end(), within[i].begin(), within[i].end(),
                        std::back_inserter(beyond));
    EXPECT_EQ(std::vector<int>(got_fringe.begin(), got_fringe.end()), beyond) << "particle " << i;
    fringe_pairs += beyond.size();
  }
  EXPECT_GT(fringe_pairs, p.size());  // the fringe is not empty
  EXPECT_EQ(list.radius, radius);
  EXPECT_EQ(fringe.radius, outer);
  mps::add_fringe(list, fringe);
  EXPECT_EQ(list.radius, outer);
  for (std::size_t i = 0; i < p.size(); ++i) {
    const auto got = list.of(i);
    EXPECT_EQ(std::vector<int>(got.begin(), got.end()), within_outer[i]) << "particle " << i;
  }
  EXPECT_THROW(mps::add_fringe(list, fringe), std::invalid_argument);  // the list is as wide as the fringe now
  EXPECT_THROW(grid.neighbors(p, radius, list, inner_radius, &inner, 0.1, fringe), std::invalid_argument);  // > cell
  EXPECT_THROW(grid.neighbors(p, radius, list, inner_radius, &inner, radius, fringe), std::invalid_argument);
  EXPECT_THROW(mps::CellGrid(d, radius, -0.01), std::invalid_argument);
}

// Rows left out of a search (a tank's dummies) are empty; the rows searched are those of a full search, their pairs
// with the rows left out included, in every list of the search, on one thread and on three (whose shares of the rows
// are cut by the rows searched, here crowded into the first third).
TEST(Neighbors, RowsLeftOutOfASearchAreEmptyAndTheOthersAsInAFullSearch) {
  const mps::Domain d{0, 1, 0, 0.8, true, false};
  const mps::Particles p = random_particles(4000, d, 8);
  const double radius = 0.05, inner_radius = 0.03, outer = 0.055;
  std::vector<char> rows(p.size(), 0);
  for (std::size_t i = 0; i < p.size(); ++i) rows[i] = i < p.size() / 3 || i % 5 == 0;
  mps::CellGrid grid(d, radius, outer - radius);
  grid.bin(p);
  mps::NeighborList all, all_inner, all_fringe;
  grid.neighbors(p, radius, all, inner_radius, &all_inner, outer, all_fringe);
  const int before = omp_get_max_threads();
  for (int threads : {1, 3}) {
    omp_set_num_threads(threads);
    mps::NeighborList list, inner, fringe, plain, plain_inner;
    grid.neighbors(p, radius, list, inner_radius, &inner, outer, fringe, rows);
    grid.neighbors(p, radius, plain, inner_radius, plain_inner, rows);
    std::size_t pairs = 0;
    for (std::size_t i = 0; i < p.size(); ++i) {
      for (const auto& [got, full] : {std::pair{&list, &all}, {&inner, &all_inner}, {&fringe, &all_fringe},
                                      {&plain, &all}, {&plain_inner, &all_inner}}) {
        const auto row = got->of(i), expected = full->of(i);
        if (rows[i]) {
          EXPECT_EQ(std::vector<int>(row.begin(), row.end()), std::vector<int>(expected.begin(), expected.end()))
              << "particle " << i << ", " << threads << " threads";
        } else {
          EXPECT_TRUE(row.empty()) << "particle " << i << ", " << threads << " threads";
        }
      }
      pairs += list.of(i).size();
    }
    EXPECT_GT(pairs, 5 * p.size() / 2);  // the rows searched found their neighbours
  }
  omp_set_num_threads(before);
  std::vector<char> short_rows(p.size() - 1, 1);
  mps::NeighborList list;
  EXPECT_THROW(grid.neighbors(p, radius, list, short_rows), std::invalid_argument);
}

TEST(Neighbors, CellOrderIsAPermutationThatKeepsNeighbourSets) {
  const mps::Domain d{0, 1, 0, 1};
  mps::Particles p = random_particles(600, d, 5);
  mps::CellGrid grid(d, 0.1);
  grid.bin(p);
  std::vector<int> order = grid.cell_order();
  std::vector<int> sorted = order;
  std::sort(sorted.begin(), sorted.end());
  for (std::size_t i = 0; i < sorted.size(); ++i) ASSERT_EQ(sorted[i], static_cast<int>(i));
  const auto before = brute_force(p, d, 0.1);
  p.permute(order);
  EXPECT_EQ(p.kind.back(), mps::Kind::ghost);  // ghosts go last
  const auto after = mps::find_neighbors(p, d, 0.1);
  for (std::size_t i = 0; i < p.size(); ++i) {
    std::vector<int> ids;
    for (int j : after.of(i)) ids.push_back(p.id[static_cast<std::size_t>(j)]);
    std::sort(ids.begin(), ids.end());
    EXPECT_EQ(ids, before[static_cast<std::size_t>(p.id[i])]) << "particle id " << p.id[i];
  }
}

TEST(Neighbors, RejectsBadGrids) {
  EXPECT_THROW(mps::CellGrid({0, 1, 0, 1}, 0.0), std::invalid_argument);
  EXPECT_THROW(mps::CellGrid({0, 1, 0, 1}, -0.1), std::invalid_argument);
  EXPECT_THROW(mps::CellGrid({0, 0, 0, 1}, 0.1), std::invalid_argument);            // empty domain
  EXPECT_THROW(mps::CellGrid({0, 0.25, 0, 1, true, false}, 0.1), std::invalid_argument);  // < 3 cells periodic
}

TEST(Domain, WrapAndMinimumImage) {
  const mps::Domain d{0, 1, -1, 1, true, false};
  double x = 1.25, y = 0.5;
  d.wrap(x, y);
  EXPECT_NEAR(x, 0.25, 1e-15);
  x = -0.1;
  d.wrap(x, y);
  EXPECT_NEAR(x, 0.9, 1e-15);
  const auto r = d.displacement(0.95, 0.0, 0.05, 0.0);
  EXPECT_NEAR(r[0], 0.1, 1e-15);
  EXPECT_FALSE(d.contains(0.5, 1.5));
  EXPECT_TRUE(d.contains(7.0, 0.5));  // periodic x: any x is inside
}

}  // namespace

namespace {
TEST(Neighbors, RestrictingAListToASmallerRadiusEqualsSearchingWithIt) {
  const mps::Domain d{0, 1, 0, 1, true, true};
  const mps::Particles p = random_particles(900, d, 6);
  const auto wide = mps::find_neighbors(p, d, 0.12);
  const auto narrow = mps::restrict_radius(wide, p, d, 0.05);
  const auto expected = brute_force(p, d, 0.05);
  for (std::size_t i = 0; i < p.size(); ++i) {
    const auto got = narrow.of(i);
    EXPECT_EQ(std::vector<int>(got.begin(), got.end()), expected[i]);
  }
  EXPECT_THROW((void)mps::restrict_radius(wide, p, d, 0.2), std::invalid_argument);
}
}  // namespace

// A domain far larger than its search radius (a particle far from the rest widened it) is refused with the count,
// not allocated: the cell counts overflowed an int at 1e300 m.
TEST(Neighbors, AGridOfMoreThan1e8CellsIsRefused) {
  try {
    mps::CellGrid grid({0, 1e300, 0, 1}, 0.03);
    ADD_FAILURE() << "a grid 1e300 m long was made";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("more than the 1e8 a grid may hold"), std::string::npos) << e.what();
  }
  EXPECT_THROW(mps::CellGrid({0, 1000, 0, 1000}, 0.1), std::invalid_argument);  // 4e8 cells
  EXPECT_NO_THROW(mps::CellGrid({0, 1000, 0, 1000}, 0.4));                      // 2.5e7 cells
}
