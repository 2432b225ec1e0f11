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

// extrude stacks a 2-D layout along z: every particle once per layer, at the layer's height, with its kind, group and
// velocity, and no velocity along z.
TEST(Geometry, ExtrudeStacksTheLayoutOncePerLayerAtTheLayersHeights) {
  mps::Particles flat;
  flat.add(0.1, 0.2, mps::Kind::fluid, 0, 1.5, -2.0);
  flat.add(-0.3, 0.4, mps::Kind::wall, 3);
  flat.add(0.5, -0.6, mps::Kind::dummy, 4);
  const double z0 = -0.25, l0 = 0.1;
  const mps::Particles3 prism = mps::extrude(flat, z0, l0, 4);
  ASSERT_EQ(prism.size(), 12U);
  for (std::size_t k = 0; k < 4; ++k)
    for (std::size_t i = 0; i < flat.size(); ++i) {
      const std::size_t j = k * flat.size() + i;
      EXPECT_EQ(prism.x[j], flat.x[i]);
      EXPECT_EQ(prism.y[j], flat.y[i]);
      EXPECT_DOUBLE_EQ(prism.z[j], z0 + (static_cast<double>(k) + 0.5) * l0);
      EXPECT_EQ(prism.kind[j], flat.kind[i]);
      EXPECT_EQ(prism.group[j], flat.group[i]);
      EXPECT_EQ(prism.u[j], flat.u[i]);
      EXPECT_EQ(prism.v[j], flat.v[i]);
      EXPECT_EQ(prism.w[j], 0.0);
      EXPECT_EQ(prism.id[j], static_cast<int>(j));
    }
  EXPECT_THROW(mps::extrude(flat, z0, l0, 0), std::invalid_argument);
  EXPECT_THROW(mps::extrude(flat, z0, -l0, 2), std::invalid_argument);
}

