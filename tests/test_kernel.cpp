#include <gtest/gtest.h>

#include <cmath>

#include "mps/kernel.hpp"

namespace {

TEST(Kernel, BoundedWeightIsFiniteAtZeroAndVanishesAtRadius) {
  const mps::Kernel k = mps::make_kernel(2.1, 0.01);
  EXPECT_NEAR(k.w(0.0), 1.0 / 0.15 - 1.0, 1e-12);
  EXPECT_EQ(k.w(k.re), 0.0);
  EXPECT_NEAR(k.w(k.re * (1 - 1e-12)), 0.0, 1e-9);
}

TEST(Kernel, ReferenceValuesMatchHandSumOnLattice) {
  // re = 2.1 l0 covers the 12 lattice neighbours at distances 1, sqrt2, 2 (4 each).
  const double l0 = 0.5;
  const mps::Kernel k = mps::make_kernel(2.1, l0, mps::Weight::classic);
  double n0 = 0.0, wr2 = 0.0;
  for (double d : {1.0, std::sqrt(2.0), 2.0}) {
    const double w = 2.1 / d - 1.0;
    n0 += 4 * w;
    wr2 += 4 * w * d * d * l0 * l0;
  }
  EXPECT_NEAR(k.n0, n0, 1e-12);
  EXPECT_NEAR(k.lambda, wr2 / n0, 1e-12);
}

TEST(Kernel, RejectsBadInput) {
  EXPECT_THROW(mps::make_kernel(2.1, 0.0), std::invalid_argument);
  EXPECT_THROW(mps::make_kernel(2.1, -1.0), std::invalid_argument);
  EXPECT_THROW(mps::make_kernel(0.9, 0.1), std::invalid_argument);
  EXPECT_THROW(mps::parse_weight("gaussian"), std::invalid_argument);
}

}  // namespace
