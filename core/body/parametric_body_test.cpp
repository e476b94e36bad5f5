// The parametric body (issue: bodies, garments and scenes, acceptance 3): a closed, consistently
// oriented surface without self-intersection in the rest pose and in every built-in pose, made to
// measure, with muscles that bulge when the joints flex.
#include "core/body/parametric_body.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <numbers>

#include "core/testing/self_intersection.h"
#include "core/mesh/topology.h"

namespace kgd {
namespace {

constexpr double kDeg = std::numbers::pi / 180.0;

const ParametricBody& Body() {
  static const Result<ParametricBody> body = BuildParametricBody();
  EXPECT_TRUE(body.ok()) << body.message();
  return *body;
}

TEST(ParametricBody, RestSurfaceIsAClosedOutwardSphereOfTheRightSize) {
  const ParametricBody& b = Body();
  const TriMesh& m = b.rest;
  EXPECT_GE(m.vertices.rows(), 10000);
  EXPECT_LE(m.vertices.rows(), 30000);
  const Status s = CheckClosedOrientedManifold(m.faces, "body");
  EXPECT_TRUE(s.ok()) << s.message();
  EXPECT_EQ(EulerCharacteristic(m.faces), 2);  // watertight, no handles: no openings to document
  EXPECT_TRUE(ValidateMesh(m.vertices, m.faces, "body").ok());
  const double volume = EnclosedVolume(m.vertices, m.faces);
  EXPECT_GT(volume, 0.04);  // outward normals; a 1.70 m adult is about 0.06-0.07 m^3
  EXPECT_LT(volume, 0.09);
  const double height = m.vertices.col(1).maxCoeff() - m.vertices.col(1).minCoeff();
  EXPECT_NEAR(height, b.measurements.height_m, 0.03 * b.measurements.height_m);
  EXPECT_TRUE(SelfIntersections(m.vertices, m.faces, 1).empty());
}

TEST(ParametricBody, LimbGirthsMatchTheMeasurements) {
  const ParametricBody& b = Body();
  const BodyMeasurements& m = b.measurements;
  EXPECT_NEAR(LimbGirth(b, {}, b.rest.vertices, kUpperArmR, 0.5), m.upper_arm_circumference_m, 0.05 * m.upper_arm_circumference_m);
  EXPECT_NEAR(LimbGirth(b, {}, b.rest.vertices, kThighL, 0.4), m.thigh_circumference_m, 0.05 * m.thigh_circumference_m);
}

TEST(ParametricBody, MadeToMeasure) {
  BodyMeasurements m;
  m.upper_arm_circumference_m = 0.36;
  m.resolution_m = 0.013;
  const Result<ParametricBody> b = BuildParametricBody(m);
  ASSERT_TRUE(b.ok()) << b.message();
  EXPECT_NEAR(LimbGirth(*b, {}, b->rest.vertices, kUpperArmL, 0.5), 0.36, 0.05 * 0.36);
  EXPECT_TRUE(CheckClosedOrientedManifold(b->rest.faces, "body").ok());
}

// A body of another size made with the default body's mesh (ParametricBodyLike): the same faces, and
// the girths, height and volume of its own measurements (the default body's own mesh for them would
// have other faces: surface nets on a grid).
TEST(ParametricBody, ABodyOfAnotherSizeKeepsTheMeshTopology) {
  const ParametricBody& b = Body();
  BodyMeasurements m = b.measurements;
  for (double* g : {&m.chest_circumference_m, &m.waist_circumference_m, &m.hip_circumference_m, &m.upper_arm_circumference_m,
                    &m.forearm_circumference_m, &m.thigh_circumference_m, &m.calf_circumference_m})
    *g *= 1.1;
  for (double* l : {&m.height_m, &m.upper_arm_length_m, &m.forearm_length_m, &m.thigh_length_m, &m.shank_length_m}) *l *= 1.1;
  const Result<ParametricBody> large = ParametricBodyLike(b, m);
  ASSERT_TRUE(large.ok()) << large.message();
  EXPECT_TRUE(large->rest.faces == b.rest.faces);
  EXPECT_EQ(large->measurements.height_m, m.height_m);
  EXPECT_TRUE(ValidateMesh(large->rest.vertices, large->rest.faces, "body").ok());
  EXPECT_NEAR(LimbGirth(*large, {}, large->rest.vertices, kThighR, 0.4), m.thigh_circumference_m, 0.05 * m.thigh_circumference_m);
  EXPECT_NEAR(LimbGirth(*large, {}, large->rest.vertices, kUpperArmL, 0.5), m.upper_arm_circumference_m, 0.05 * m.upper_arm_circumference_m);
  const double height = large->rest.vertices.col(1).maxCoeff() - large->rest.vertices.col(1).minCoeff();
  EXPECT_NEAR(height, m.height_m, 0.03 * m.height_m);
  // Volume grows as girth^2 x height: 1.1^3.
  EXPECT_NEAR(EnclosedVolume(large->rest.vertices, large->rest.faces) / EnclosedVolume(b.rest.vertices, b.rest.faces), 1.331, 0.05);
  EXPECT_TRUE(SelfIntersections(large->rest.vertices, large->rest.faces, 1).empty());
}

TEST(ParametricBody, BadMeasurementsAndAnglesAreNamed) {
  BodyMeasurements m;
  m.thigh_circumference_m = 2.0;
  const Result<ParametricBody> b = BuildParametricBody(m);
  ASSERT_FALSE(b.ok());
  EXPECT_NE(b.message().find("thigh_circumference_m = 2 is outside ["), std::string::npos) << b.message();
  const Result<Positions> p = PoseBody(Body(), {{"r_elbw_flex", 1.0}});
  ASSERT_FALSE(p.ok());
  EXPECT_NE(p.message().find("r_elbw_flex"), std::string::npos) << p.message();
  EXPECT_FALSE(PoseBody(Body(), {{"r_elbow_flex", std::nan("")}}).ok());
  EXPECT_NE(PoseBody(Body(), {{"r_elbow_flex", 12.5}}).message().find("'r_elbow_flex' = 12.5 rad"), std::string::npos);
}

TEST(ParametricBody, MusclesBulgeWithFlexion) {
  const ParametricBody& b = Body();
  const JointAngles flexed = {{"r_elbow_flex", 100 * kDeg}, {"r_knee_flex", 90 * kDeg}};
  const Result<Positions> p = PoseBody(b, flexed);
  ASSERT_TRUE(p.ok()) << p.message();
  const double biceps_rest = LimbGirth(b, {}, b.rest.vertices, kUpperArmR, 0.5);
  const double biceps_flexed = LimbGirth(b, flexed, *p, kUpperArmR, 0.5);
  const double thigh_rest = LimbGirth(b, {}, b.rest.vertices, kThighR, 0.4);
  const double thigh_flexed = LimbGirth(b, flexed, *p, kThighR, 0.4);
  std::printf("biceps girth %.1f -> %.1f mm, thigh girth %.1f -> %.1f mm\n", 1e3 * biceps_rest, 1e3 * biceps_flexed,
              1e3 * thigh_rest, 1e3 * thigh_flexed);
  EXPECT_GT(biceps_flexed, 1.03 * biceps_rest);
  EXPECT_GT(thigh_flexed, 1.03 * thigh_rest);
  // The other arm did not move and does not bulge.
  EXPECT_NEAR(LimbGirth(b, flexed, *p, kUpperArmL, 0.5), LimbGirth(b, {}, b.rest.vertices, kUpperArmL, 0.5), 1e-3);
}

TEST(ParametricBody, BentJointsKeepTheirGirth) {
  // Dual-quaternion skinning and the fillet: no candy wrapper, no collapse at the elbow (linear blend
  // skinning loses a third of the girth there), and no swelling away from it. Near the bent joint the
  // section plane runs through the crease, so its loop may be a little shorter than at rest.
  const ParametricBody& b = Body();
  const JointAngles flexed = {{"r_elbow_flex", 100 * kDeg}};
  const Result<Positions> p = PoseBody(b, flexed);
  ASSERT_TRUE(p.ok());
  for (double t : {0.1, 0.2, 0.5}) {
    const double rest = LimbGirth(b, {}, b.rest.vertices, kForearmR, t);
    const double bent = LimbGirth(b, flexed, *p, kForearmR, t);
    std::printf("forearm girth at t = %.2f: %.1f -> %.1f mm\n", t, 1e3 * rest, 1e3 * bent);
    EXPECT_GT(bent, 0.85 * rest) << "forearm at t = " << t;
    if (t == 0.5) {
      EXPECT_NEAR(bent, rest, 0.02 * rest) << "forearm at t = " << t;
    }
  }
}

TEST(ParametricBody, BentJointsKeepTheirGirthRoundTheCrease) {
  // Round the joint itself (the plane bisecting the bend) two rigid round limbs and their fillet grow:
  // without the crease's pinch the elbow's girth grows by 14 % at 100 degrees and the knee's by 10 %
  // at 90, and a sleeve is stretched all round the joint. Real flesh gives way in the crease, and the
  // MakeHuman elbow keeps its girth (its sleeve's hoop stretch there is 1.00-1.03).
  const ParametricBody& b = Body();
  const JointAngles flexed = {{"r_elbow_flex", 100 * kDeg}, {"r_knee_flex", 90 * kDeg}};
  const Result<Positions> p = PoseBody(b, flexed);
  ASSERT_TRUE(p.ok()) << p.message();
  for (int bone : {kForearmR, kShankR}) {
    const double rest = JointGirth(b, {}, b.rest.vertices, bone);
    const double bent = JointGirth(b, flexed, *p, bone);
    std::printf("%s girth round the joint: %.1f -> %.1f mm (%.3f)\n", BoneName(bone), 1e3 * rest, 1e3 * bent, bent / rest);
    EXPECT_NEAR(bent, rest, 0.05 * rest) << BoneName(bone);
  }
}

TEST(ParametricBody, BentElbowSkinKeepsItsMetric) {
  // Skinning and projection alone stretch the skin at the inside of a bent elbow up to 2.2x around
  // the arm; the skin relaxation brings every edge near the elbow within reach of its rest length
  // (the outside of the elbow must stretch, ~30 % along the arm, as real skin does).
  const ParametricBody& b = Body();
  const Result<Positions> p = PoseBody(b, {{"r_elbow_flex", 100 * kDeg}});
  ASSERT_TRUE(p.ok());
  const Faces& f = b.rest.faces;
  std::vector<double> stretched;  // edge length ratios above 1.05
  for (Eigen::Index i = 0; i < f.rows(); ++i)
    for (int k = 0; k < 3; ++k) {
      const int u = f(i, k), v = f(i, (k + 1) % 3);
      const double ratio = (p->row(u) - p->row(v)).norm() / (b.rest.vertices.row(u) - b.rest.vertices.row(v)).norm();
      if (ratio > 1.05) stretched.push_back(ratio);
    }
  ASSERT_FALSE(stretched.empty());
  std::sort(stretched.begin(), stretched.end());
  const double p90 = stretched[stretched.size() * 9 / 10], p99 = stretched[stretched.size() * 99 / 100];
  std::printf("edges stretched > 5 %% at a 100 degree elbow: %zu, 90th percentile %.2f, 99th %.2f, largest %.2f\n",
              stretched.size(), p90, p99, stretched.back());
  EXPECT_LT(p99, 1.8);
}

}  // namespace
}  // namespace kgd
