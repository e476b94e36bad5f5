#include "core/scene/paper_scenes.h"

#include <algorithm>
#include <array>
#include <map>
#include <cmath>
#include <numbers>

#include "core/mesh/topology.h"

namespace kgd {
namespace {

constexpr double kDeg = std::numbers::pi / 180.0;

JointAngles Degrees(std::initializer_list<std::pair<const std::string, double>> list) {
  JointAngles out;
  for (const auto& [name, deg] : list) out[name] = deg * kDeg;
  return out;
}

// Grows and trims a face set into a clean garment: pockets filled, ears and pinched boundary
// vertices removed, the largest piece kept.
std::vector<int> CleanRegion(const Faces& faces, int num_vertices, std::vector<char> in) {
  const int nf = static_cast<int>(faces.rows());
  // Face neighbours across edges.
  std::vector<std::array<int, 3>> across(nf, {-1, -1, -1});
  {
    std::map<std::pair<int, int>, std::pair<int, int>> edge;  // (a, b) -> (face, slot)
    for (int f = 0; f < nf; ++f)
      for (int k = 0; k < 3; ++k) {
        const int a = faces(f, k), b = faces(f, (k + 1) % 3);
        auto it = edge.find({b, a});
        if (it != edge.end()) {
          across[f][k] = it->second.first;
          across[it->second.first][it->second.second] = f;
        } else {
          edge[{a, b}] = {f, k};
        }
      }
  }
  auto count_in = [&](int f) {
    int c = 0;
    for (int g : across[f]) c += g >= 0 && in[g];
    return c;
  };
  for (int round = 0; round < 20; ++round) {
    bool changed = false;
    for (int f = 0; f < nf; ++f)
      if (!in[f] && count_in(f) >= 2) in[f] = 1, changed = true;
    for (int f = 0; f < nf; ++f)
      if (in[f] && count_in(f) <= 1) in[f] = 0, changed = true;
    // Pinches: a vertex with more than two boundary edges.
    std::vector<int> boundary_edges(num_vertices, 0);
    for (int f = 0; f < nf; ++f)
      if (in[f])
        for (int k = 0; k < 3; ++k)
          if (across[f][k] < 0 || !in[across[f][k]]) {
            ++boundary_edges[faces(f, k)];
            ++boundary_edges[faces(f, (k + 1) % 3)];
          }
    for (int f = 0; f < nf; ++f)
      if (in[f])
        for (int k = 0; k < 3; ++k)
          if (boundary_edges[faces(f, k)] > 2) in[f] = 0, changed = true;
    if (!changed) break;
  }
  std::vector<int> ids;
  for (int f = 0; f < nf; ++f)
    if (in[f]) ids.push_back(f);
  if (ids.empty()) return ids;
  const SubMesh sub = ExtractFaces(faces, ids);
  const FacePieces pieces = EdgeConnectedPieces(sub.faces);
  std::vector<int> size(pieces.count, 0);
  for (int p : pieces.piece) ++size[p];
  const int largest = static_cast<int>(std::max_element(size.begin(), size.end()) - size.begin());
  std::vector<int> out;
  for (size_t i = 0; i < ids.size(); ++i)
    if (pieces.piece[i] == largest) out.push_back(ids[i]);
  return out;
}

}  // namespace

std::vector<PaperMotion> PaperMotions() {
  std::vector<PaperMotion> m;
  m.push_back({"arm_flexion", "sleeve_arm", "Right elbow flexes from 15 to 100 degrees; arm sleeve from ~10 cm above to ~10 cm below the elbow.",
               {}, Degrees({{"r_elbow_flex", 100}}), 8, 0.15, 2});
  m.push_back({"arm_extension", "sleeve_arm", "Right elbow extends from 60 to 0 degrees; arm sleeve.",
               Degrees({{"r_elbow_flex", 60}}), Degrees({{"r_elbow_flex", 0}}), 4, 0.15, 2});
  m.push_back({"knee_flexion", "sleeve_knee", "Right hip flexes 45 and knee 90 degrees (ankle -25); knee sleeve from ~12 cm above to ~12 cm below the knee.",
               {}, Degrees({{"r_hip_flex", 45}, {"r_knee_flex", 90}, {"r_ankle_flex", -25}}), 8, 0.10, 1});
  m.push_back({"knee_extension", "sleeve_knee", "Right knee extends from 40 to -5 degrees with the hip flexed 25; knee sleeve.",
               Degrees({{"r_hip_flex", 25}, {"r_knee_flex", 40}}), Degrees({{"r_hip_flex", 25}, {"r_knee_flex", -5}}), 4, 0.15, 1});
  m.push_back({"slouch", "shirt", "Spine flexes 28, neck 15, head -12 degrees, shoulders protract 15; shirt with short sleeves.",
               {},
               Degrees({{"spine01_flex", 10}, {"spine02_flex", 10}, {"spine03_flex", 5}, {"spine04_flex", 3}, {"neck01_flex", 10},
                        {"neck02_flex", 5}, {"head_flex", -12}, {"l_clav_protr", 15}, {"r_clav_protr", 15}, {"l_clav_elev", -4},
                        {"r_clav_elev", -4}, {"l_shoulder_flex", -20}, {"r_shoulder_flex", -20}}),
               8, 0.10, 1});
  // Arms reach forward (the MakeHuman crouch's 45 degrees would put this body's hands into its thighs).
  m.push_back({"crouch", "shorts", "Both hips flex 85 and knees 90 degrees with the trunk pitched 20 forward; shorts.",
               {},
               Degrees({{"l_hip_flex", 85}, {"r_hip_flex", 85}, {"l_knee_flex", 90}, {"r_knee_flex", 90}, {"l_shoulder_flex", 90},
                        {"r_shoulder_flex", 90}, {"trunk_pitch", 20}}),
               4, 0.15, 1});
  m.push_back({"lunge", "shorts", "Right hip flexes 80 and knee 90 degrees forward, left hip extends 25 with the knee at 69; shorts.",
               {}, Degrees({{"r_hip_flex", 80}, {"r_knee_flex", 90}, {"l_hip_flex", -25}, {"l_knee_flex", 69}, {"l_ankle_flex", -29}}),
               4, 0.15, 1});
  return m;
}

std::vector<BraceScene> BraceScenes() {
  using R = MotionRole;
  // The sleeve's bend weighs 15: the resist-only sleeve already leaves the bend nearly free (under 1 % of
  // its fully reinforced density), and at weight 1 the roles lower that little (docs/RESULTS.md).
  std::vector<BraceScene> b;
  b.push_back({"arm_brace", "sleeve_arm",
               "Arm sleeve at a 60 degree elbow that resists the elbow straightening (to 0) and allows it to bend (to 120).",
               Degrees({{"r_elbow_flex", 60}}),
               {{"straighten", R::kResist, 1.0, Degrees({{"r_elbow_flex", 0}}), 4}, {"bend", R::kAllow, 15.0, Degrees({{"r_elbow_flex", 120}}), 4}},
               0.15, 2});
  b.push_back({"knee_brace", "sleeve_knee",
               "Knee sleeve at a 20 degree knee (hip 25) that resists extension past straight (to -5) and allows flexion (to 90).",
               Degrees({{"r_hip_flex", 25}, {"r_knee_flex", 20}}),
               {{"hyperextend", R::kResist, 1.0, Degrees({{"r_knee_flex", -5}}), 4}, {"flex", R::kAllow, 1.0, Degrees({{"r_knee_flex", 90}}), 4}},
               0.15, 1});
  // The slouch is the paper motion's; the reach lifts both arms forward to 90 degrees.
  b.push_back({"posture_shirt", "shirt", "Shirt that resists the slouch and allows both arms to reach forward to 90 degrees.", {},
               {{"slouch", R::kResist, 1.0,
                 Degrees({{"spine01_flex", 10}, {"spine02_flex", 10}, {"spine03_flex", 5}, {"spine04_flex", 3}, {"neck01_flex", 10},
                          {"neck02_flex", 5}, {"head_flex", -12}, {"l_clav_protr", 15}, {"r_clav_protr", 15}, {"l_clav_elev", -4},
                          {"r_clav_elev", -4}, {"l_shoulder_flex", -20}, {"r_shoulder_flex", -20}}),
                 8},
                {"reach_forward", R::kAllow, 1.0, Degrees({{"l_shoulder_flex", 90}, {"r_shoulder_flex", 90}}), 8}},
               0.10, 1});
  return b;
}

Result<SceneSpec> BraceSceneOn(const ParametricBody& body, const BraceScene& brace) {
  Result<BodyRegion> region = ParametricGarmentRegion(body, brace.garment);
  if (!region.ok()) return region.status();
  SceneSpec s;
  s.name = brace.name;
  s.description = brace.description;
  s.budget = brace.budget;
  for (const BraceMotion& bm : brace.motions) {
    Result<std::vector<Positions>> poses = PoseSequence(body, MotionKeyframes(brace.rest, bm.pose, bm.frames));
    if (!poses.ok()) return poses.status().WithContext(brace.name + ", motion '" + bm.name + "': ");
    SceneMotion m;
    m.name = bm.name;
    m.role = bm.role;
    m.weight = bm.weight;
    m.pose.faces = body.rest.faces;
    // One rest pose for all: the first motion's (every sequence starts with the same keyframe).
    m.pose.rest = s.motions.empty() ? (*poses)[0] : s.motions.front().pose.rest;
    m.pose.deformed = poses->back();
    m.pose.frames.assign(poses->begin() + 1, poses->end());
    s.motions.push_back(std::move(m));
  }
  s.motion = s.motions.front().pose;
  s.garment_region = region->faces;
  s.attachment_body_faces = region->attachment_faces;
  s.subdivisions = brace.subdivisions;
  s.effects.contact = ContactModel::kUnilateral;
  s.effects.friction = kPaperSceneFriction;
  s.effects.attachments = true;
  KGD_RETURN_IF_ERROR(CutGarmentFromMotion(&s, brace.name + ": garment " + brace.garment, brace.name + ": attachment bands"));
  KGD_RETURN_IF_ERROR(ValidateSceneMotions(s));
  return s;
}

Result<BodyRegion> ParametricGarmentRegion(const ParametricBody& body, const std::string& garment, double band_width_m) {
  const Positions& x = body.rest.vertices;
  const Faces& faces = body.rest.faces;
  const int nv = static_cast<int>(x.rows());
  auto axial = [&](int v, int bone) {
    const Eigen::Vector3d dir = (BoneEnd(body, bone) - body.joint[bone]).normalized();
    return (x.row(v).transpose() - body.joint[bone]).dot(dir);
  };
  auto length = [&](int bone) { return (BoneEnd(body, bone) - body.joint[bone]).norm(); };
  const double hip_y = body.joint[kPelvis].y();
  std::vector<char> vin(nv, 0);
  for (int v = 0; v < nv; ++v) {
    const int b = body.dominant_bone[v];
    const double y = x(v, 1);
    bool in = false;
    if (garment == "sleeve_arm") {
      in = (b == kUpperArmR && axial(v, b) >= length(b) - 0.10) || (b == kForearmR && axial(v, b) <= 0.10);
    } else if (garment == "sleeve_knee") {
      in = (b == kThighR && axial(v, b) >= length(b) - 0.12) || (b == kShankR && axial(v, b) <= 0.12);
    } else if (garment == "shirt") {
      in = (b == kPelvis || b == kLumbar || b == kThorax || b == kChest ||
            ((b == kUpperArmL || b == kUpperArmR) && axial(v, b) <= 0.5 * length(b))) &&
           y >= hip_y + 0.06;
    } else if (garment == "shorts") {
      in = (b == kPelvis || b == kLumbar || b == kThorax || ((b == kThighL || b == kThighR) && axial(v, b) <= 0.5 * length(b))) &&
           y <= hip_y + 0.10;
    } else {
      return Status::Error("unknown garment '" + garment + "' (sleeve_arm, sleeve_knee, shirt, shorts)");
    }
    vin[v] = in;
  }
  std::vector<char> fin(faces.rows(), 0);
  for (Eigen::Index f = 0; f < faces.rows(); ++f) fin[f] = vin[faces(f, 0)] && vin[faces(f, 1)] && vin[faces(f, 2)];
  BodyRegion region;
  region.faces = CleanRegion(faces, nv, fin);
  if (region.faces.empty()) return Status::Error("garment '" + garment + "' selects no face of the parametric body");

  // Attachment bands along the open ends; the shirt's neckline (the highest end) stays free.
  const SubMesh sub = ExtractFaces(faces, region.faces);
  std::vector<std::vector<int>> loops = BoundaryLoops(sub.faces);
  int neckline = -1;
  if (garment == "shirt") {
    double best = -1e300;
    for (size_t l = 0; l < loops.size(); ++l) {
      double y = 0;
      for (int v : loops[l]) y += x(sub.vertex_ids[v], 1) / loops[l].size();
      if (y > best) best = y, neckline = static_cast<int>(l);
    }
  }
  std::vector<Eigen::Vector3d> held;
  for (size_t l = 0; l < loops.size(); ++l)
    if (static_cast<int>(l) != neckline)
      for (int v : loops[l]) held.push_back(x.row(sub.vertex_ids[v]));
  for (int f : region.faces) {
    const Eigen::Vector3d c = (x.row(faces(f, 0)) + x.row(faces(f, 1)) + x.row(faces(f, 2))).transpose() / 3.0;
    double d = 1e300;
    for (const auto& p : held) d = std::min(d, (p - c).norm());
    if (d < band_width_m) region.attachment_faces.push_back(f);
  }
  return region;
}

Result<const ParametricBody*> DefaultParametricBody() {
  static const Result<ParametricBody> body = BuildParametricBody();
  if (!body.ok()) return body.status();
  return &body.value();
}

Result<SceneSpec> PaperScene(const ParametricBody& body, const PaperMotion& motion) {
  Result<BodyRegion> region = ParametricGarmentRegion(body, motion.garment);
  if (!region.ok()) return region.status();
  const std::vector<JointAngles> keys = MotionKeyframes(motion.rest, motion.pose, motion.frames);
  Result<std::vector<Positions>> poses = PoseSequence(body, keys);
  if (!poses.ok()) return poses.status().WithContext(motion.name + ": ");
  SceneSpec s;
  s.name = motion.name;
  s.description = motion.description;
  s.budget = motion.budget;
  BodyMotion m;
  m.faces = body.rest.faces;
  m.rest = (*poses)[0];
  m.deformed = poses->back();
  m.frames.assign(poses->begin() + 1, poses->end());
  s.motion = std::move(m);
  s.garment_region = region->faces;
  s.attachment_body_faces = region->attachment_faces;
  s.subdivisions = motion.subdivisions;
  s.effects.contact = ContactModel::kUnilateral;
  s.effects.friction = kPaperSceneFriction;
  s.effects.attachments = true;
  if (Status st = CutGarmentFromMotion(&s, motion.name + ": garment " + motion.garment, motion.name + ": attachment bands"); !st.ok())
    return st;
  return s;
}

std::vector<SizedScene> SizedScenes() {
  // Sizes differ mostly in girth, as size charts do: bodies scaled alike in girth and height would be
  // similar figures, whose garments strain alike (a membrane's strain does not change with scale).
  const std::vector<BodySize> sml = {{"M", 1.0, 1.0}, {"S", 0.9, 0.97}, {"L", 1.1, 1.03}};
  std::vector<SizedScene> out;
  out.push_back({"knee_flexion_sizes", "knee_flexion",
                 "knee_flexion's sleeve designed for three sizes at once (S, M, L: girths 0.9, 1, 1.1 and height and limb lengths "
                 "0.97, 1, 1.03 times the body's), for the worst of them.",
                 sml, BodyObjective::kWorst});
  out.push_back({"knee_flexion_sizes_mean", "knee_flexion",
                 "knee_flexion_sizes for the mean of the three sizes' density ratios.", sml, BodyObjective::kMean});
  return out;
}

BodyMeasurements ScaledMeasurements(const BodyMeasurements& m, const BodySize& size) {
  BodyMeasurements out = m;
  for (double* g : {&out.chest_circumference_m, &out.waist_circumference_m, &out.hip_circumference_m, &out.upper_arm_circumference_m,
                    &out.forearm_circumference_m, &out.thigh_circumference_m, &out.calf_circumference_m})
    *g *= size.girth_scale;
  for (double* l : {&out.height_m, &out.upper_arm_length_m, &out.forearm_length_m, &out.thigh_length_m, &out.shank_length_m})
    *l *= size.height_scale;
  return out;
}

Result<SceneSpec> SizedSceneOn(const ParametricBody& body, const SizedScene& sized) {
  const PaperMotion* motion = nullptr;
  static const std::vector<PaperMotion> motions = PaperMotions();
  for (const PaperMotion& m : motions)
    if (m.name == sized.motion) motion = &m;
  if (!motion) return Status::Error(sized.name + ": no paper motion '" + sized.motion + "'");
  Result<SceneSpec> scene = PaperScene(body, *motion);
  if (!scene.ok()) return scene.status();
  SceneSpec s = std::move(scene).value();
  s.name = sized.name;
  s.description = sized.description;
  s.body_objective = sized.objective;
  const std::vector<JointAngles> keys = MotionKeyframes(motion->rest, motion->pose, motion->frames);
  for (size_t i = 0; i < sized.sizes.size(); ++i) {
    const BodySize& size = sized.sizes[i];
    SceneBody b;
    b.name = size.name;
    if (i == 0) {
      b.pose = *s.motion;
    } else {
      Result<ParametricBody> other = ParametricBodyLike(body, ScaledMeasurements(body.measurements, size));
      if (!other.ok()) return other.status().WithContext(sized.name + ", body '" + size.name + "': ");
      Result<std::vector<Positions>> poses = PoseSequence(*other, keys);
      if (!poses.ok()) return poses.status().WithContext(sized.name + ", body '" + size.name + "': ");
      b.pose.faces = other->rest.faces;
      b.pose.rest = (*poses)[0];
      b.pose.deformed = poses->back();
      b.pose.frames.assign(poses->begin() + 1, poses->end());
    }
    s.bodies.push_back(std::move(b));
  }
  KGD_RETURN_IF_ERROR(ValidateSceneBodies(s));
  return s;
}

}  // namespace kgd
