#include "core/body/body_field.h"

#include <gtest/gtest.h>

#include "core/scene/shapes.h"

namespace kgd {
namespace {

// A capsule limb with a straight, round middle (radius 4 cm, 48 vertices around).
TriMesh Cylinder() {
  LimbShape s;
  s.waist_depth = 0;
  s.around = 48;
  return LimbRest(s);
}

TEST(BodyField, IsASignedDistanceNearTheSurfaceOfACylinder) {
  const TriMesh m = Cylinder();
  auto field = BodyField::Build(m.vertices, m.faces);
  ASSERT_TRUE(field.ok()) << field.message();
  NeighborCache cache;
  // On the straight part, Phi approximates radius - R (positive outside); polygonal facets make the
  // IMLS surface sit within a fraction of the sagitta of the true circle.
  for (double r : {0.035, 0.038, 0.04, 0.042, 0.044}) {
    const FieldSample f = (*field)->Evaluate(Eigen::Vector3d(r, 0.08, 0), &cache, true, false);
    ASSERT_TRUE(f.supported) << r;
    EXPECT_NEAR(f.phi_m, r - 0.04, 3e-4) << r;
    EXPECT_NEAR(f.grad.x(), 1.0, 0.05);
  }
  // Far away: no kernel support.
  EXPECT_FALSE((*field)->Evaluate(Eigen::Vector3d(0.5, 0, 0), &cache, false, false).supported);
}

TEST(BodyField, GradientAndHessianMatchFiniteDifferences) {
  LimbShape s;
  s.around = 20;
  const TriMesh m = LimbRest(s);
  auto field = BodyField::Build(m.vertices, m.faces);
  ASSERT_TRUE(field.ok());
  NeighborCache cache;
  for (const Eigen::Vector3d& x : {Eigen::Vector3d(0.038, 0.01, 0.01), Eigen::Vector3d(-0.01, 0.03, 0.036),
                                  Eigen::Vector3d(0.0, 0.21, 0.03)}) {
    const FieldSample f = (*field)->Evaluate(x, &cache, true, true);
    ASSERT_TRUE(f.supported);
    const double h = 1e-6;
    for (int i = 0; i < 3; ++i) {
      Eigen::Vector3d xp = x, xm = x;
      xp[i] += h;
      xm[i] -= h;
      const FieldSample p = (*field)->Evaluate(xp, &cache, true, false), q = (*field)->Evaluate(xm, &cache, true, false);
      EXPECT_NEAR((p.phi_m - q.phi_m) / (2 * h), f.grad[i], 1e-6);
      EXPECT_LT(((p.grad - q.grad) / (2 * h) - f.hess.col(i)).norm(), 1e-4 * std::max(1.0, f.hess.norm()));
    }
  }
}

TEST(BodyField, NeighbourCacheIsRebuiltOnlyAfterMovingBeyondItsMargin) {
  LimbShape s;
  const TriMesh m = LimbRest(s);
  auto field = BodyField::Build(m.vertices, m.faces);
  ASSERT_TRUE(field.ok());
  NeighborCache cache;
  const Eigen::Vector3d x(0.04, 0, 0);
  (*field)->Evaluate(x, &cache, false, false);
  EXPECT_EQ(cache.rebuilds, 1);
  const double margin = (*field)->cache_margin_m();
  (*field)->Evaluate(x + Eigen::Vector3d(0, 0.9 * margin, 0), &cache, false, false);
  EXPECT_EQ(cache.rebuilds, 1);
  // A cached evaluation equals a fresh one.
  NeighborCache fresh;
  const Eigen::Vector3d y = x + Eigen::Vector3d(0, 0.9 * margin, 0);
  EXPECT_DOUBLE_EQ((*field)->Evaluate(y, &cache, false, false).phi_m, (*field)->Evaluate(y, &fresh, false, false).phi_m);
  (*field)->Evaluate(x + Eigen::Vector3d(0, 1.1 * margin, 0), &cache, false, false);
  EXPECT_EQ(cache.rebuilds, 2);
}

// Points near a cylinder's surface (the body's own vertices, face midpoints, points 2 mm off) land on
// the zero set, close to where they started; a point beyond the support is refused by its index.
TEST(BodyField, PlaceOnZeroSetPutsPointsOnTheSurface) {
  const TriMesh m = Cylinder();
  auto field = BodyField::Build(m.vertices, m.faces);
  ASSERT_TRUE(field.ok()) << field.message();
  Positions points(4, 3);
  points.row(0) = m.vertices.row(m.faces(100, 0));
  points.row(1) = (m.vertices.row(m.faces(100, 0)) + m.vertices.row(m.faces(100, 1)) + m.vertices.row(m.faces(100, 2))) / 3.0;
  points.row(2) << 0.042, 0.08, 0;
  points.row(3) << 0, 0.08, 0.038;
  Result<Positions> placed = PlaceOnZeroSet(**field, points, "point");
  ASSERT_TRUE(placed.ok()) << placed.message();
  NeighborCache cache;
  for (int i = 0; i < 4; ++i) {
    const Eigen::Vector3d x = placed->row(i).transpose();
    EXPECT_LE(std::abs((*field)->Evaluate(x, &cache, false, false).phi_m), 1e-12) << i;
    EXPECT_LE((placed->row(i) - points.row(i)).norm(), 2.5e-3) << i;
  }
  Positions far = points;
  far.row(2) << 0.5, 0, 0;
  Result<Positions> refused = PlaceOnZeroSet(**field, far, "garment vertex");
  ASSERT_FALSE(refused.ok());
  EXPECT_NE(refused.message().find("garment vertex 2 at (0.5, 0, 0) m"), std::string::npos) << refused.message();
}

TEST(BodyField, RejectsAnInvalidBodyMesh) {
  Positions v(3, 3);
  v << 0, 0, 0, 1, 0, 0, 2, 0, 0;
  Faces f(1, 3);
  f << 0, 1, 2;
  auto field = BodyField::Build(v, f);
  ASSERT_FALSE(field.ok());
  EXPECT_NE(field.message().find("face 0 has zero area"), std::string::npos) << field.message();
}

}  // namespace
}  // namespace kgd
