#include "core/mesh/surface_nets.h"

#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <cmath>

#include "core/testing/self_intersection.h"
#include "core/mesh/topology.h"

namespace kgd {
namespace {

TEST(SurfaceNets, SphereIsAClosedOutwardManifoldNearTheSurface) {
  const double r = 0.1037, h = 0.01;  // not a multiple of h: no surface point on a grid node
  const TriMesh m = SurfaceNets([&](const Eigen::Vector3d& p) { return p.norm() - r; }, Eigen::Vector3d::Constant(-0.15),
                                Eigen::Vector3d::Constant(0.15), h);
  ASSERT_GT(m.faces.rows(), 100);
  EXPECT_TRUE(CheckClosedOrientedManifold(m.faces, "sphere").ok());
  EXPECT_EQ(EulerCharacteristic(m.faces), 2);
  for (Eigen::Index v = 0; v < m.vertices.rows(); ++v) EXPECT_NEAR(m.vertices.row(v).norm(), r, h);
  const double volume = 4.0 / 3.0 * std::acos(-1.0) * r * r * r;
  EXPECT_NEAR(EnclosedVolume(m.vertices, m.faces), volume, 0.05 * volume);  // positive: faces point outwards
  EXPECT_TRUE(SelfIntersections(m.vertices, m.faces).empty());
}

TEST(SurfaceNets, TorusHasGenusOne) {
  const double R = 0.1, a = 0.04;
  const TriMesh m = SurfaceNets(
      [&](const Eigen::Vector3d& p) { return std::hypot(std::hypot(p.x(), p.y()) - R, p.z()) - a; },
      Eigen::Vector3d(-0.16, -0.16, -0.06), Eigen::Vector3d(0.16, 0.16, 0.06), 0.008);
  EXPECT_TRUE(CheckClosedOrientedManifold(m.faces, "torus").ok());
  EXPECT_EQ(EulerCharacteristic(m.faces), 0);
}

}  // namespace
}  // namespace kgd
