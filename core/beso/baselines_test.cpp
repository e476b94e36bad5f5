// Line and X baselines on a straight tube, where s and theta are known in closed form.
#include "core/beso/baselines.h"

#include <gtest/gtest.h>

#include <cmath>

#include "core/sim/garment_system.h"

namespace kgd {
namespace {

// A tube of radius r along z from 0 to length, `around` x `along` quads split in two triangles;
// attachment bands = the first and last rows of quads.
struct Tube {
  TriMesh mesh;
  std::vector<int> bands;
};
Tube MakeTube(int around, int along, double r = 0.05, double length = 0.3) {
  Tube t;
  t.mesh.vertices.resize(around * (along + 1), 3);
  for (int j = 0; j <= along; ++j)
    for (int i = 0; i < around; ++i) {
      const double a = 2 * M_PI * i / around;
      t.mesh.vertices.row(j * around + i) << r * std::cos(a), r * std::sin(a), length * j / along;
    }
  t.mesh.faces.resize(2 * around * along, 3);
  int f = 0;
  for (int j = 0; j < along; ++j)
    for (int i = 0; i < around; ++i) {
      const int a = j * around + i, b = j * around + (i + 1) % around, c = a + around, d = b + around;
      if (j == 0 || j == along - 1) {
        t.bands.push_back(f);
        t.bands.push_back(f + 1);
      }
      t.mesh.faces.row(f++) << a, b, d;
      t.mesh.faces.row(f++) << a, d, c;
    }
  return t;
}

double Wrap(double a) { return std::remainder(a, 2 * M_PI); }

TEST(Baselines, CoordinatesFollowTheTube) {
  const Tube t = MakeTube(48, 30);
  const Result<GarmentCoordinates> c = ComputeGarmentCoordinates(t.mesh, t.bands);
  ASSERT_TRUE(c.ok()) << c.message();
  const Positions centroids = FaceCentroids(t.mesh.vertices, t.mesh.faces, [&] {
    std::vector<int> all(t.mesh.faces.rows());
    for (size_t f = 0; f < all.size(); ++f) all[f] = static_cast<int>(f);
    return all;
  }());
  // s is linear in z between the bands (harmonic on a uniform tube); theta = the polar angle + a constant.
  const double offset = Wrap(c->theta[0] - std::atan2(centroids(0, 1), centroids(0, 0)));
  for (Eigen::Index f = 0; f < centroids.rows(); ++f) {
    const double z = centroids(f, 2);
    if (z > 0.01 && z < 0.29) {
      EXPECT_NEAR(c->s[f], (z - 0.01) / 0.28, 0.02) << "face " << f;
    }
    EXPECT_NEAR(Wrap(c->theta[f] - std::atan2(centroids(f, 1), centroids(f, 0)) - offset), 0.0, 1e-9) << "face " << f;
  }
}

TEST(Baselines, LineAndXMeetTheAreaAndHaveTheirShapes) {
  const Tube t = MakeTube(64, 40);
  const Result<GarmentCoordinates> c = ComputeGarmentCoordinates(t.mesh, t.bands);
  ASSERT_TRUE(c.ok());
  const Eigen::VectorXd area = FaceAreas(t.mesh.vertices, t.mesh.faces);
  const double target = 0.15 * area.sum();
  for (BaselineShape shape : {BaselineShape::kLine, BaselineShape::kX}) {
    const std::vector<uint8_t> d = BaselineDesign(*c, area, shape, 0.3, target);
    double a = 0;
    for (size_t f = 0; f < d.size(); ++f) a += d[f] == kReinforced ? area[f] : 0.0;
    // Whole columns of faces enter together (2 per row x 40 rows), so the area is met to one column.
    EXPECT_NEAR(a, target, 2 * 40 * area.maxCoeff()) << ToString(shape);
    for (size_t f = 0; f < d.size(); ++f) {
      if (d[f] != kReinforced) continue;
      if (shape == BaselineShape::kLine) {
        EXPECT_LT(std::abs(Wrap(c->theta[f] - 0.3)), 0.15 * M_PI + 0.1) << "face " << f;
      } else {
        const double sh = M_PI * (c->s[f] - 0.5);
        EXPECT_LT(std::min(std::abs(Wrap(c->theta[f] - 0.3 - sh)), std::abs(Wrap(c->theta[f] - 0.3 + sh))), 0.15 * M_PI) << "face " << f;
      }
    }
  }
  // The X's two arms cross in the middle and sit half a turn apart at the bands.
  const std::vector<uint8_t> x = BaselineDesign(*c, area, BaselineShape::kX, 0.0, 0.1 * area.sum());
  for (size_t f = 0; f < x.size(); ++f) {
    if (std::abs(c->s[f] - 0.5) < 0.02 && std::abs(Wrap(c->theta[f])) < 0.05) {
      EXPECT_EQ(x[f], kReinforced) << "face " << f;
    }
    if (std::abs(Wrap(c->theta[f] - M_PI)) < 0.3) {
      EXPECT_EQ(x[f], kCloth) << "face " << f;
    }
  }
  // The weighted mean angle finds where the weight is.
  Eigen::VectorXd w = Eigen::VectorXd::Zero(area.size());
  for (Eigen::Index f = 0; f < w.size(); ++f) w[f] = std::exp(4 * std::cos(c->theta[f] - 1.0));
  EXPECT_NEAR(WeightedMeanAngle(*c, w), 1.0, 1e-3);
}

TEST(Baselines, NeedTwoBands) {
  const Tube t = MakeTube(16, 10);
  std::vector<int> one(t.bands.begin(), t.bands.begin() + 32);
  const Result<GarmentCoordinates> c = ComputeGarmentCoordinates(t.mesh, one);
  ASSERT_FALSE(c.ok());
  EXPECT_NE(c.message().find("this garment has 1"), std::string::npos) << c.message();
}

}  // namespace
}  // namespace kgd
