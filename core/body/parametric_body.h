// A parametric human body written for this project: a skeleton and a smooth closed surface made to
// measure from a handful of measurements, posed by joint angles with pose-dependent muscle bulging.
//
// The surface is the zero level set of an implicit body: elliptic round cones along the bones, joined
// by smooth minima (blend radii grow with the bend of a joint, so bent elbows and knees get a fillet
// instead of a crease or an interpenetration). The rest mesh is polygonized once (surface nets, then
// projected onto the level set); a pose moves every rest vertex with dual-quaternion skinning (no
// candy-wrapper twist) and projects it onto the posed implicit body, so every pose is a surface with
// the rest mesh's topology.
//
// Conventions (as ../shared/bodies/ uses them): metres, +y up, +z forward (the body faces +z), +x is
// the body's left, the floor is y = 0 near the feet. Angles are radians in code; the joint names and
// sign conventions are those of the MakeHuman data's README (l_elbow_flex, r_knee_flex, ...).
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <array>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "core/mesh/trimesh.h"
#include "core/util/status.h"

namespace kgd {

// Circumferences are girths of the surface (m), lengths are between joint centres (m).
struct BodyMeasurements {
  double height_m = 1.70;
  double chest_circumference_m = 0.96;
  double waist_circumference_m = 0.80;
  double hip_circumference_m = 0.98;
  double upper_arm_circumference_m = 0.29;
  double forearm_circumference_m = 0.26;
  double thigh_circumference_m = 0.54;
  double calf_circumference_m = 0.36;
  double upper_arm_length_m = 0.30;  // shoulder to elbow
  double forearm_length_m = 0.26;    // elbow to wrist
  double thigh_length_m = 0.43;      // hip to knee
  double shank_length_m = 0.43;      // knee to ankle
  double resolution_m = 0.013;       // edge length of the surface mesh (m): 15k vertices at 1.3 cm, 38k at 8 mm; at most 13 mm
};

// Every measurement by name, with its default and the range ValidateMeasurements accepts (SI).
struct MeasurementRange {
  const char* name;
  double default_value, min, max;
};
std::vector<MeasurementRange> BodyMeasurementRanges();

// Ranges that keep the construction meaningful (e.g. a thigh thinner than the knee is refused).
Status ValidateMeasurements(const BodyMeasurements& m);

// Sets one measurement by its field name ("height_m", "upper_arm_circumference_m", ...); unknown names
// are errors that list the known ones. The value is checked by ValidateMeasurements.
Status SetMeasurement(BodyMeasurements* m, const std::string& name, double value);
// `name=value` items (SI, as given to --body) into measurements; none given: no value.
Result<std::optional<BodyMeasurements>> ParseBodyMeasurements(const std::vector<std::string>& items);

enum Bone : int {
  kPelvis, kLumbar, kThorax, kChest, kNeck, kHead,
  kClavicleL, kUpperArmL, kForearmL, kHandL, kClavicleR, kUpperArmR, kForearmR, kHandR,
  kThighL, kShankL, kFootL, kThighR, kShankR, kFootR,
  kNumBones
};
const char* BoneName(int bone);

// Joint angles (rad) by name; a pose lists only what differs from the rest pose.
using JointAngles = std::map<std::string, double>;
// Every accepted joint-angle name.
std::vector<std::string> JointAngleNames();
// Unknown names and non-finite values are errors that name the joint.
Status ValidateJointAngles(const JointAngles& angles);
// The rest pose of the generated body (a relaxed A-pose): shoulders abducted 45 deg, elbows flexed
// 15 deg, knees 5 deg, everything else 0 -- the same rest pose as the MakeHuman data.
JointAngles RestAngles();

// One elliptic round cone along a bone, in rest coordinates: centre line a -> b; cross-section radii
// along u1 (lateral) and u2 (anterior) vary linearly from a to b plus `mid_bulge_m * sin(pi t)`;
// the caps are ellipsoids. `flex_bulge` widens the anterior radius (biceps) or the whole section
// (thigh) in proportion to the flexion of `bulge_joint` beyond its rest value.
struct BodyPrimitive {
  int bone = kPelvis;
  Eigen::Vector3d a, b, u1, u2;
  double r1_a = 0, r2_a = 0, r1_b = 0, r2_b = 0, mid_bulge_m = 0;
  std::string bulge_joint;      // e.g. "r_elbow_flex"; empty for none
  double bulge_per_rad = 0;     // relative radius increase per radian of extra flexion
  bool bulge_anterior_only = false;
};

struct ParametricBody {
  BodyMeasurements measurements;
  std::array<Eigen::Vector3d, kNumBones> joint;  // rest position of each bone's proximal joint
  std::array<int, kNumBones> parent;            // -1 for the pelvis (root)
  std::vector<BodyPrimitive> primitives;
  TriMesh rest;                                 // surface in RestAngles()
  // Skinning: up to four (bone, weight) pairs per rest vertex, weights summing to one.
  std::vector<std::array<std::pair<int, double>, 4>> weights;
  std::vector<int> dominant_bone;               // per rest vertex
};

// Builds the skeleton, the implicit body and the rest mesh. Errors name the offending measurement.
Result<ParametricBody> BuildParametricBody(const BodyMeasurements& m = {});

// The parametric body made to `m` with the rest mesh of `like` (its faces and skinning weights), so
// that the two bodies and all their poses share one mesh topology (a garment cut from one region of
// faces is the same garment on both): each rest vertex of `like` is carried bone by bone (along each
// bone's primitive by the ratio of its lengths, across by the ratio of its radii, blended with the
// skinning weights), projected onto the new implicit body and relaxed along it, as the rest mesh of
// BuildParametricBody is. Errors: bad measurements, a carried mesh that folds over (measurements far
// from like's). The parametric body's own rest mesh changes with the measurements (surface nets on a
// grid), so bodies of other sizes that must share a garment are made with this.
Result<ParametricBody> ParametricBodyLike(const ParametricBody& like, const BodyMeasurements& m);

// Rigid motion of every bone from rest to the pose `angles` (rest values where a name is missing).
std::array<Eigen::Isometry3d, kNumBones> BoneTransforms(const ParametricBody& body, const JointAngles& angles);

// The rest mesh's vertices in the pose `angles`. The skin moves from the rest pose in steps of at most
// 10 degrees per joint (each step: skinning increment, projection onto that step's implicit body,
// relaxation of folded patches), so a pose depends on the path: see PoseSequence.
Result<Positions> PoseBody(const ParametricBody& body, const JointAngles& angles);

// A motion's keyframes: its rest pose, then `frames` poses interpolating every angle linearly, frame k
// at t = k / frames (the last is `pose`). Angles missing from `rest` take the body's rest values; angles
// missing from `pose` keep their value in `rest`. With frames = 0: {rest, pose}.
std::vector<JointAngles> MotionKeyframes(const JointAngles& rest, const JointAngles& pose, int frames);

// The rest mesh's vertices at each keyframe, moving from the rest pose through the keyframes in
// order (joint angles interpolated linearly between consecutive keyframes). A motion's frames are
// its keyframes; posing them in one sequence is cheaper than one by one.
Result<std::vector<Positions>> PoseSequence(const ParametricBody& body, const std::vector<JointAngles>& keyframes);

// Girth of a limb (m): the length of the loop where the plane through the point at fraction `t` of
// the bone (joint to child joint), perpendicular to the bone, cuts the posed surface, keeping only
// the loop around the bone. For the upper arm, forearm, thigh and shank.
double LimbGirth(const ParametricBody& body, const JointAngles& angles, const Positions& posed, int bone, double t);

// Girth round a joint (m): the loop where the plane through the joint that bisects the bend cuts
// the posed surface. `bone` is the child (forearm for the elbow, shank for the knee); its parent must
// carry primitives (not a clavicle).
double JointGirth(const ParametricBody& body, const JointAngles& angles, const Positions& posed, int bone);

// Position (rest) of the distal end of a bone: its first child's joint (the tip for hands, feet, head).
Eigen::Vector3d BoneEnd(const ParametricBody& body, int bone);

}  // namespace kgd
