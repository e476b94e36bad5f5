#include "core/testing/self_intersection.h"

#include <gtest/gtest.h>

namespace kgd {
namespace {

TEST(SelfIntersection, FindsCrossingTrianglesOnly) {
  Positions x(9, 3);
  x << 0, 0, 0, 1, 0, 0, 0, 1, 0,          // triangle in z = 0
      0.2, 0.2, -0.5, 0.2, 0.2, 0.5, 0.9, 0.9, 0,  // pierces the first one at (0.2, 0.2, 0)
      5, 5, 5, 6, 5, 5, 5, 6, 5;             // far away
  Faces f(3, 3);
  f << 0, 1, 2, 3, 4, 5, 6, 7, 8;
  const auto pairs = SelfIntersections(x, f);
  ASSERT_EQ(pairs.size(), 1u);
  EXPECT_EQ(pairs[0], std::make_pair(0, 1));
  // Move the piercing triangle off to the side: no crossing.
  x.middleRows(3, 3).col(0).array() += 3.0;
  EXPECT_TRUE(SelfIntersections(x, f).empty());
}

TEST(SelfIntersection, NeighboursSharingAVertexDoNotCount) {
  Positions x(4, 3);
  x << 0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1;
  Faces f(4, 3);
  f << 0, 2, 1, 0, 1, 3, 1, 2, 3, 0, 3, 2;
  EXPECT_TRUE(SelfIntersections(x, f).empty());
}

}  // namespace
}  // namespace kgd
