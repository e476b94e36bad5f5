// Cleaning for manufacture on a flat sheet, where widths and areas are known exactly; patches keep their
// area and straight outlines stay exact.
#include "core/fabrication/patches.h"

#include <gtest/gtest.h>

#include <functional>

#include "core/scene/shapes.h"

namespace kgd {
namespace {

// A 100 x 100 mm sheet on a 1 mm grid, and faces by their centroids.
struct Sheet100 {
  TriMesh mesh = RectangleSheet(0.10, 0.10, 0.001);
  Positions centroid;
  Sheet100() {
    centroid.resize(mesh.faces.rows(), 3);
    for (Eigen::Index f = 0; f < mesh.faces.rows(); ++f)
      centroid.row(f) = (mesh.vertices.row(mesh.faces(f, 0)) + mesh.vertices.row(mesh.faces(f, 1)) + mesh.vertices.row(mesh.faces(f, 2))) / 3;
  }
  std::vector<uint8_t> Where(const std::function<bool(double, double)>& in) const {
    std::vector<uint8_t> d(mesh.faces.rows());
    for (Eigen::Index f = 0; f < mesh.faces.rows(); ++f) d[f] = in(centroid(f, 0), centroid(f, 2));
    return d;
  }
  double Area(const std::vector<uint8_t>& d) const {
    const Eigen::VectorXd a = FaceAreas(mesh.vertices, mesh.faces);
    double s = 0;
    for (size_t f = 0; f < d.size(); ++f) s += d[f] ? a[f] : 0;
    return s;
  }
};

TEST(CleanDesign, RemovesFeaturesThinnerThanTheMinimumAndKeepsWiderOnes) {
  const Sheet100 s;
  // A 20 mm block with a 2 mm strip and a 5 mm strip leaving it.
  const auto block = [](double x, double z) { return x > 0.04 && x < 0.06 && z > 0.04 && z < 0.06; };
  const std::vector<uint8_t> d = s.Where([&](double x, double z) {
    return block(x, z) || (z > 0.02 && z < 0.022 && x > 0.01 && x < 0.09) || (x > 0.02 && x < 0.025 && z > 0.01 && z < 0.09);
  });
  const CleanedDesign c = CleanDesign(s.mesh, d, {.min_feature_m = 0.003});
  // An opening: the 2 mm strip goes except a stub within the minimum width of the wide parts; the block
  // and the 5 mm strip stay, but for their convex corners (rounded by less than a grid cell).
  auto near_corner = [](double x, double z) {
    for (const auto& [cx, cz] : std::vector<std::pair<double, double>>{
             {0.04, 0.04}, {0.06, 0.04}, {0.04, 0.06}, {0.06, 0.06}, {0.02, 0.01}, {0.025, 0.01}, {0.02, 0.09}, {0.025, 0.09}})
      if (std::abs(x - cx) < 0.0015 && std::abs(z - cz) < 0.0015) return true;
    return false;
  };
  for (Eigen::Index f = 0; f < s.mesh.faces.rows(); ++f) {
    const double x = s.centroid(f, 0), z = s.centroid(f, 2);
    const bool wide = block(x, z) || (x > 0.02 && x < 0.025 && z > 0.01 && z < 0.09);
    if (wide && !near_corner(x, z)) { EXPECT_TRUE(c.design[f]) << "a wide part lost the face at " << x << ", " << z; }
    if (!wide && std::abs(x - 0.0225) > 0.004) { EXPECT_FALSE(c.design[f]) << "the thin strip kept the face at " << x << ", " << z; }
  }
  EXPECT_NEAR(c.removed_m2, s.Area(d) - s.Area(c.design), 1e-12);
  EXPECT_NEAR(c.removed_m2, 0.002 * 0.075, 10e-6) << "the thin strip's area, to a few corner cells";
}

TEST(CleanDesign, DropsSmallIslandsAndFillsSmallHoles) {
  const Sheet100 s;
  std::vector<uint8_t> d = s.Where([](double x, double z) {
    const bool big = x > 0.02 && x < 0.08 && z > 0.02 && z < 0.08;
    const bool hole = x > 0.05 && x < 0.054 && z > 0.05 && z < 0.054;       // 4 x 4 mm
    const bool island = x > 0.01 && x < 0.014 && z > 0.01 && z < 0.014;    // 4 x 4 mm, apart
    return (big && !hole) || island;
  });
  const CleanedDesign c = CleanDesign(s.mesh, d, {.min_feature_m = 0.003, .min_area_m2 = 25e-6});
  EXPECT_EQ(c.islands_removed, 1);
  EXPECT_EQ(c.holes_filled, 1);
  for (Eigen::Index f = 0; f < s.mesh.faces.rows(); ++f) {
    const double x = s.centroid(f, 0), z = s.centroid(f, 2);
    if (x > 0.05 && x < 0.054 && z > 0.05 && z < 0.054) { EXPECT_TRUE(c.design[f]) << "the hole is filled"; }
    if (x < 0.015 && z < 0.015) { EXPECT_FALSE(c.design[f]) << "the island is gone"; }
  }
  // Kept faces (attachments) hold their island.
  const std::vector<uint8_t> keep = s.Where([](double x, double z) { return x < 0.012 && z < 0.012; });
  const CleanedDesign k = CleanDesign(s.mesh, d, {.min_feature_m = 0.003, .min_area_m2 = 25e-6}, keep);
  EXPECT_EQ(k.islands_removed, 0);
}

TEST(ReinforcementPatches, AStraightBandKeepsItsExactOutlineAndAreaAndAHoleRunsClockwise) {
  const Sheet100 s;
  Result<Pattern> p = CutPattern(s.mesh);
  ASSERT_TRUE(p.ok()) << p.message();
  const std::vector<uint8_t> d = s.Where([](double x, double z) {
    return x > 0.03 && x < 0.07 && z > 0.01 && z < 0.09 && !(x > 0.045 && x < 0.055 && z > 0.045 && z < 0.055);
  });
  const std::vector<Patch> patches = ReinforcementPatches(*p, d);
  ASSERT_EQ(patches.size(), 1u);
  const Patch& patch = patches[0];
  EXPECT_NEAR(patch.area_m2, 0.04 * 0.08 - 0.01 * 0.01, 1e-12);
  EXPECT_NEAR(patch.outline_area_m2, patch.area_m2, 1e-12);
  const Eigen::RowVector2d extent = patch.outline.colwise().maxCoeff() - patch.outline.colwise().minCoeff();
  EXPECT_NEAR(extent.minCoeff(), 0.04, 1e-12);
  EXPECT_NEAR(extent.maxCoeff(), 0.08, 1e-12);
  ASSERT_EQ(patch.holes.size(), 1u);
  EXPECT_LT(SignedArea(patch.holes[0]), 0);
  EXPECT_GT(SignedArea(patch.outline), 0);
}

TEST(ReinforcementPatches, AStaircaseIsFairedAndKeepsItsAreaWithinAPercent) {
  const Sheet100 s;
  Result<Pattern> p = CutPattern(s.mesh);
  ASSERT_TRUE(p.ok());
  // A disc of radius 30 mm: a staircase of grid triangles.
  const std::vector<uint8_t> d = s.Where([](double x, double z) { return std::hypot(x - 0.05, z - 0.05) < 0.03; });
  const std::vector<Patch> patches = ReinforcementPatches(*p, d);
  ASSERT_EQ(patches.size(), 1u);
  EXPECT_NEAR(patches[0].outline_area_m2 / patches[0].area_m2, 1, 0.01);
  // Faired: every outline vertex lies close to the circle (the staircase's corners stick out ~0.5 mm).
  double worst = 0;
  for (Eigen::Index i = 0; i < patches[0].outline.rows(); ++i) {
    const Eigen::RowVector2d q = patches[0].outline.row(i);
    worst = std::max(worst, std::abs((q - patches[0].outline.colwise().mean()).norm() - 0.03));
  }
  EXPECT_LT(worst, 0.0008);
}

}  // namespace
}  // namespace kgd
