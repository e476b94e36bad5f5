#include "core/scene/builtin_scenes.h"
#include "core/scene/scene_cache.h"

#include <cmath>
#include <filesystem>
#include <map>

#include "core/beso/design_constraints.h"
#include "core/scene/paper_scenes.h"
#include "core/scene/scene_file.h"
#include "core/scene/shapes.h"

namespace kgd {

Result<SceneSpec> PullTestScene(const std::string& design, double pull_m) {
  SceneSpec s;
  s.name = "pull_test_" + design;
  s.garment = RectangleSheet(0.10, 0.14, 0.0025);
  s.initial = s.garment.vertices;
  const int nf = static_cast<int>(s.garment.faces.rows());
  const Positions c = FaceCentroids(s.garment.vertices, s.garment.faces, [&] {
    std::vector<int> all(nf);
    for (int f = 0; f < nf; ++f) all[f] = f;
    return all;
  }());
  const double eps = 1e-9;
  auto in_active = [&](int f) { return c(f, 2) > 0.02 && c(f, 2) < 0.12; };
  s.design.assign(nf, kCloth);
  if (design == "all_reinforced") {
    s.design.assign(nf, kReinforced);
  } else if (design == "line") {
    // A 4 cm band, centred, joining the clamps: 40 % of the 10 x 10 cm active area.
    for (int f = 0; f < nf; ++f)
      if (c(f, 0) > 0.03 - eps && c(f, 0) < 0.07 + eps) s.design[f] = kReinforced;
  } else if (design == "x") {
    // Two diagonal bands corner to corner of the active area; width chosen for 40 % of its area.
    auto band = [&](double w, int f) {
      const double x = c(f, 0), z = c(f, 2) - 0.02;
      const double d1 = std::abs(x - z) / std::sqrt(2.0), d2 = std::abs(x + z - 0.10) / std::sqrt(2.0);
      return std::min(d1, d2) <= 0.5 * w;
    };
    const Eigen::VectorXd area = FaceAreas(s.garment.vertices, s.garment.faces);
    auto fraction = [&](double w) {
      double a = 0, total = 0;
      for (int f = 0; f < nf; ++f)
        if (in_active(f)) { total += area[f]; if (band(w, f)) a += area[f]; }
      return a / total;
    };
    double lo = 0.0, hi = 0.05;
    for (int it = 0; it < 60; ++it) {
      const double mid = 0.5 * (lo + hi);
      (fraction(mid) < 0.40 ? lo : hi) = mid;
    }
    for (int f = 0; f < nf; ++f)
      if (in_active(f) && band(hi, f)) s.design[f] = kReinforced;
  } else if (design != "all_cloth") {
    return Status::Error("pull test design '" + design + "' is not all_cloth, all_reinforced, line or x");
  }
  s.effects.clamps = true;
  Clamp fixed, moving;
  fixed.name = "fixed";
  moving.name = "moving";
  for (Eigen::Index v = 0; v < s.garment.vertices.rows(); ++v) {
    const double z = s.garment.vertices(v, 2);
    if (z <= 0.02 + eps) fixed.vertices.push_back(v);
    if (z >= 0.12 - eps) moving.vertices.push_back(v);
  }
  moving.displacement_m = Eigen::Vector3d(0, 0, pull_m);
  s.clamps = {fixed, moving};
  return s;
}

SceneSpec SleeveOnLimbScene(const SleeveOptions& o) {
  LimbShape shape;
  shape.around = o.around;
  const TriMesh body_rest = LimbRest(shape);
  const Positions body_posed = LimbPosed(shape, body_rest.vertices, o.flex_angle_rad);
  // Garment: faces whose vertices all lie within the sleeve's half-length of the joint (in rest).
  std::vector<int> garment_faces;
  for (Eigen::Index f = 0; f < body_rest.faces.rows(); ++f) {
    bool inside = true;
    for (int k = 0; k < 3; ++k) inside &= std::abs(body_rest.vertices(body_rest.faces(f, k), 1)) <= o.sleeve_halflength_m + 1e-9;
    if (inside) garment_faces.push_back(f);
  }
  std::vector<int> remap(body_rest.vertices.rows(), -1);
  std::vector<int> garment_vertices;
  for (int f : garment_faces)
    for (int k = 0; k < 3; ++k) {
      const int v = body_rest.faces(f, k);
      if (remap[v] < 0) { remap[v] = garment_vertices.size(); garment_vertices.push_back(v); }
    }
  SceneSpec s;
  s.name = "sleeve_on_limb";
  s.garment.faces.resize(garment_faces.size(), 3);
  for (size_t i = 0; i < garment_faces.size(); ++i)
    for (int k = 0; k < 3; ++k) s.garment.faces(i, k) = remap[body_rest.faces(garment_faces[i], k)];
  s.garment.vertices.resize(garment_vertices.size(), 3);
  s.initial.resize(garment_vertices.size(), 3);
  double y_min = 1e300, y_max = -1e300;
  for (size_t i = 0; i < garment_vertices.size(); ++i) {
    // The sleeve is a straight tube of the limb's nominal radius (it does not follow the waist), shorter
    // than the limb section it covers, so it is in tension between its attachment bands.
    const Eigen::Vector3d p = body_rest.vertices.row(garment_vertices[i]);
    const double radial = std::hypot(p.x(), p.z());
    const double scale = o.hoop_tightness * shape.radius_m / radial;
    if (o.rest_on_body) s.garment.vertices.row(i) = p.transpose();
    else s.garment.vertices.row(i) << scale * p.x(), o.axial_tightness * p.y(), scale * p.z();
    s.initial.row(i) = body_posed.row(garment_vertices[i]);
    y_min = std::min(y_min, p.y());
    y_max = std::max(y_max, p.y());
  }
  // Attachment bands: the ring of faces at each open end.
  const double band = 0.25 * (2.0 * std::acos(-1.0) * shape.radius_m / o.around) * 4.0;
  for (size_t i = 0; i < garment_faces.size(); ++i) {
    double y = 0;
    for (int k = 0; k < 3; ++k) y += body_rest.vertices(body_rest.faces(garment_faces[i], k), 1) / 3.0;
    if (y < y_min + band || y > y_max - band) s.attachment_faces.push_back(i);
  }
  s.design.assign(garment_faces.size(), o.reinforced ? kReinforced : kCloth);
  s.body = TriMesh{body_posed, body_rest.faces};
  s.effects.contact = o.contact;
  s.effects.attachments = true;
  return s;
}

std::vector<std::string> BuiltinSceneNames() {
  std::vector<std::string> names;
  for (const PaperMotion& m : PaperMotions()) names.push_back(m.name);
  for (const BraceScene& b : BraceScenes()) names.push_back(b.name);
  for (const SizedScene& z : SizedScenes()) names.push_back(z.name);
  for (const char* n : {"sleeve_on_limb", "pull_test_all_cloth", "pull_test_all_reinforced", "pull_test_line", "pull_test_x"})
    names.push_back(n);
  return names;
}

std::vector<BuiltinSceneInfo> BuiltinSceneInfos() {
  // The paper scenes' garments on the default body (building one takes seconds; tests/builtin_scenes_test
  // holds this table to the scenes).
  const std::map<std::string, std::pair<int, double>> size = {
      {"arm_flexion", {13936, 0.04731}}, {"arm_extension", {13936, 0.04715}}, {"knee_flexion", {5200, 0.08252}},
      {"knee_extension", {5200, 0.08269}}, {"slouch", {33368, 0.4959}}, {"crouch", {19716, 0.3083}}, {"lunge", {19716, 0.3083}},
      {"arm_brace", {13936, 0.04715}}, {"knee_brace", {5200, 0.08264}}, {"posture_shirt", {33368, 0.4959}},
      {"knee_flexion_sizes", {5200, 0.08252}}, {"knee_flexion_sizes_mean", {5200, 0.08252}}};
  std::vector<BuiltinSceneInfo> out;
  for (const PaperMotion& m : PaperMotions()) {
    const auto it = size.find(m.name);
    out.push_back({m.name, m.garment, m.description, m.budget, m.frames, m.subdivisions, true, it == size.end() ? 0 : it->second.first,
                   it == size.end() ? 0 : it->second.second});
  }
  for (const BraceScene& b : BraceScenes()) {
    const auto it = size.find(b.name);
    int frames = 0;
    for (const BraceMotion& m : b.motions) frames += m.frames;
    out.push_back({b.name, b.garment, b.description, b.budget, frames, b.subdivisions, true, it == size.end() ? 0 : it->second.first,
                   it == size.end() ? 0 : it->second.second});
    for (const BraceMotion& m : b.motions) out.back().motions.push_back({m.name, m.role, m.weight});
  }
  for (const SizedScene& z : SizedScenes())
    for (const PaperMotion& m : PaperMotions())
      if (m.name == z.motion) {
        const auto it = size.find(z.name);
        out.push_back({z.name, m.garment, z.description, m.budget, m.frames * static_cast<int>(z.sizes.size()), m.subdivisions, true,
                       it == size.end() ? 0 : it->second.first, it == size.end() ? 0 : it->second.second});
        for (const BodySize& b : z.sizes) out.back().motions.push_back({b.name, MotionRole::kResist, 1.0});
        out.back().body_objective = ToString(z.objective);
      }
  for (const std::string& n : BuiltinSceneNames()) {
    bool paper = false;
    for (const PaperMotion& m : PaperMotions()) paper |= m.name == n;
    for (const BraceScene& b : BraceScenes()) paper |= b.name == n;
    for (const SizedScene& z : SizedScenes()) paper |= z.name == n;
    if (paper) continue;
    BuiltinSceneInfo info{n, "", "", 1.0, 0, 0, false};
    info.description = n.rfind("pull_test", 0) == 0 ? "pull test of the paper's 2D validation" : "sleeve on a capsule limb (simulator checks)";
    // These scenes are small and need no body: their budget, motions and symmetry are read off the scene itself.
    if (Result<SceneSpec> s = BuiltinScene(n); s.ok()) {
      info.budget = s->budget;
      info.garment_faces = static_cast<int>(s->garment.faces.rows());
      info.garment_area_m2 = FaceAreas(s->garment.vertices, s->garment.faces).sum();
      for (const SceneMotion& m : MotionsOf(*s)) info.motions.push_back({m.name, m.role, m.weight});
      info.symmetric = PairMirrorFaces(s->garment, SymmetryPlane{}).ok();
    }
    out.push_back(info);
  }
  // The parametric body's garments that cover both sides are symmetric (tests/builtin_scenes_test pairs
  // their faces); a scene of one motion weighs its own, resisted with weight 1.
  for (BuiltinSceneInfo& info : out) {
    if (info.parametric_body) info.symmetric = info.garment == "shirt" || info.garment == "shorts";
    if (info.motions.empty()) info.motions = {{info.name, MotionRole::kResist, 1.0}};
  }
  return out;
}

Result<SceneSpec> BuiltinScene(const std::string& name, const BodyMeasurements& measurements) {
  for (const PaperMotion& m : PaperMotions())
    if (m.name == name) {
      Result<ParametricBody> body = BuildParametricBody(measurements);
      if (!body.ok()) return body.status();
      return PaperScene(*body, m);
    }
  for (const BraceScene& b : BraceScenes())
    if (b.name == name) {
      Result<ParametricBody> body = BuildParametricBody(measurements);
      if (!body.ok()) return body.status();
      return BraceSceneOn(*body, b);
    }
  for (const SizedScene& z : SizedScenes())
    if (z.name == name) {
      Result<ParametricBody> body = BuildParametricBody(measurements);
      if (!body.ok()) return body.status();
      return SizedSceneOn(*body, z);
    }
  return Status::Error("body measurements apply only to the paper's scenes on the parametric body, not to '" + name + "'");
}

Result<SceneSpec> BuiltinScene(const std::string& name) {
  for (const PaperMotion& m : PaperMotions())
    if (m.name == name) {
      Result<const ParametricBody*> body = DefaultParametricBody();
      if (!body.ok()) return body.status();
      return PaperScene(**body, m);
    }
  for (const BraceScene& b : BraceScenes())
    if (b.name == name) {
      Result<const ParametricBody*> body = DefaultParametricBody();
      if (!body.ok()) return body.status();
      return BraceSceneOn(**body, b);
    }
  for (const SizedScene& z : SizedScenes())
    if (z.name == name) {
      Result<const ParametricBody*> body = DefaultParametricBody();
      if (!body.ok()) return body.status();
      return SizedSceneOn(**body, z);
    }
  if (name == "sleeve_on_limb") return SleeveOnLimbScene({});
  const std::string prefix = "pull_test_";
  if (name.rfind(prefix, 0) == 0) return PullTestScene(name.substr(prefix.size()));
  std::string list;
  for (const auto& n : BuiltinSceneNames()) list += (list.empty() ? "" : ", ") + n;
  return Status::Error("unknown built-in scene '" + name + "' (built-in scenes: " + list + ")");
}

Result<SceneSpec> ResolveScene(const std::string& arg, const std::vector<std::string>& body_items,
                               const std::optional<std::string>& cache_dir) {
  Result<std::optional<BodyMeasurements>> body = ParseBodyMeasurements(body_items);
  if (!body.ok()) return body.status();
  if (std::filesystem::exists(arg)) {
    if (*body) return Status::Error(arg + ": --body applies to built-in scenes, not to scene files");
    return LoadScene(arg);
  }
  if (arg.find('/') != std::string::npos || (arg.size() > 5 && arg.substr(arg.size() - 5) == ".json"))
    return Status::Error(arg + ": no such scene file");
  return ResolveBuiltinScene(arg, body_items, cache_dir);
}

bool IsCachedBuiltinScene(const std::string& name) {
  for (const PaperMotion& m : PaperMotions())
    if (m.name == name) return true;
  for (const BraceScene& b : BraceScenes())
    if (b.name == name) return true;
  for (const SizedScene& z : SizedScenes())
    if (z.name == name) return true;
  return false;
}

Result<SceneSpec> ResolveBuiltinScene(const std::string& name, const std::vector<std::string>& body_items,
                                      const std::optional<std::string>& cache_dir) {
  Result<std::optional<BodyMeasurements>> body = ParseBodyMeasurements(body_items);
  if (!body.ok()) return body.status();
  // On a warm machine the scenes on the parametric body come from the scene cache (a fraction of a
  // second).
  const bool parametric = IsCachedBuiltinScene(name);
  const BodyMeasurements measurements = *body ? **body : BodyMeasurements();
  const std::string cache = cache_dir ? *cache_dir : SceneCacheDir();
  if (parametric)
    if (std::optional<SceneSpec> cached = LoadCachedScene(cache, name, measurements)) return std::move(*cached);
  Result<SceneSpec> built = *body ? BuiltinScene(name, **body) : BuiltinScene(name);
  if (parametric && built.ok()) (void)StoreCachedScene(cache, name, measurements, *built);
  return built;
}


}  // namespace kgd
