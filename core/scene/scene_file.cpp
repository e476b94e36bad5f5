#include "core/scene/scene_file.h"

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <algorithm>
#include <charconv>
#include <set>
#include <sstream>

#include "core/beso/design_constraints.h"
#include "core/mesh/mesh_io.h"
#include "core/scene/scene_keys.h"

namespace kgd {
namespace fs = std::filesystem;
namespace sk = scene_key;
using nlohmann::json;

namespace {

// "a, b, c"
template <typename Range>
std::string JoinKeys(const Range& keys) {
  std::string list;
  for (const auto& k : keys) list += std::string(list.empty() ? "" : ", ") + k;
  return list;
}

// Typed access to a JSON scene with messages that name the file and the key path, and to the files it
// names: in the scene's folder on disk, or in a bundle in memory (then `dir` is empty).
class Reader {
 public:
  Reader(std::string file, fs::path dir, const SceneBundle* bundle, std::vector<std::string>* files_read)
      : file_(std::move(file)), dir_(std::move(dir)), bundle_(bundle), files_read_(files_read) {}

  Status Fail(const std::string& key, const std::string& what) const {
    return Status::Error(file_ + ": " + key + ": " + what);
  }
  // `obj` must be an object whose keys are all keys of `section` in KGD_SCENE_KEYS.
  Status CheckKeys(const json& obj, const std::string& path, const char* section) const {
    if (!obj.is_object()) return Fail(path.empty() ? "(top level)" : path, "must be an object");
    const std::vector<std::string> allowed = SceneKeysOf(section);
    for (const auto& [k, v] : obj.items())
      if (std::find(allowed.begin(), allowed.end(), k) == allowed.end())
        return Fail(path.empty() ? k : path + "." + k, "unknown key (expected one of: " + JoinKeys(allowed) + ")");
    return Status::Ok();
  }
  Status Number(const json& obj, const std::string& path, const char* key, double* out) const {
    if (!obj.contains(key)) return Status::Ok();
    const json& v = obj[key];
    if (!v.is_number() || !std::isfinite(v.get<double>())) return Fail(path.empty() ? key : path + "." + key, "must be a finite number");
    *out = v.get<double>();
    return Status::Ok();
  }
  Status Bool(const json& obj, const std::string& path, const char* key, bool* out) const {
    if (!obj.contains(key)) return Status::Ok();
    if (!obj[key].is_boolean()) return Fail(path + "." + key, "must be true or false");
    *out = obj[key].get<bool>();
    return Status::Ok();
  }
  Status Choice(const json& obj, const std::string& path, const char* key, std::initializer_list<const char*> options,
                std::string* out) const {
    if (!obj.contains(key)) return Status::Ok();
    const json& v = obj[key];
    const std::string list = JoinKeys(options);
    if (!v.is_string()) return Fail(path + "." + key, "must be one of: " + list);
    for (const char* o : options)
      if (v.get<std::string>() == o) { *out = o; return Status::Ok(); }
    return Fail(path + "." + key, "'" + v.get<std::string>() + "' is not one of: " + list);
  }
  std::string Resolve(const std::string& rel) const {
    if (files_read_) files_read_->push_back(rel);
    return (dir_ / rel).lexically_normal().string();
  }
  // A file the scene names, by its resolved name (Resolve): its bytes in the bundle, or an error.
  Result<std::string_view> Bundled(const std::string& name) const {
    const auto it = bundle_->files.find(name);
    if (it == bundle_->files.end()) return Status::Error(name + ": not among the scene's files");
    return it->second;
  }
  Result<TriMesh> MeshFile(const std::string& name) const {
    if (!bundle_) return ReadMesh(name);
    Result<std::string_view> bytes = Bundled(name);
    return bytes.ok() ? ParseMesh(*bytes, name) : Result<TriMesh>(bytes.status());
  }
  Result<std::vector<int>> IndexFile(const std::string& name) const {
    if (!bundle_) return ReadIndexList(name);
    Result<std::string_view> bytes = Bundled(name);
    return bytes.ok() ? ParseIndexList(*bytes, name) : Result<std::vector<int>>(bytes.status());
  }
  Result<std::string> TextFile(const std::string& name, const char* what) const {
    if (bundle_) {
      Result<std::string_view> bytes = Bundled(name);
      return bytes.ok() ? Result<std::string>(std::string(*bytes)) : Result<std::string>(bytes.status());
    }
    std::ifstream in(name, std::ios::binary);
    if (!in) return Status::Error(name + ": cannot open the " + what);
    std::ostringstream text;
    text << in.rdbuf();
    return text.str();
  }
  Result<TriMesh> Mesh(const json& v, const std::string& key) const {
    if (!v.is_string()) return Fail(key, "must be a mesh file path");
    return MeshFile(Resolve(v.get<std::string>()));
  }
  // An index list given inline or as a file (one integer per line).
  Result<std::vector<int>> Indices(const json& v, const std::string& key) const {
    if (v.is_string()) return IndexFile(Resolve(v.get<std::string>()));
    if (!v.is_array()) return Fail(key, "must be a file path or an array of indices");
    std::vector<int> out;
    for (size_t i = 0; i < v.size(); ++i) {
      if (!v[i].is_number_integer()) return Fail(key + "[" + std::to_string(i) + "]", "must be an integer");
      // Read wide: get<int> would wrap 4294967297 to a valid index.
      const int64_t index = v[i].is_number_unsigned() && v[i].get<uint64_t>() > uint64_t(INT64_MAX) ? INT64_MAX
                                                                                                 : v[i].get<int64_t>();
      if (index < INT32_MIN || index > INT32_MAX)
        return Fail(key + "[" + std::to_string(i) + "]", "index " + v[i].dump() + " is out of range");
      out.push_back(static_cast<int>(index));
    }
    return out;
  }
  Status Vec3(const json& obj, const std::string& path, const char* key, Eigen::Vector3d* out) const {
    if (!obj.contains(key)) return Status::Ok();
    const json& v = obj[key];
    if (!v.is_array() || v.size() != 3) return Fail(path + "." + key, "must be an array of three numbers");
    for (int k = 0; k < 3; ++k) {
      if (!v[k].is_number() || !std::isfinite(v[k].get<double>()))
        return Fail(path + "." + key, "must be an array of three finite numbers");
      (*out)[k] = v[k].get<double>();
    }
    return Status::Ok();
  }
  Status MaterialAt(const json& obj, const std::string& path, Material* m) const {
    if (Status s = CheckKeys(obj, path, "SceneMaterial"); !s.ok()) return s;
    if (Status s = Number(obj, path, sk::SceneMaterial::youngs_modulus_Pa, &m->youngs_modulus_Pa); !s.ok()) return s;
    if (Status s = Number(obj, path, sk::SceneMaterial::poisson_ratio, &m->poisson_ratio); !s.ok()) return s;
    return Number(obj, path, sk::SceneMaterial::thickness_m, &m->thickness_m);
  }
  const std::string& file() const { return file_; }

 private:
  std::string file_;
  fs::path dir_;
  const SceneBundle* bundle_;
  std::vector<std::string>* files_read_;
};

// The sections of a scene file, read in this order: effects first (they decide what else is read), the
// garment (cut from the body's motion, or a mesh of its own) and its design, the budget, materials, the
// body and contact, attachments, clamps, the solver.

// An energy term's effect switch (core/sim/term_list.h), read by its type.
Status ReadEffect(const Reader& r, const json& e, const char* key, bool* out) { return r.Bool(e, "effects", key, out); }
Status ReadEffect(const Reader& r, const json& e, const char* key, double* out) { return r.Number(e, "effects", key, out); }
Status ReadEffect(const Reader& r, const json& e, const char* key, ContactModel* out) {
  std::string contact = "none";
  KGD_RETURN_IF_ERROR(r.Choice(e, "effects", key, {"none", "unilateral", "bilateral"}, &contact));
  *out = contact == "none" ? ContactModel::kNone : contact == "unilateral" ? ContactModel::kUnilateral : ContactModel::kBilateral;
  return Status::Ok();
}

Status ReadEffects(const Reader& r, const json& doc, SceneSpec* s) {
  if (doc.contains(sk::Scene::effects)) {
    const json& e = doc[sk::Scene::effects];
    KGD_RETURN_IF_ERROR(r.CheckKeys(e, "effects", "SceneEffects"));
#define KGD_READ_EFFECT(Y, Class, key, sum_place, Type, effect, value, effect_what, time_what) \
  KGD_RETURN_IF_ERROR(ReadEffect(r, e, sk::SceneEffects::effect, &s->effects.effect));
    KGD_ENERGY_TERMS(KGD_READ_EFFECT, )
#undef KGD_READ_EFFECT
    KGD_RETURN_IF_ERROR(r.Bool(e, "effects", sk::SceneEffects::clamps, &s->effects.clamps));
    std::string relax = "exact";
    KGD_RETURN_IF_ERROR(r.Choice(e, "effects", sk::SceneEffects::relaxation, {"exact", "authors", "none"}, &relax));
    s->effects.relaxation = relax == "exact" ? Relaxation::kExact : relax == "authors" ? Relaxation::kAuthors : Relaxation::kNone;
  }

  return Status::Ok();
}

// One entry of `motions` as the file gives it; its poses are read with the body's.
struct MotionEntry {
  SceneMotion motion;  // name, role, weight
  std::string key;     // "motions[1]"
  const json* deformed = nullptr;
  std::vector<const json*> frames;
};

// `motions`: each a unique name, a role and a weight >= 0; the first is the scene's own (resisted, a
// weight > 0, its poses body.deformed and body.frames), every other gives its deformed pose.
Status ReadMotionEntries(const Reader& r, const json& doc, std::vector<MotionEntry>* out) {
  if (!doc.contains(sk::Scene::motions)) return Status::Ok();
  const json& ms = doc[sk::Scene::motions];
  if (!ms.is_array() || ms.empty()) return r.Fail("motions", "must be a non-empty array of motions");
  for (size_t i = 0; i < ms.size(); ++i) {
    const json& m = ms[i];
    MotionEntry e;
    e.key = "motions[" + std::to_string(i) + "]";
    KGD_RETURN_IF_ERROR(r.CheckKeys(m, e.key, "SceneMotion"));
    if (!m.contains(sk::SceneMotion::name) || !m[sk::SceneMotion::name].is_string() || m[sk::SceneMotion::name].get<std::string>().empty())
      return r.Fail(e.key + ".name", "missing (every motion needs a name, a non-empty string)");
    e.motion.name = m[sk::SceneMotion::name].get<std::string>();
    const std::string what = "motion '" + e.motion.name + "'";
    for (size_t j = 0; j < out->size(); ++j)
      if ((*out)[j].motion.name == e.motion.name) return r.Fail(e.key + ".name", what + ": two motions have this name (" + (*out)[j].key + ")");
    if (m.contains(sk::SceneMotion::role)) {
      const json& role = m[sk::SceneMotion::role];
      Result<MotionRole> parsed = MotionRoleFromName(role.is_string() ? role.get<std::string>() : role.dump(), what);
      if (!parsed.ok()) return r.Fail(e.key + ".role", parsed.message());
      e.motion.role = *parsed;
    }
    KGD_RETURN_IF_ERROR(r.Number(m, e.key, sk::SceneMotion::weight, &e.motion.weight));
    if (!(e.motion.weight >= 0)) return r.Fail(e.key + ".weight", what + ": weight " + m[sk::SceneMotion::weight].dump() + " must be >= 0");
    if (i == 0) {
      for (const char* k : {sk::SceneMotion::deformed, sk::SceneMotion::frames})
        if (m.contains(k))
          return r.Fail(e.key + "." + k, what + ": the first motion is the scene's own: its poses are body.deformed and body.frames");
      if (e.motion.role != MotionRole::kResist || !(e.motion.weight > 0))
        return r.Fail(e.key, what + ": the first motion is the scene's own and must be resisted with a weight > 0 (role " +
                                 ToString(e.motion.role) + ", weight " + m.value(sk::SceneMotion::weight, json(1.0)).dump() + ")");
    } else {
      if (!m.contains(sk::SceneMotion::deformed)) return r.Fail(e.key + ".deformed", what + ": missing (every motion but the first gives its deformed pose)");
      e.deformed = &m[sk::SceneMotion::deformed];
      if (m.contains(sk::SceneMotion::frames)) {
        const json& fr = m[sk::SceneMotion::frames];
        if (!fr.is_array() || fr.empty()) return r.Fail(e.key + ".frames", what + ": must be a non-empty array of mesh file paths");
        for (const json& f : fr) e.frames.push_back(&f);
      }
    }
    out->push_back(std::move(e));
  }
  return Status::Ok();
}

// One entry of `bodies` as the file gives it; its poses are read with the body's.
struct BodyEntry {
  SceneBody body;   // name, weight
  std::string key;  // "bodies[1]"
  const json* rest = nullptr;
  const json* deformed = nullptr;
  std::vector<const json*> frames;
};

// `bodies`: each a unique name and a weight >= 0; the first is the scene's own (a weight > 0, its poses
// body.rest, body.deformed and body.frames), every other gives its rest and deformed poses (and frames).
Status ReadBodyEntries(const Reader& r, const json& doc, std::vector<BodyEntry>* out) {
  if (!doc.contains(sk::Scene::bodies)) return Status::Ok();
  const json& bs = doc[sk::Scene::bodies];
  if (!bs.is_array() || bs.empty()) return r.Fail("bodies", "must be a non-empty array of bodies");
  for (size_t i = 0; i < bs.size(); ++i) {
    const json& b = bs[i];
    BodyEntry e;
    e.key = "bodies[" + std::to_string(i) + "]";
    KGD_RETURN_IF_ERROR(r.CheckKeys(b, e.key, "SceneRangeBody"));
    if (!b.contains(sk::SceneRangeBody::name) || !b[sk::SceneRangeBody::name].is_string() || b[sk::SceneRangeBody::name].get<std::string>().empty())
      return r.Fail(e.key + ".name", "missing (every body needs a name, a non-empty string)");
    e.body.name = b[sk::SceneRangeBody::name].get<std::string>();
    const std::string what = "body '" + e.body.name + "'";
    for (size_t j = 0; j < out->size(); ++j)
      if ((*out)[j].body.name == e.body.name) return r.Fail(e.key + ".name", what + ": two bodies have this name (" + (*out)[j].key + ")");
    KGD_RETURN_IF_ERROR(r.Number(b, e.key, sk::SceneRangeBody::weight, &e.body.weight));
    if (!(e.body.weight >= 0)) return r.Fail(e.key + ".weight", what + ": weight " + b[sk::SceneRangeBody::weight].dump() + " must be >= 0");
    if (i == 0) {
      for (const char* k : {sk::SceneRangeBody::rest, sk::SceneRangeBody::deformed, sk::SceneRangeBody::frames})
        if (b.contains(k))
          return r.Fail(e.key + "." + k, what + ": the first body is the scene's own: its poses are body.rest, body.deformed and body.frames");
      if (!(e.body.weight > 0)) return r.Fail(e.key + ".weight", what + ": the first body is the scene's own and must have a weight > 0");
    } else {
      for (const char* k : {sk::SceneRangeBody::rest, sk::SceneRangeBody::deformed})
        if (!b.contains(k)) return r.Fail(e.key + "." + k, what + ": missing (every body but the first gives its rest and deformed poses)");
      e.rest = &b[sk::SceneRangeBody::rest];
      e.deformed = &b[sk::SceneRangeBody::deformed];
      if (b.contains(sk::SceneRangeBody::frames)) {
        const json& fr = b[sk::SceneRangeBody::frames];
        if (!fr.is_array() || fr.empty()) return r.Fail(e.key + ".frames", what + ": must be a non-empty array of mesh file paths");
        for (const json& f : fr) e.frames.push_back(&f);
      }
    }
    out->push_back(std::move(e));
  }
  return Status::Ok();
}

// A garment cut from the body's motion: body.rest, body.deformed and body.frames (one topology), the
// region (body faces), subdivisions and the attachment body faces; the poses of the other `motions`
// and of the other `bodies` (the same topology).
Status ReadGarmentCutFromBody(const Reader& r, const json& g, const json& b, const json& a, const std::vector<MotionEntry>& motions,
                              const std::vector<BodyEntry>& bodies, SceneSpec* s) {
  for (const char* k : {sk::SceneGarment::rest, sk::SceneGarment::initial})
    if (g.contains(k))
      return r.Fail(std::string("garment.") + k, "not allowed with garment.region (a garment cut from the body takes its shapes from body.rest and body.deformed)");
  if (b.contains(sk::SceneBody::mesh)) return r.Fail("body.mesh", "not allowed with garment.region (give body.rest and body.deformed)");
  if (a.contains(sk::SceneAttachments::faces)) return r.Fail("attachments.faces", "not allowed with garment.region (give attachments.body_faces, body faces)");
  for (const char* k : {sk::SceneBody::rest, sk::SceneBody::deformed})
    if (!b.contains(k)) return r.Fail(std::string("body.") + k, "missing (required with garment.region)");
  Result<TriMesh> rest = r.Mesh(b[sk::SceneBody::rest], "body.rest");
  if (!rest.ok()) return rest.status();
  const std::string rest_file = r.Resolve(b[sk::SceneBody::rest].get<std::string>());
  BodyMotion motion;
  motion.faces = rest->faces;
  motion.rest = rest->vertices;
  std::vector<std::string> names = {rest_file};
  // Every other pose: same vertex count and the very same faces as the rest mesh. A motion is a dozen
  // meshes of tens of MB of text: they are read in parallel, then checked in order.
  // Each pose with its key, whose it is ("": the body's own; "motion 'reach'", "body 'S'"), where it
  // goes and what it is.
  enum class Kind { kRest, kDeformed, kFrame };
  std::vector<BodyMotion> other(motions.size());       // other[m]: the poses of motions[m], m >= 1
  std::vector<BodyMotion> other_body(bodies.size());   // other_body[k]: the poses of bodies[k], k >= 1
  struct Pose {
    std::string key;
    const json* value;
    std::string whose;
    BodyMotion* into;
    Kind kind;
  };
  std::vector<Pose> poses = {{"body.deformed", &b[sk::SceneBody::deformed], "", &motion, Kind::kDeformed}};
  if (b.contains(sk::SceneBody::frames)) {
    const json& fr = b[sk::SceneBody::frames];
    if (!fr.is_array() || fr.empty()) return r.Fail("body.frames", "must be a non-empty array of mesh file paths");
    for (size_t i = 0; i < fr.size(); ++i) poses.push_back({"body.frames[" + std::to_string(i) + "]", &fr[i], "", &motion, Kind::kFrame});
  }
  for (size_t m = 1; m < motions.size(); ++m) {
    const std::string whose = "motion '" + motions[m].motion.name + "'";
    poses.push_back({motions[m].key + ".deformed", motions[m].deformed, whose, &other[m], Kind::kDeformed});
    for (size_t i = 0; i < motions[m].frames.size(); ++i)
      poses.push_back({motions[m].key + ".frames[" + std::to_string(i) + "]", motions[m].frames[i], whose, &other[m], Kind::kFrame});
  }
  for (size_t k = 1; k < bodies.size(); ++k) {
    const std::string whose = "body '" + bodies[k].body.name + "'";
    poses.push_back({bodies[k].key + ".rest", bodies[k].rest, whose, &other_body[k], Kind::kRest});
    poses.push_back({bodies[k].key + ".deformed", bodies[k].deformed, whose, &other_body[k], Kind::kDeformed});
    for (size_t i = 0; i < bodies[k].frames.size(); ++i)
      poses.push_back({bodies[k].key + ".frames[" + std::to_string(i) + "]", bodies[k].frames[i], whose, &other_body[k], Kind::kFrame});
  }
  for (const Pose& p : poses) {
    if (!p.value->is_string()) return r.Fail(p.key, "must be a mesh file path");
    names.push_back(r.Resolve(p.value->get<std::string>()));
  }
  const int n = static_cast<int>(poses.size());
  std::vector<Result<TriMesh>> read(n, Status::Error(""));
#pragma omp parallel for schedule(dynamic)
  for (int i = 0; i < n; ++i) read[i] = r.MeshFile(names[i + 1]);
  for (int i = 0; i < n; ++i) {
    const Pose& p = poses[i];
    // Another motion's or body's pose is named with its key and owner besides its file.
    const std::string context = p.whose.empty() ? "" : r.file() + ": " + p.key + " (" + p.whose + "): ";
    const char* one = p.whose.rfind("body", 0) == 0 ? " (every body must have the topology of body.rest, so that the garment is the same on each)"
                                                    : " (all poses must share one topology)";
    if (!read[i].ok()) return read[i].status().WithContext(context);
    const TriMesh& pose = *read[i];
    const std::string& file = names[i + 1];
    if (pose.vertices.rows() != motion.rest.rows())
      return Status::Error(context + file + ": has " + std::to_string(pose.vertices.rows()) + " vertices but " + rest_file + " has " +
                           std::to_string(motion.rest.rows()) + one);
    if (pose.faces.rows() != motion.faces.rows())
      return Status::Error(context + file + ": has " + std::to_string(pose.faces.rows()) + " faces but " + rest_file + " has " +
                           std::to_string(motion.faces.rows()) + one);
    for (Eigen::Index f = 0; f < motion.faces.rows(); ++f)
      if (pose.faces.row(f) != motion.faces.row(f))
        return Status::Error(context + file + ": face " + std::to_string(f) + " differs from face " + std::to_string(f) + " of " + rest_file + one);
    if (!p.whose.empty()) KGD_RETURN_IF_ERROR(ValidateMesh(pose.vertices, pose.faces, file).WithContext(context));
    Positions& out = p.kind == Kind::kRest ? p.into->rest : p.kind == Kind::kDeformed ? p.into->deformed : p.into->frames.emplace_back();
    out = std::move(read[i]->vertices);
  }
  KGD_RETURN_IF_ERROR(ValidateBodyMotion(motion, names));
  s->motion = std::move(motion);
  for (size_t m = 0; m < motions.size(); ++m) {
    SceneMotion sm = motions[m].motion;
    if (m == 0) {
      sm.pose = *s->motion;
    } else {
      sm.pose = std::move(other[m]);
      sm.pose.faces = s->motion->faces;
      sm.pose.rest = s->motion->rest;
    }
    s->motions.push_back(std::move(sm));
  }
  for (size_t k = 0; k < bodies.size(); ++k) {
    SceneBody body = bodies[k].body;
    if (k == 0) {
      body.pose = *s->motion;
    } else {
      body.pose = std::move(other_body[k]);
      body.pose.faces = s->motion->faces;
    }
    s->bodies.push_back(std::move(body));
  }
  Result<std::vector<int>> region = r.Indices(g[sk::SceneGarment::region], "garment.region");
  if (!region.ok()) return region.status();
  s->garment_region = std::move(region).value();
  double subdivisions = 0;
  KGD_RETURN_IF_ERROR(r.Number(g, "garment", sk::SceneGarment::subdivisions, &subdivisions));
  if (subdivisions != std::floor(subdivisions) || subdivisions < 0 || subdivisions > 4)
    return r.Fail("garment.subdivisions", "must be an integer in [0, 4]");
  s->subdivisions = static_cast<int>(subdivisions);
  std::string attach_name = r.file() + ": attachments.body_faces";
  if (a.contains(sk::SceneAttachments::body_faces)) {
    Result<std::vector<int>> faces = r.Indices(a[sk::SceneAttachments::body_faces], "attachments.body_faces");
    if (!faces.ok()) return faces.status();
    s->attachment_body_faces = std::move(faces).value();
    if (a[sk::SceneAttachments::body_faces].is_string()) attach_name = r.Resolve(a[sk::SceneAttachments::body_faces].get<std::string>());
  }
  const std::string region_name = g[sk::SceneGarment::region].is_string() ? r.Resolve(g[sk::SceneGarment::region].get<std::string>()) : r.file() + ": garment.region";
  KGD_RETURN_IF_ERROR(CutGarmentFromMotion(s, region_name, attach_name));
  KGD_RETURN_IF_ERROR(ValidateSceneMotions(*s).WithContext(r.file() + ": motions: "));
  return ValidateSceneBodies(*s).WithContext(r.file() + ": bodies: ");
}

// A garment mesh of its own, with optional start positions of the same topology.
Status ReadGarmentOfItsOwn(const Reader& r, const json& g, const json& b, const json& a, SceneSpec* s) {
  if (!g.contains(sk::SceneGarment::rest)) return r.Fail("garment.rest", "missing (or give garment.region to cut the garment from the body)");
  if (g.contains(sk::SceneGarment::subdivisions)) return r.Fail("garment.subdivisions", "only allowed with garment.region");
  for (const char* k : {sk::SceneBody::rest, sk::SceneBody::deformed, sk::SceneBody::frames})
    if (b.contains(k)) return r.Fail(std::string("body.") + k, "only allowed with garment.region (for a garment of its own give body.mesh)");
  if (a.contains(sk::SceneAttachments::body_faces)) return r.Fail("attachments.body_faces", "only allowed with garment.region (give attachments.faces)");
  Result<TriMesh> rest = r.Mesh(g[sk::SceneGarment::rest], "garment.rest");
  if (!rest.ok()) return rest.status();
  s->garment = std::move(rest).value();
  KGD_RETURN_IF_ERROR(ValidateMesh(s->garment.vertices, s->garment.faces, r.Resolve(g[sk::SceneGarment::rest].get<std::string>())));
  s->initial = s->garment.vertices;
  if (g.contains(sk::SceneGarment::initial)) {
    Result<TriMesh> init = r.Mesh(g[sk::SceneGarment::initial], "garment.initial");
    if (!init.ok()) return init.status();
    const std::string init_file = r.Resolve(g[sk::SceneGarment::initial].get<std::string>());
    if (init->vertices.rows() != s->garment.vertices.rows())
      return Status::Error(init_file + ": has " + std::to_string(init->vertices.rows()) +
                           " vertices but the rest mesh has " + std::to_string(s->garment.vertices.rows()));
    if (init->faces.rows() != s->garment.faces.rows() || init->faces != s->garment.faces)
      return Status::Error(init_file + ": faces differ from the rest mesh (the two poses must share one topology)");
    s->initial = init->vertices;
  }
  return Status::Ok();
}

Status ReadDesign(const Reader& r, const json& g, SceneSpec* s) {
  const int nf = static_cast<int>(s->garment.faces.rows());
  s->design.assign(nf, kCloth);
  if (g.contains(sk::SceneGarment::design)) {
    const json& d = g[sk::SceneGarment::design];
    if (d.is_string()) {
      const std::string v = d.get<std::string>();
      if (v == "all_reinforced") s->design.assign(nf, kReinforced);
      else if (v != "all_cloth") return r.Fail("garment.design", "'" + v + "' is not all_cloth, all_reinforced or an object");
    } else {
      KGD_RETURN_IF_ERROR(r.CheckKeys(d, "garment.design", "SceneDesign"));
      if (d.contains(sk::SceneDesign::reinforced_faces)) {
        Result<std::vector<int>> faces = r.Indices(d[sk::SceneDesign::reinforced_faces], "garment.design.reinforced_faces");
        if (!faces.ok()) return faces.status();
        KGD_RETURN_IF_ERROR(ValidateFaceList(*faces, nf, r.file() + ": garment.design.reinforced_faces"));
        for (int f : *faces) s->design[f] = kReinforced;
      }
    }
  }
  return Status::Ok();
}

// One seam per line: garment vertex indices separated by spaces; blank lines and # comments skipped.
Result<std::vector<std::vector<int>>> ParseSeamFile(const std::string& text, const std::string& path) {
  std::istringstream in(text);
  std::vector<std::vector<int>> seams;
  int line_number = 0;
  for (std::string line; std::getline(in, line);) {
    ++line_number;
    line = line.substr(0, line.find('#'));
    std::istringstream words(line);
    std::vector<int> seam;
    for (std::string w; words >> w;) {
      int v = 0;
      const auto [end, ec] = std::from_chars(w.data(), w.data() + w.size(), v);
      if (ec != std::errc() || end != w.data() + w.size())
        return Status::Error(path + ":" + std::to_string(line_number) + ": '" + w + "' is not a vertex index");
      seam.push_back(v);
    }
    if (!seam.empty()) seams.push_back(std::move(seam));
  }
  return seams;
}

// garment.seams: paths along the garment's edges (checked here, so that a bad seam is named with its
// scene file rather than at export).
Status ReadSeams(const Reader& r, const json& g, SceneSpec* s) {
  if (!g.contains(sk::SceneGarment::seams)) return Status::Ok();
  const json& v = g[sk::SceneGarment::seams];
  std::vector<std::vector<int>> seams;
  std::string where = r.file() + ": garment.seams";
  if (v.is_string()) {
    where = r.Resolve(v.get<std::string>());
    Result<std::string> text = r.TextFile(where, "seam file");
    if (!text.ok()) return text.status();
    Result<std::vector<std::vector<int>>> read = ParseSeamFile(*text, where);
    if (!read.ok()) return read.status();
    seams = std::move(read).value();
  } else if (v.is_array()) {
    for (size_t i = 0; i < v.size(); ++i) {
      Result<std::vector<int>> seam = r.Indices(v[i], "garment.seams[" + std::to_string(i) + "]");
      if (!seam.ok() || !v[i].is_array()) return r.Fail("garment.seams[" + std::to_string(i) + "]", "must be an array of garment vertex indices");
      seams.push_back(std::move(seam).value());
    }
  } else {
    return r.Fail("garment.seams", "must be an array of seams ([[0, 1, 2], ...]) or a seam file");
  }
  std::set<std::pair<int, int>> edges;
  const Faces& faces = s->garment.faces;
  for (Eigen::Index f = 0; f < faces.rows(); ++f)
    for (int k = 0; k < 3; ++k) edges.insert(std::minmax(faces(f, k), faces(f, (k + 1) % 3)));
  const int nv = static_cast<int>(s->garment.vertices.rows());
  for (size_t i = 0; i < seams.size(); ++i) {
    const std::string name = where + ": seam " + std::to_string(i + 1);
    if (seams[i].size() < 2) return Status::Error(name + " has fewer than two vertices");
    for (size_t k = 0; k < seams[i].size(); ++k) {
      if (seams[i][k] < 0 || seams[i][k] >= nv)
        return Status::Error(name + ": vertex " + std::to_string(seams[i][k]) + " is not a garment vertex (0.." + std::to_string(nv - 1) + ")");
      if (k > 0 && !edges.count(std::minmax(seams[i][k - 1], seams[i][k])))
        return Status::Error(name + " is not a path along edges: vertices " + std::to_string(seams[i][k - 1]) + " and " + std::to_string(seams[i][k]) +
                             " share no edge of the garment");
    }
  }
  s->seams = std::move(seams);
  return Status::Ok();
}

// garment.keep_out, garment.keep_in (garment faces) and garment.symmetry (a mirror plane; its pairing
// is checked here, so that an asymmetric garment is refused with its scene file's name).
Status ReadDesignConstraints(const Reader& r, const json& g, SceneSpec* s) {
  const int nf = static_cast<int>(s->garment.faces.rows());
  for (auto [key, out] : {std::pair{sk::SceneGarment::keep_out, &s->keep_out_faces}, std::pair{sk::SceneGarment::keep_in, &s->keep_in_faces}}) {
    if (!g.contains(key)) continue;
    const std::string name = std::string("garment.") + key;
    Result<std::vector<int>> faces = r.Indices(g[key], name);
    if (!faces.ok()) return faces.status();
    KGD_RETURN_IF_ERROR(ValidateFaceList(*faces, nf, r.file() + ": " + name));
    *out = std::move(faces).value();
  }
  std::vector<uint8_t> out(nf, 0);
  for (int f : s->keep_out_faces) out[f] = 1;
  for (int f : s->keep_in_faces)
    if (out[f]) return r.Fail("garment.keep_in", "face " + std::to_string(f) + " is also in garment.keep_out");
  if (!g.contains(sk::SceneGarment::symmetry)) return Status::Ok();
  const json& sym = g[sk::SceneGarment::symmetry];
  KGD_RETURN_IF_ERROR(r.CheckKeys(sym, "garment.symmetry", "SceneSymmetry"));
  SymmetryPlane plane;
  KGD_RETURN_IF_ERROR(r.Vec3(sym, "garment.symmetry", sk::SceneSymmetry::point_m, &plane.point_m));
  KGD_RETURN_IF_ERROR(r.Vec3(sym, "garment.symmetry", sk::SceneSymmetry::normal, &plane.normal));
  if (!(plane.normal.norm() > 0)) return r.Fail("garment.symmetry.normal", "must not be zero");
  plane.normal.normalize();
  KGD_RETURN_IF_ERROR(r.Number(sym, "garment.symmetry", sk::SceneSymmetry::tolerance_m, &plane.tolerance_m));
  if (sym.contains(sk::SceneSymmetry::tolerance_m) && !(plane.tolerance_m > 0)) return r.Fail("garment.symmetry.tolerance_m", "must be > 0");
  Result<MirrorPairing> pairing = PairMirrorFaces(s->garment, plane);
  if (!pairing.ok()) return Status::Error(r.file() + ": garment." + pairing.message());
  Result<DesignUnits> units = MakeDesignUnits(nf, s->keep_out_faces, s->keep_in_faces, {}, &*pairing);
  if (!units.ok()) return Status::Error(r.file() + ": " + units.message());
  s->symmetry = plane;
  return Status::Ok();
}

Status ReadMaterials(const Reader& r, const json& doc, SceneSpec* s) {
  // Materials.
  if (doc.contains(sk::Scene::materials)) {
    const json& m = doc[sk::Scene::materials];
    KGD_RETURN_IF_ERROR(r.CheckKeys(m, "materials", "SceneMaterials"));
    std::string lame = "solid3d";
    KGD_RETURN_IF_ERROR(r.Choice(m, "materials", sk::SceneMaterials::lame, {"solid3d", "plane_stress"}, &lame));
    s->lame = lame == "solid3d" ? LameConversion::kSolid3D : LameConversion::kPlaneStress;
    if (m.contains(sk::SceneMaterials::cloth)) KGD_RETURN_IF_ERROR(r.MaterialAt(m[sk::SceneMaterials::cloth], "materials.cloth", &s->cloth));
    if (m.contains(sk::SceneMaterials::reinforced)) KGD_RETURN_IF_ERROR(r.MaterialAt(m[sk::SceneMaterials::reinforced], "materials.reinforced", &s->reinforced));
  }

  return Status::Ok();
}

// Body and contact: the body mesh is read only when the effects ask for contact.
Status ReadContact(const Reader& r, const json& doc, const json& b, SceneSpec* s) {
  if (doc.contains(sk::Scene::contact)) {
    KGD_RETURN_IF_ERROR(r.CheckKeys(doc[sk::Scene::contact], "contact", "SceneContact"));
    KGD_RETURN_IF_ERROR(r.Number(doc[sk::Scene::contact], "contact", sk::SceneContact::stiffness_N_per_m, &s->contact_stiffness_N_per_m));
  }
  if (!s->motion && s->effects.contact != ContactModel::kNone) {
    if (!b.contains(sk::SceneBody::mesh)) return r.Fail("body.mesh", "missing, but effects.contact is '" +
                                                            std::string(s->effects.contact == ContactModel::kUnilateral ? "unilateral" : "bilateral") + "'");
    Result<TriMesh> body = r.Mesh(b[sk::SceneBody::mesh], "body.mesh");
    if (!body.ok()) return body.status();
    KGD_RETURN_IF_ERROR(ValidateMesh(body->vertices, body->faces, r.Resolve(b[sk::SceneBody::mesh].get<std::string>())));
    s->body = std::move(body).value();
  }

  return Status::Ok();
}

// Attachments of a garment of its own (a cut garment's come from attachments.body_faces).
Status ReadAttachmentFaces(const Reader& r, const json& a, SceneSpec* s) {
  const int nf = static_cast<int>(s->garment.faces.rows());
  if (a.contains(sk::SceneAttachments::faces)) {
    Result<std::vector<int>> faces = r.Indices(a[sk::SceneAttachments::faces], "attachments.faces");
    if (!faces.ok()) return faces.status();
    KGD_RETURN_IF_ERROR(ValidateFaceList(*faces, nf, r.file() + ": attachments.faces"));
    s->attachment_faces = std::move(faces).value();
  }
  if (s->effects.attachments && s->attachment_faces.empty())
    return r.Fail(s->motion ? "attachments.body_faces" : "attachments.faces", "missing or empty, but effects.attachments is true");

  return Status::Ok();
}

Status ReadClamps(const Reader& r, const json& doc, SceneSpec* s) {
  // Clamps.
  if (doc.contains(sk::Scene::clamps)) {
    const json& cs = doc[sk::Scene::clamps];
    if (!cs.is_array()) return r.Fail("clamps", "must be an array");
    for (size_t i = 0; i < cs.size(); ++i) {
      const std::string p = "clamps[" + std::to_string(i) + "]";
      const json& c = cs[i];
      KGD_RETURN_IF_ERROR(r.CheckKeys(c, p, "SceneClamp"));
      Clamp clamp;
      clamp.name = c.contains(sk::SceneClamp::name) && c[sk::SceneClamp::name].is_string() ? c[sk::SceneClamp::name].get<std::string>() : "clamp" + std::to_string(i);
      if (!c.contains(sk::SceneClamp::vertices)) return r.Fail(p + ".vertices", "missing");
      const json& v = c[sk::SceneClamp::vertices];
      if (v.is_object()) {
        KGD_RETURN_IF_ERROR(r.CheckKeys(v, p + ".vertices", "SceneClampBox"));
        Eigen::Vector3d lo = Eigen::Vector3d::Constant(-1e300), hi = Eigen::Vector3d::Constant(1e300);
        KGD_RETURN_IF_ERROR(r.Vec3(v, p + ".vertices", sk::SceneClampBox::box_min, &lo));
        KGD_RETURN_IF_ERROR(r.Vec3(v, p + ".vertices", sk::SceneClampBox::box_max, &hi));
        for (Eigen::Index k = 0; k < s->garment.vertices.rows(); ++k) {
          const Eigen::Vector3d x = s->garment.vertices.row(k);
          if ((x.array() >= lo.array()).all() && (x.array() <= hi.array()).all()) clamp.vertices.push_back(k);
        }
        if (clamp.vertices.empty()) return r.Fail(p + ".vertices", "the box selects no vertex of the rest mesh");
      } else {
        Result<std::vector<int>> ids = r.Indices(v, p + ".vertices");
        if (!ids.ok()) return ids.status();
        clamp.vertices = std::move(ids).value();
      }
      if (c.contains(sk::SceneClamp::axes)) {
        if (!c[sk::SceneClamp::axes].is_string()) return r.Fail(p + ".axes", "must be a string of x, y, z (e.g. \"xyz\" or \"z\")");
        const std::string axes = c[sk::SceneClamp::axes].get<std::string>();
        clamp.axes = {false, false, false};
        for (char ch : axes) {
          if (ch < 'x' || ch > 'z') return r.Fail(p + ".axes", "'" + axes + "' may contain only x, y and z");
          clamp.axes[ch - 'x'] = true;
        }
      }
      KGD_RETURN_IF_ERROR(r.Vec3(c, p, sk::SceneClamp::displacement_m, &clamp.displacement_m));
      s->clamps.push_back(std::move(clamp));
    }
  }
  if (s->effects.clamps && s->clamps.empty()) return r.Fail("clamps", "missing or empty, but effects.clamps is true");

  return Status::Ok();
}

Status ReadSolver(const Reader& r, const json& doc, SceneSpec* s) {
  // Solver.
  if (doc.contains(sk::Scene::solver)) {
    const json& so = doc[sk::Scene::solver];
    KGD_RETURN_IF_ERROR(r.CheckKeys(so, "solver", "SceneSolver"));
    std::string method = "newton";
    KGD_RETURN_IF_ERROR(r.Choice(so, "solver", sk::SceneSolver::method, {"newton", "lbfgs"}, &method));
    s->solver.method = method == "newton" ? SolverMethod::kNewton : SolverMethod::kLbfgs;
    KGD_RETURN_IF_ERROR(r.Number(so, "solver", sk::SceneSolver::grad_tol, &s->solver.grad_tol));
    if (!(s->solver.grad_tol > 0)) return r.Fail("solver.grad_tol", "must be > 0");
    double it = s->solver.max_iterations, hist = s->solver.lbfgs_history;
    KGD_RETURN_IF_ERROR(r.Number(so, "solver", sk::SceneSolver::max_iterations, &it));
    KGD_RETURN_IF_ERROR(r.Number(so, "solver", sk::SceneSolver::lbfgs_history, &hist));
    if (it < 0 || it > 1e8) return r.Fail("solver.max_iterations", "must be in [0, 1e8]");
    if (hist < 1 || hist > 1000) return r.Fail("solver.lbfgs_history", "must be in [1, 1000]");
    s->solver.max_iterations = static_cast<int>(it);
    s->solver.lbfgs_history = static_cast<int>(hist);
    KGD_RETURN_IF_ERROR(r.Bool(so, "solver", sk::SceneSolver::reuse_factorization, &s->solver.reuse_factorization));
    KGD_RETURN_IF_ERROR(r.Bool(so, "solver", sk::SceneSolver::project_contact_crossings, &s->solver.project_contact_crossings));
    KGD_RETURN_IF_ERROR(r.Bool(so, "solver", sk::SceneSolver::local_steps, &s->solver.local_steps));
  }

  return Status::Ok();
}

// The scene names a garment: a garment mesh of its own (garment.rest) or one cut from the body
// (garment.region). What CheckSceneHasGarment checks before any file is read.
Status GarmentGiven(const Reader& r, const json& doc) {
  if (!doc.is_object() || !doc.contains(sk::Scene::garment))
    return r.Fail("garment", "missing (give garment.rest, or garment.region with body.rest and body.deformed)");
  const json& g = doc[sk::Scene::garment];
  if (g.is_object() && !g.contains(sk::SceneGarment::rest) && !g.contains(sk::SceneGarment::region))
    return r.Fail("garment.rest", "missing (or give garment.region to cut the garment from the body)");
  return Status::Ok();
}

// A scene file's text `text`, named `path`, whose files are in `dir` on disk or in `bundle`.
Result<SceneSpec> LoadSceneText(const std::string& text, const std::string& path, const fs::path& dir, const SceneBundle* bundle,
                                std::vector<std::string>* files_read) {
  json doc;
  try {
    doc = json::parse(text);
  } catch (const json::parse_error& e) {
    return Status::Error(path + ": not valid JSON at byte " + std::to_string(e.byte) + ": " + e.what());
  } catch (const json::exception& e) {  // out_of_range: a number beyond double, e.g. 1e400
    return Status::Error(path + ": not valid JSON: " + e.what());
  }
  const Reader r(path, dir, bundle, files_read);
  SceneSpec s;
  KGD_RETURN_IF_ERROR(r.CheckKeys(doc, "", "Scene"));
  if (doc.contains(sk::Scene::name)) {
    if (!doc[sk::Scene::name].is_string()) return r.Fail("name", "must be a string");
    s.name = doc[sk::Scene::name].get<std::string>();
  } else {
    s.name = fs::path(path).stem().string();
  }
  KGD_RETURN_IF_ERROR(ReadEffects(r, doc, &s));

  KGD_RETURN_IF_ERROR(GarmentGiven(r, doc));
  const json& g = doc[sk::Scene::garment];
  KGD_RETURN_IF_ERROR(r.CheckKeys(g, "garment", "SceneGarment"));
  const json no_object = json::object();
  const json& b = doc.contains(sk::Scene::body) ? doc[sk::Scene::body] : no_object;
  KGD_RETURN_IF_ERROR(r.CheckKeys(b, "body", "SceneBody"));
  KGD_RETURN_IF_ERROR(r.Number(b, "body", sk::SceneBody::support_scale, &s.body_support_scale));
  const json& a = doc.contains(sk::Scene::attachments) ? doc[sk::Scene::attachments] : no_object;
  KGD_RETURN_IF_ERROR(r.CheckKeys(a, "attachments", "SceneAttachments"));
  KGD_RETURN_IF_ERROR(r.Number(a, "attachments", sk::SceneAttachments::stiffness_N_per_m, &s.attachment_stiffness_N_per_m));
  std::vector<MotionEntry> motions;
  KGD_RETURN_IF_ERROR(ReadMotionEntries(r, doc, &motions));
  if (!motions.empty() && !g.contains(sk::SceneGarment::region))
    return r.Fail("motions", "only allowed with garment.region (the motions share the body's rest pose and the garment cut in it)");
  std::vector<BodyEntry> bodies;
  KGD_RETURN_IF_ERROR(ReadBodyEntries(r, doc, &bodies));
  if (!bodies.empty() && !g.contains(sk::SceneGarment::region))
    return r.Fail("bodies", "only allowed with garment.region (the garment is cut from every body by the same region)");
  if (!bodies.empty() && !motions.empty())
    return r.Fail("bodies", "not allowed with motions (a design weighs several motions of one body or one motion of several bodies)");
  if (doc.contains(sk::Scene::body_objective)) {
    if (bodies.empty()) return r.Fail("body_objective", "only allowed with bodies");
    const json& o = doc[sk::Scene::body_objective];
    Result<BodyObjective> objective = BodyObjectiveFromName(o.is_string() ? o.get<std::string>() : o.dump(), "the bodies' objective");
    if (!objective.ok()) return r.Fail("body_objective", objective.message());
    s.body_objective = *objective;
  }
  KGD_RETURN_IF_ERROR(g.contains(sk::SceneGarment::region) ? ReadGarmentCutFromBody(r, g, b, a, motions, bodies, &s)
                                                           : ReadGarmentOfItsOwn(r, g, b, a, &s));
  KGD_RETURN_IF_ERROR(ReadDesign(r, g, &s));
  KGD_RETURN_IF_ERROR(ReadSeams(r, g, &s));
  KGD_RETURN_IF_ERROR(ReadDesignConstraints(r, g, &s));
  if (doc.contains(sk::Scene::description)) {
    if (!doc[sk::Scene::description].is_string()) return r.Fail("description", "must be a string");
    s.description = doc[sk::Scene::description].get<std::string>();
  }
  KGD_RETURN_IF_ERROR(r.Number(doc, "", sk::Scene::budget, &s.budget));
  if (!(s.budget > 0 && s.budget <= 1)) return r.Fail("budget", "must be in (0, 1] (a fraction of the garment area)");
  if (doc.contains(sk::Scene::max_pressure_kPa)) {
    double kpa = 0;
    KGD_RETURN_IF_ERROR(r.Number(doc, "", sk::Scene::max_pressure_kPa, &kpa));
    if (!(kpa > 0 && std::isfinite(kpa))) return r.Fail(sk::Scene::max_pressure_kPa, "must be finite and above 0 (a skin pressure, kPa)");
    s.max_pressure_Pa = 1e3 * kpa;
  }
  KGD_RETURN_IF_ERROR(ReadMaterials(r, doc, &s));
  KGD_RETURN_IF_ERROR(ReadContact(r, doc, b, &s));
  KGD_RETURN_IF_ERROR(ReadAttachmentFaces(r, a, &s));
  KGD_RETURN_IF_ERROR(ReadClamps(r, doc, &s));
  KGD_RETURN_IF_ERROR(ReadSolver(r, doc, &s));

  // Whole-model checks (materials, clamp indices, ...) with the scene file as context.
  Result<GarmentModel> model = BuildGarmentModel(s);
  if (!model.ok()) return Status::Error(path + ": " + model.message());
  return s;
}

}  // namespace

Result<SceneSpec> LoadScene(const std::string& path, std::vector<std::string>* files_read) {
  // A stream on a folder opens and then throws on the first read.
  std::error_code ec;
  if (fs::is_directory(path, ec))
    return Status::Error(path + ": is a folder, not a scene file (for a scene exported there, pass " +
                         (fs::path(path) / "scene.json").string() +
                         "; a built-in scene's name must not also name a file or folder in the working directory)");
  std::ifstream in(path, std::ios::binary);
  if (!in) return Status::Error(path + ": cannot open scene file");
  std::ostringstream text;
  text << in.rdbuf();
  return LoadSceneText(text.str(), path, fs::path(path).parent_path(), nullptr, files_read);
}

Result<SceneSpec> LoadScene(const SceneBundle& bundle, std::vector<std::string>* files_read) {
  SceneBundle normalized{bundle.name, bundle.scene_json, {}};
  for (const auto& [name, bytes] : bundle.files) normalized.files[fs::path(name).lexically_normal().string()] = bytes;
  return LoadSceneText(std::string(bundle.scene_json), bundle.name, fs::path(), &normalized, files_read);
}

Status CheckSceneHasGarment(std::string_view scene_json, const std::string& path) {
  const json doc = json::parse(scene_json, nullptr, /*allow_exceptions=*/false);
  if (doc.is_discarded()) return Status::Error(path + ": not valid JSON");
  return GarmentGiven(Reader(path, fs::path(), nullptr, nullptr), doc);
}

namespace {
Status WriteIndexList(const std::string& path, const std::vector<int>& ids) {
  std::ofstream out(path);
  if (!out) return Status::Error(path + ": cannot open for writing");
  for (int i : ids) out << i << '\n';
  return out ? Status::Ok() : Status::Error(path + ": write failed");
}
const char* RelaxationName(Relaxation r) {
  return r == Relaxation::kExact ? "exact" : r == Relaxation::kAuthors ? "authors" : "none";
}
nlohmann::ordered_json EffectJson(bool on) { return on; }
nlohmann::ordered_json EffectJson(double value) { return value; }
const char* ContactName(ContactModel c);
nlohmann::ordered_json EffectJson(ContactModel c) { return ContactName(c); }
const char* ContactName(ContactModel c) {
  return c == ContactModel::kNone ? "none" : c == ContactModel::kUnilateral ? "unilateral" : "bilateral";
}
nlohmann::ordered_json MaterialJson(const Material& m) {
  return {{sk::SceneMaterial::youngs_modulus_Pa, m.youngs_modulus_Pa}, {sk::SceneMaterial::poisson_ratio, m.poisson_ratio}, {sk::SceneMaterial::thickness_m, m.thickness_m}};
}
}  // namespace

Status ExportScene(const SceneSpec& s, const std::string& dir_path) {
  KGD_RETURN_IF_ERROR(ValidateSceneMotions(s).WithContext(s.name + ": "));
  KGD_RETURN_IF_ERROR(ValidateSceneBodies(s).WithContext(s.name + ": "));
  const fs::path dir(dir_path);
  std::error_code ec;
  fs::create_directories(dir, ec);
  if (ec) return Status::Error(dir_path + ": cannot create directory: " + ec.message());
  nlohmann::ordered_json doc;
  doc[sk::Scene::name] = s.name;
  if (!s.description.empty()) doc[sk::Scene::description] = s.description;
  if (s.budget != 1.0) doc[sk::Scene::budget] = s.budget;
  if (s.max_pressure_Pa > 0) doc[sk::Scene::max_pressure_kPa] = 1e-3 * s.max_pressure_Pa;
  if (s.motion) {
    KGD_RETURN_IF_ERROR(WriteObj((dir / "body_rest.obj").string(), s.motion->rest, s.motion->faces));
    KGD_RETURN_IF_ERROR(WriteObj((dir / "body_deformed.obj").string(), s.motion->deformed, s.motion->faces));
    doc[sk::Scene::body][sk::SceneBody::rest] = "body_rest.obj";
    doc[sk::Scene::body][sk::SceneBody::deformed] = "body_deformed.obj";
    if (!s.motion->frames.empty()) {
      fs::create_directories(dir / "frames", ec);
      if (ec) return Status::Error((dir / "frames").string() + ": cannot create directory: " + ec.message());
      nlohmann::ordered_json frames = nlohmann::ordered_json::array();
      for (size_t i = 0; i < s.motion->frames.size(); ++i) {
        char file[64];
        std::snprintf(file, sizeof file, "frames/frame_%02zu.obj", i + 1);
        KGD_RETURN_IF_ERROR(WriteObj((dir / file).string(), s.motion->frames[i], s.motion->faces));
        frames.push_back(file);
      }
      doc[sk::Scene::body][sk::SceneBody::frames] = frames;
    }
    doc[sk::Scene::body][sk::SceneBody::support_scale] = s.body_support_scale;
    KGD_RETURN_IF_ERROR(WriteIndexList((dir / "garment_region.txt").string(), s.garment_region));
    doc[sk::Scene::garment][sk::SceneGarment::region] = "garment_region.txt";
    doc[sk::Scene::garment][sk::SceneGarment::subdivisions] = s.subdivisions;
    if (!s.motions.empty()) {
      nlohmann::ordered_json motions = nlohmann::ordered_json::array();
      for (size_t m = 0; m < s.motions.size(); ++m) {
        const SceneMotion& sm = s.motions[m];
        nlohmann::ordered_json entry = {{sk::SceneMotion::name, sm.name}, {sk::SceneMotion::role, ToString(sm.role)},
                                        {sk::SceneMotion::weight, sm.weight}};
        if (m > 0) {  // the first motion's poses are body.deformed and body.frames
          const std::string folder = "motions/" + std::to_string(m);
          fs::create_directories(dir / folder, ec);
          if (ec) return Status::Error((dir / folder).string() + ": cannot create directory: " + ec.message());
          KGD_RETURN_IF_ERROR(WriteObj((dir / folder / "deformed.obj").string(), sm.pose.deformed, s.motion->faces));
          entry[sk::SceneMotion::deformed] = folder + "/deformed.obj";
          if (!sm.pose.frames.empty()) {
            nlohmann::ordered_json frames = nlohmann::ordered_json::array();
            for (size_t i = 0; i < sm.pose.frames.size(); ++i) {
              char file[64];
              std::snprintf(file, sizeof file, "/frame_%02zu.obj", i + 1);
              KGD_RETURN_IF_ERROR(WriteObj((dir / (folder + file)).string(), sm.pose.frames[i], s.motion->faces));
              frames.push_back(folder + file);
            }
            entry[sk::SceneMotion::frames] = frames;
          }
        }
        motions.push_back(entry);
      }
      doc[sk::Scene::motions] = motions;
    }
    if (!s.bodies.empty()) {
      // The first body's poses are body.rest, body.deformed and body.frames; every other's in bodies/K/.
      nlohmann::ordered_json bodies = nlohmann::ordered_json::array();
      for (size_t k = 0; k < s.bodies.size(); ++k) {
        const SceneBody& b = s.bodies[k];
        nlohmann::ordered_json entry = {{sk::SceneRangeBody::name, b.name}, {sk::SceneRangeBody::weight, b.weight}};
        if (k > 0) {
          const std::string folder = "bodies/" + std::to_string(k);
          fs::create_directories(dir / folder / (b.pose.frames.empty() ? "" : "frames"), ec);
          if (ec) return Status::Error((dir / folder).string() + ": cannot create directory: " + ec.message());
          KGD_RETURN_IF_ERROR(WriteObj((dir / folder / "rest.obj").string(), b.pose.rest, s.motion->faces));
          KGD_RETURN_IF_ERROR(WriteObj((dir / folder / "deformed.obj").string(), b.pose.deformed, s.motion->faces));
          entry[sk::SceneRangeBody::rest] = folder + "/rest.obj";
          entry[sk::SceneRangeBody::deformed] = folder + "/deformed.obj";
          if (!b.pose.frames.empty()) {
            nlohmann::ordered_json frames = nlohmann::ordered_json::array();
            for (size_t i = 0; i < b.pose.frames.size(); ++i) {
              char file[64];
              std::snprintf(file, sizeof file, "/frames/frame_%02zu.obj", i + 1);
              KGD_RETURN_IF_ERROR(WriteObj((dir / (folder + file)).string(), b.pose.frames[i], s.motion->faces));
              frames.push_back(folder + file);
            }
            entry[sk::SceneRangeBody::frames] = frames;
          }
        }
        bodies.push_back(entry);
      }
      doc[sk::Scene::bodies] = bodies;
      doc[sk::Scene::body_objective] = ToString(s.body_objective);
    }
  } else {
    KGD_RETURN_IF_ERROR(WriteObj((dir / "garment_rest.obj").string(), s.garment.vertices, s.garment.faces));
    doc[sk::Scene::garment][sk::SceneGarment::rest] = "garment_rest.obj";
    if (s.initial != s.garment.vertices) {
      KGD_RETURN_IF_ERROR(WriteObj((dir / "garment_initial.obj").string(), s.initial, s.garment.faces));
      doc[sk::Scene::garment][sk::SceneGarment::initial] = "garment_initial.obj";
    }
  }
  std::vector<int> reinforced;
  for (size_t f = 0; f < s.design.size(); ++f)
    if (s.design[f] == kReinforced) reinforced.push_back(f);
  if (reinforced.empty()) doc[sk::Scene::garment][sk::SceneGarment::design] = "all_cloth";
  else if (reinforced.size() == s.design.size()) doc[sk::Scene::garment][sk::SceneGarment::design] = "all_reinforced";
  else {
    KGD_RETURN_IF_ERROR(WriteIndexList((dir / "reinforced_faces.txt").string(), reinforced));
    doc[sk::Scene::garment][sk::SceneGarment::design] = {{sk::SceneDesign::reinforced_faces, "reinforced_faces.txt"}};
  }
  if (!s.seams.empty()) doc[sk::Scene::garment][sk::SceneGarment::seams] = s.seams;
  if (!s.keep_out_faces.empty()) {
    KGD_RETURN_IF_ERROR(WriteIndexList((dir / "keep_out_faces.txt").string(), s.keep_out_faces));
    doc[sk::Scene::garment][sk::SceneGarment::keep_out] = "keep_out_faces.txt";
  }
  if (!s.keep_in_faces.empty()) {
    KGD_RETURN_IF_ERROR(WriteIndexList((dir / "keep_in_faces.txt").string(), s.keep_in_faces));
    doc[sk::Scene::garment][sk::SceneGarment::keep_in] = "keep_in_faces.txt";
  }
  if (s.symmetry) {
    const SymmetryPlane& p = *s.symmetry;
    nlohmann::ordered_json sym = {{sk::SceneSymmetry::point_m, {p.point_m[0], p.point_m[1], p.point_m[2]}},
                                  {sk::SceneSymmetry::normal, {p.normal[0], p.normal[1], p.normal[2]}}};
    if (p.tolerance_m > 0) sym[sk::SceneSymmetry::tolerance_m] = p.tolerance_m;
    doc[sk::Scene::garment][sk::SceneGarment::symmetry] = sym;
  }
  doc[sk::Scene::materials] = {{sk::SceneMaterials::lame, s.lame == LameConversion::kSolid3D ? "solid3d" : "plane_stress"},
                      {sk::SceneMaterials::cloth, MaterialJson(s.cloth)},
                      {sk::SceneMaterials::reinforced, MaterialJson(s.reinforced)}};
  doc[sk::Scene::effects] = {{sk::SceneEffects::relaxation, RelaxationName(s.effects.relaxation)}, {sk::SceneEffects::clamps, s.effects.clamps}};
#define KGD_WRITE_EFFECT(Y, Class, key, sum_place, Type, effect, value, effect_what, time_what) \
  doc[sk::Scene::effects][sk::SceneEffects::effect] = EffectJson(s.effects.effect);
  KGD_ENERGY_TERMS(KGD_WRITE_EFFECT, )
#undef KGD_WRITE_EFFECT
  if (s.body && !s.motion) {
    KGD_RETURN_IF_ERROR(WriteObj((dir / "body.obj").string(), s.body->vertices, s.body->faces));
    doc[sk::Scene::body] = {{sk::SceneBody::mesh, "body.obj"}, {sk::SceneBody::support_scale, s.body_support_scale}};
  }
  if (s.body) doc[sk::Scene::contact] = {{sk::SceneContact::stiffness_N_per_m, s.contact_stiffness_N_per_m}};
  if (s.motion) {
    if (!s.attachment_body_faces.empty()) {
      KGD_RETURN_IF_ERROR(WriteIndexList((dir / "attachment_body_faces.txt").string(), s.attachment_body_faces));
      doc[sk::Scene::attachments] = {{sk::SceneAttachments::body_faces, "attachment_body_faces.txt"}, {sk::SceneAttachments::stiffness_N_per_m, s.attachment_stiffness_N_per_m}};
    }
  } else if (!s.attachment_faces.empty()) {
    KGD_RETURN_IF_ERROR(WriteIndexList((dir / "attachment_faces.txt").string(), s.attachment_faces));
    doc[sk::Scene::attachments] = {{sk::SceneAttachments::faces, "attachment_faces.txt"}, {sk::SceneAttachments::stiffness_N_per_m, s.attachment_stiffness_N_per_m}};
  }
  if (!s.clamps.empty()) {
    nlohmann::ordered_json cs = nlohmann::ordered_json::array();
    for (size_t i = 0; i < s.clamps.size(); ++i) {
      const Clamp& c = s.clamps[i];
      const std::string file = "clamp_" + std::to_string(i) + "_vertices.txt";
      KGD_RETURN_IF_ERROR(WriteIndexList((dir / file).string(), c.vertices));
      std::string axes;
      for (int k = 0; k < 3; ++k)
        if (c.axes[k]) axes += static_cast<char>('x' + k);
      cs.push_back({{sk::SceneClamp::name, c.name}, {sk::SceneClamp::vertices, file}, {sk::SceneClamp::axes, axes},
                    {sk::SceneClamp::displacement_m, {c.displacement_m[0], c.displacement_m[1], c.displacement_m[2]}}});
    }
    doc[sk::Scene::clamps] = cs;
  }
  doc[sk::Scene::solver] = {{sk::SceneSolver::method, s.solver.method == SolverMethod::kNewton ? "newton" : "lbfgs"},
                   {sk::SceneSolver::grad_tol, s.solver.grad_tol},
                   {sk::SceneSolver::max_iterations, s.solver.max_iterations},
                   {sk::SceneSolver::reuse_factorization, s.solver.reuse_factorization},
                   {sk::SceneSolver::lbfgs_history, s.solver.lbfgs_history},
                   {sk::SceneSolver::project_contact_crossings, s.solver.project_contact_crossings},
                   {sk::SceneSolver::local_steps, s.solver.local_steps}};
  std::ofstream out(dir / "scene.json");
  if (!out) return Status::Error((dir / "scene.json").string() + ": cannot open for writing");
  out << doc.dump(2) << '\n';
  return out ? Status::Ok() : Status::Error((dir / "scene.json").string() + ": write failed");
}

}  // namespace kgd
