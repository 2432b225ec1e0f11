// Lattices and walls (mps/boundaries/geometry.hpp): what they place, and what they refuse.
#include <gtest/gtest.h>

#include <stdexcept>
#include <string>

#include "mps/boundaries/geometry.hpp"

namespace {

std::string refusal(mps::Rect rect, double l0) {
  mps::Particles p;
  try {
    mps::fill_rectangle(p, rect, l0, mps::Kind::fluid);
  } catch (const std::invalid_argument& e) {
    return e.what();
  }
  return "";
}

}  // namespace

// Cell-centred points: a 0.4 x 0.2 rectangle at 0.1 holds 4 x 2 of them, the first half a spacing in.
TEST(Geometry, FillRectanglePutsOnePointAtEveryCellCentre) {
  mps::Particles p;
  mps::fill_rectangle(p, {1.0, 2.0, 1.4, 2.2}, 0.1, mps::Kind::fluid, 3);
  ASSERT_EQ(p.size(), 8u);
  EXPECT_DOUBLE_EQ(p.x[0], 1.05);
  EXPECT_DOUBLE_EQ(p.y[0], 2.05);
  for (std::size_t i = 0; i < p.size(); ++i) {
    EXPECT_GT(p.x[i], 1.0);
    EXPECT_LT(p.x[i], 1.4);
    EXPECT_EQ(p.group[i], 3);
  }
}

// An empty rectangle names itself and what to change: the message had been "rectangle is empty at this spacing".
TEST(Geometry, AnEmptyRectangleIsRefusedWithItsCornersAndTheLargestSpacing) {
  const std::string coarse = refusal({0, 0, 0.146, 0.292}, 1.0);
  EXPECT_NE(coarse.find("the rectangle [0, 0.146] x [0, 0.292] holds no lattice point at spacing 1"), std::string::npos)
      << coarse;
  EXPECT_NE(coarse.find("use a spacing of at most 0.146"), std::string::npos) << coarse;
  const std::string reversed = refusal({1, 1, 0, 0}, 0.1);
  EXPECT_NE(reversed.find("must lie above and right of (x0, y0)"), std::string::npos) << reversed;
}
