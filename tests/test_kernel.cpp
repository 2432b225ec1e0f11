#include <gtest/gtest.h>

#include <cmath>

#include "mps/core/kernel.hpp"

namespace {

TEST(Kernel, BoundedWeightIsFiniteAtZeroAndVanishesAtRadius) {
  const mps::Kernel k = mps::make_kernel(2.1, 0.01);
  EXPECT_NEAR(k.w(0.0), 1.0 / 0.15 - 1.0, 1e-12);
  EXPECT_EQ(k.w(k.re), 0.0);
  EXPECT_NEAR(k.w(k.re * (1 - 1e-12)), 0.0, 1e-9);
}

// The branch-free weight the Laplacian sums with: w's bits below re (and at r = 0 for the classic weight, infinity),
// and a zero from re on, for both weights.
TEST(Kernel, UnbranchedWeightIsWBelowTheRadiusAndZeroFromIt) {
  for (const mps::Weight weight : {mps::Weight::bounded, mps::Weight::classic}) {
    const mps::Kernel k = mps::make_kernel(4.1, 0.01, weight);
    for (int step = 1; step < 4000; ++step) {
      const double r = k.re * step / 2000.0;
      const double unbranched = k.w_unbranched(r);
      if (r < k.re) {
        EXPECT_EQ(unbranched, k.w(r)) << "r = " << r;  // bitwise
      } else {
        EXPECT_EQ(unbranched, 0.0) << "r = " << r;  // +0 or -0
      }
    }
    EXPECT_EQ(k.w_unbranched(0.0), k.w(0.0));
    EXPECT_EQ(k.w_unbranched(std::nextafter(k.re, 0.0)), k.w(std::nextafter(k.re, 0.0)));
  }
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
  EXPECT_THROW(mps::make_kernel(std::nan(""), 0.1), std::invalid_argument);
  // Beyond 10 l0 is refused before the lattice sums (1e6 l0 never returned).
  try {
    (void)mps::make_kernel(1e6, 0.1);
    ADD_FAILURE() << "accepted a radius of 1e6 l0";
  } catch (const std::invalid_argument& e) {
    EXPECT_STREQ(e.what(), "kernel: radius re/l0 = 1e+06 is outside (1, 10]; choose a radius in that range (the usual "
                           "ones are 2.1 to 4.1)");
  }
  EXPECT_DOUBLE_EQ(mps::make_kernel(10.0, 0.1).re, 1.0);
  EXPECT_THROW(mps::parse_weight("gaussian"), std::invalid_argument);
}

}  // namespace
