// Design agreement: the Jaccard index on closed-form cases, and designs carried between resolutions.
#include "core/beso/design_compare.h"

#include <gtest/gtest.h>

#include "core/mesh/topology.h"
#include "core/scene/builtin_scenes.h"

namespace kgd {
namespace {

TEST(DesignCompare, JaccardWeighsFacesByArea) {
  const Eigen::VectorXd area = (Eigen::VectorXd(4) << 1, 1, 2, 4).finished();
  EXPECT_EQ(DesignJaccard({1, 1, 0, 0}, {1, 1, 0, 0}, area), 1.0);
  EXPECT_EQ(DesignJaccard({1, 1, 0, 0}, {0, 0, 1, 1}, area), 0.0);
  EXPECT_DOUBLE_EQ(DesignJaccard({1, 0, 1, 0}, {1, 0, 0, 1}, area), 1.0 / 7.0);  // both: 1; either: 1 + 2 + 4
  EXPECT_DOUBLE_EQ(DesignJaccard({0, 0, 1, 1}, {0, 0, 0, 1}, area), 4.0 / 6.0);
  EXPECT_EQ(DesignJaccard({0, 0, 0, 0}, {0, 0, 0, 0}, area), 1.0);  // nothing reinforced in either: the same
}

// A design on a mesh carried to its midpoint subdivision: each middle child (centroid on its parent's)
// takes its parent's design, most of the area agrees with the design prolonged to the children, and
// carried back (each parent's centroid is its middle child's) it is the same design.
TEST(DesignCompare, ADesignCarriedToAFinerMeshAndBackIsUnchanged) {
  Result<SceneSpec> scene = PullTestScene("line");
  ASSERT_TRUE(scene.ok());
  const TriMesh coarse = scene->garment;
  const Subdivision sub = SubdivideMidpoint(coarse.faces, static_cast<int>(coarse.vertices.rows()));
  const TriMesh fine{sub.prolongation * coarse.vertices, sub.faces};
  const std::vector<uint8_t>& design = scene->design;
  const std::vector<uint8_t> carried = TransferDesign(coarse, design, fine);
  ASSERT_EQ(carried.size(), static_cast<size_t>(fine.faces.rows()));
  std::vector<uint8_t> prolonged(fine.faces.rows());
  for (Eigen::Index f = 0; f < fine.faces.rows(); ++f) {
    prolonged[f] = design[f / 4];
    if (f % 4 == 3) {
      EXPECT_EQ(carried[f], design[f / 4]) << "middle child " << f;
    }
  }
  EXPECT_GT(DesignJaccard(carried, prolonged, FaceAreas(fine.vertices, fine.faces)), 0.9);
  const std::vector<uint8_t> back = TransferDesign(fine, carried, coarse);
  EXPECT_EQ(DesignJaccard(back, design, FaceAreas(coarse.vertices, coarse.faces)), 1.0);
  int reinforced = 0;
  for (uint8_t d : design) reinforced += d;
  EXPECT_GT(reinforced, 0);
  EXPECT_LT(reinforced, static_cast<int>(design.size()));
}

}  // namespace
}  // namespace kgd
