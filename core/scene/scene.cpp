#include "core/scene/scene.h"

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <set>
#include <sstream>

#include "core/mesh/mesh_io.h"
#include "core/scene/paper_scenes.h"
#include "core/scene/shapes.h"

namespace kgd {
namespace fs = std::filesystem;
using nlohmann::json;

namespace {

// Typed access to a JSON scene with messages that name the file and the key path.
class Reader {
 public:
  Reader(std::string file, fs::path dir, std::vector<std::string>* files_read)
      : file_(std::move(file)), dir_(std::move(dir)), files_read_(files_read) {}

  Status Fail(const std::string& key, const std::string& what) const {
    return Status::Error(file_ + ": " + key + ": " + what);
  }
  Status CheckKeys(const json& obj, const std::string& path, std::initializer_list<const char*> allowed) const {
    if (!obj.is_object()) return Fail(path.empty() ? "(top level)" : path, "must be an object");
    const std::set<std::string> ok(allowed.begin(), allowed.end());
    for (const auto& [k, v] : obj.items())
      if (!ok.count(k)) {
        std::string list;
        for (const char* a : allowed) list += std::string(list.empty() ? "" : ", ") + a;
        return Fail(path.empty() ? k : path + "." + k, "unknown key (expected one of: " + list + ")");
      }
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
    std::string list;
    for (const char* o : options) list += std::string(list.empty() ? "" : ", ") + o;
    if (!v.is_string()) return Fail(path + "." + key, "must be one of: " + list);
    for (const char* o : options)
      if (v.get<std::string>() == o) { *out = o; return Status::Ok(); }
    return Fail(path + "." + key, "'" + v.get<std::string>() + "' is not one of: " + list);
  }
  std::string Resolve(const std::string& rel) const {
    if (files_read_) files_read_->push_back(rel);
    return (dir_ / rel).lexically_normal().string();
  }
  Result<TriMesh> Mesh(const json& v, const std::string& key) const {
    if (!v.is_string()) return Fail(key, "must be a mesh file path");
    return ReadMesh(Resolve(v.get<std::string>()));
  }
  // An index list given inline or as a file (one integer per line).
  Result<std::vector<int>> Indices(const json& v, const std::string& key) const {
    if (v.is_string()) return ReadIndexList(Resolve(v.get<std::string>()));
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
    if (Status s = CheckKeys(obj, path, {"youngs_modulus_Pa", "poisson_ratio", "thickness_m"}); !s.ok()) return s;
    if (Status s = Number(obj, path, "youngs_modulus_Pa", &m->youngs_modulus_Pa); !s.ok()) return s;
    if (Status s = Number(obj, path, "poisson_ratio", &m->poisson_ratio); !s.ok()) return s;
    return Number(obj, path, "thickness_m", &m->thickness_m);
  }
  const std::string& file() const { return file_; }

 private:
  std::string file_;
  fs::path dir_;
  std::vector<std::string>* files_read_;
};

}  // namespace

Result<SceneSpec> LoadScene(const std::string& path, std::vector<std::string>* files_read) {
  // A stream on a folder opens and then throws on the first read.
  std::error_code ec;
  if (fs::is_directory(path, ec))
    return Status::Error(path + ": is a folder, not a scene file (for a scene exported there, pass " +
                         (fs::path(path) / "scene.json").string() +
                         "; a built-in scene's name must not also name a file or folder in the working directory)");
  std::ifstream in(path);
  if (!in) return Status::Error(path + ": cannot open scene file");
  json doc;
  try {
    doc = json::parse(in);
  } catch (const json::parse_error& e) {
    return Status::Error(path + ": not valid JSON at byte " + std::to_string(e.byte) + ": " + e.what());
  }
  const Reader r(path, fs::path(path).parent_path(), files_read);
  SceneSpec s;
  KGD_RETURN_IF_ERROR(r.CheckKeys(doc, "", {"name", "description", "budget", "garment", "materials", "effects", "body",
                                            "contact", "attachments", "clamps", "solver"}));
  if (doc.contains("name")) {
    if (!doc["name"].is_string()) return r.Fail("name", "must be a string");
    s.name = doc["name"].get<std::string>();
  } else {
    s.name = fs::path(path).stem().string();
  }

  // Effects first: they decide what else is read.
  if (doc.contains("effects")) {
    const json& e = doc["effects"];
    KGD_RETURN_IF_ERROR(r.CheckKeys(e, "effects", {"membrane", "relaxation", "fold_barrier", "contact", "friction", "attachments", "clamps"}));
    KGD_RETURN_IF_ERROR(r.Number(e, "effects", "friction", &s.effects.friction));
    KGD_RETURN_IF_ERROR(r.Bool(e, "effects", "fold_barrier", &s.effects.fold_barrier));
    KGD_RETURN_IF_ERROR(r.Bool(e, "effects", "membrane", &s.effects.membrane));
    KGD_RETURN_IF_ERROR(r.Bool(e, "effects", "attachments", &s.effects.attachments));
    KGD_RETURN_IF_ERROR(r.Bool(e, "effects", "clamps", &s.effects.clamps));
    std::string relax = "exact", contact = "none";
    KGD_RETURN_IF_ERROR(r.Choice(e, "effects", "relaxation", {"exact", "authors", "none"}, &relax));
    KGD_RETURN_IF_ERROR(r.Choice(e, "effects", "contact", {"none", "unilateral", "bilateral"}, &contact));
    s.effects.relaxation = relax == "exact" ? Relaxation::kExact : relax == "authors" ? Relaxation::kAuthors : Relaxation::kNone;
    s.effects.contact = contact == "none" ? ContactModel::kNone
                        : contact == "unilateral" ? ContactModel::kUnilateral : ContactModel::kBilateral;
  }

  // Garment: a mesh of its own, or cut from the body's motion.
  if (!doc.contains("garment"))
    return r.Fail("garment", "missing (give garment.rest, or garment.region with body.rest and body.deformed)");
  const json& g = doc["garment"];
  KGD_RETURN_IF_ERROR(r.CheckKeys(g, "garment", {"rest", "initial", "region", "subdivisions", "design"}));
  const json no_object = json::object();
  const json& b = doc.contains("body") ? doc["body"] : no_object;
  KGD_RETURN_IF_ERROR(r.CheckKeys(b, "body", {"mesh", "rest", "deformed", "frames", "support_scale"}));
  KGD_RETURN_IF_ERROR(r.Number(b, "body", "support_scale", &s.body_support_scale));
  const json& a = doc.contains("attachments") ? doc["attachments"] : no_object;
  KGD_RETURN_IF_ERROR(r.CheckKeys(a, "attachments", {"faces", "body_faces", "stiffness_N_per_m"}));
  KGD_RETURN_IF_ERROR(r.Number(a, "attachments", "stiffness_N_per_m", &s.attachment_stiffness_N_per_m));
  if (g.contains("region")) {
    for (const char* k : {"rest", "initial"})
      if (g.contains(k))
        return r.Fail(std::string("garment.") + k, "not allowed with garment.region (a garment cut from the body takes its shapes from body.rest and body.deformed)");
    if (b.contains("mesh")) return r.Fail("body.mesh", "not allowed with garment.region (give body.rest and body.deformed)");
    if (a.contains("faces")) return r.Fail("attachments.faces", "not allowed with garment.region (give attachments.body_faces, body faces)");
    for (const char* k : {"rest", "deformed"})
      if (!b.contains(k)) return r.Fail(std::string("body.") + k, "missing (required with garment.region)");
    Result<TriMesh> rest = r.Mesh(b["rest"], "body.rest");
    if (!rest.ok()) return rest.status();
    const std::string rest_file = r.Resolve(b["rest"].get<std::string>());
    BodyMotion motion;
    motion.faces = rest->faces;
    motion.rest = rest->vertices;
    std::vector<std::string> names = {rest_file};
    // Every other pose: same vertex count and the very same faces as the rest mesh.
    auto read_pose = [&](const json& v, const std::string& key, Positions* out) -> Status {
      Result<TriMesh> pose = r.Mesh(v, key);
      if (!pose.ok()) return pose.status();
      const std::string file = r.Resolve(v.get<std::string>());
      names.push_back(file);
      if (pose->vertices.rows() != motion.rest.rows())
        return Status::Error(file + ": has " + std::to_string(pose->vertices.rows()) + " vertices but " + rest_file + " has " +
                             std::to_string(motion.rest.rows()) + " (all poses must share one topology)");
      if (pose->faces.rows() != motion.faces.rows())
        return Status::Error(file + ": has " + std::to_string(pose->faces.rows()) + " faces but " + rest_file + " has " +
                             std::to_string(motion.faces.rows()) + " (all poses must share one topology)");
      for (Eigen::Index f = 0; f < motion.faces.rows(); ++f)
        if (pose->faces.row(f) != motion.faces.row(f))
          return Status::Error(file + ": face " + std::to_string(f) + " differs from face " + std::to_string(f) + " of " + rest_file +
                               " (all poses must share one topology)");
      *out = pose->vertices;
      return Status::Ok();
    };
    KGD_RETURN_IF_ERROR(read_pose(b["deformed"], "body.deformed", &motion.deformed));
    if (b.contains("frames")) {
      const json& fr = b["frames"];
      if (!fr.is_array() || fr.empty()) return r.Fail("body.frames", "must be a non-empty array of mesh file paths");
      for (size_t i = 0; i < fr.size(); ++i) {
        motion.frames.emplace_back();
        KGD_RETURN_IF_ERROR(read_pose(fr[i], "body.frames[" + std::to_string(i) + "]", &motion.frames.back()));
      }
    }
    KGD_RETURN_IF_ERROR(ValidateBodyMotion(motion, names));
    s.motion = std::move(motion);
    Result<std::vector<int>> region = r.Indices(g["region"], "garment.region");
    if (!region.ok()) return region.status();
    s.garment_region = std::move(region).value();
    double subdivisions = 0;
    KGD_RETURN_IF_ERROR(r.Number(g, "garment", "subdivisions", &subdivisions));
    if (subdivisions != std::floor(subdivisions) || subdivisions < 0 || subdivisions > 4)
      return r.Fail("garment.subdivisions", "must be an integer in [0, 4]");
    s.subdivisions = static_cast<int>(subdivisions);
    std::string attach_name = r.file() + ": attachments.body_faces";
    if (a.contains("body_faces")) {
      Result<std::vector<int>> faces = r.Indices(a["body_faces"], "attachments.body_faces");
      if (!faces.ok()) return faces.status();
      s.attachment_body_faces = std::move(faces).value();
      if (a["body_faces"].is_string()) attach_name = r.Resolve(a["body_faces"].get<std::string>());
    }
    const std::string region_name = g["region"].is_string() ? r.Resolve(g["region"].get<std::string>()) : r.file() + ": garment.region";
    KGD_RETURN_IF_ERROR(CutGarmentFromMotion(&s, region_name, attach_name));
  } else {
    if (!g.contains("rest")) return r.Fail("garment.rest", "missing (or give garment.region to cut the garment from the body)");
    if (g.contains("subdivisions")) return r.Fail("garment.subdivisions", "only allowed with garment.region");
    for (const char* k : {"rest", "deformed", "frames"})
      if (b.contains(k)) return r.Fail(std::string("body.") + k, "only allowed with garment.region (for a garment of its own give body.mesh)");
    if (a.contains("body_faces")) return r.Fail("attachments.body_faces", "only allowed with garment.region (give attachments.faces)");
    Result<TriMesh> rest = r.Mesh(g["rest"], "garment.rest");
    if (!rest.ok()) return rest.status();
    s.garment = std::move(rest).value();
    KGD_RETURN_IF_ERROR(ValidateMesh(s.garment.vertices, s.garment.faces, r.Resolve(g["rest"].get<std::string>())));
    s.initial = s.garment.vertices;
    if (g.contains("initial")) {
      Result<TriMesh> init = r.Mesh(g["initial"], "garment.initial");
      if (!init.ok()) return init.status();
      const std::string init_file = r.Resolve(g["initial"].get<std::string>());
      if (init->vertices.rows() != s.garment.vertices.rows())
        return Status::Error(init_file + ": has " + std::to_string(init->vertices.rows()) +
                             " vertices but the rest mesh has " + std::to_string(s.garment.vertices.rows()));
      if (init->faces.rows() != s.garment.faces.rows() || init->faces != s.garment.faces)
        return Status::Error(init_file + ": faces differ from the rest mesh (the two poses must share one topology)");
      s.initial = init->vertices;
    }
  }
  const int nf = static_cast<int>(s.garment.faces.rows());
  s.design.assign(nf, kCloth);
  if (g.contains("design")) {
    const json& d = g["design"];
    if (d.is_string()) {
      const std::string v = d.get<std::string>();
      if (v == "all_reinforced") s.design.assign(nf, kReinforced);
      else if (v != "all_cloth") return r.Fail("garment.design", "'" + v + "' is not all_cloth, all_reinforced or an object");
    } else {
      KGD_RETURN_IF_ERROR(r.CheckKeys(d, "garment.design", {"reinforced_faces"}));
      if (d.contains("reinforced_faces")) {
        Result<std::vector<int>> faces = r.Indices(d["reinforced_faces"], "garment.design.reinforced_faces");
        if (!faces.ok()) return faces.status();
        KGD_RETURN_IF_ERROR(ValidateFaceList(*faces, nf, r.file() + ": garment.design.reinforced_faces"));
        for (int f : *faces) s.design[f] = kReinforced;
      }
    }
  }
  if (doc.contains("description")) {
    if (!doc["description"].is_string()) return r.Fail("description", "must be a string");
    s.description = doc["description"].get<std::string>();
  }
  KGD_RETURN_IF_ERROR(r.Number(doc, "", "budget", &s.budget));
  if (!(s.budget > 0 && s.budget <= 1)) return r.Fail("budget", "must be in (0, 1] (a fraction of the garment area)");

  // Materials.
  if (doc.contains("materials")) {
    const json& m = doc["materials"];
    KGD_RETURN_IF_ERROR(r.CheckKeys(m, "materials", {"lame", "cloth", "reinforced"}));
    std::string lame = "solid3d";
    KGD_RETURN_IF_ERROR(r.Choice(m, "materials", "lame", {"solid3d", "plane_stress"}, &lame));
    s.lame = lame == "solid3d" ? LameConversion::kSolid3D : LameConversion::kPlaneStress;
    if (m.contains("cloth")) KGD_RETURN_IF_ERROR(r.MaterialAt(m["cloth"], "materials.cloth", &s.cloth));
    if (m.contains("reinforced")) KGD_RETURN_IF_ERROR(r.MaterialAt(m["reinforced"], "materials.reinforced", &s.reinforced));
  }

  // Body and contact: read only when the effects ask for contact.
  if (doc.contains("contact")) {
    KGD_RETURN_IF_ERROR(r.CheckKeys(doc["contact"], "contact", {"stiffness_N_per_m"}));
    KGD_RETURN_IF_ERROR(r.Number(doc["contact"], "contact", "stiffness_N_per_m", &s.contact_stiffness_N_per_m));
  }
  if (!s.motion && s.effects.contact != ContactModel::kNone) {
    if (!b.contains("mesh")) return r.Fail("body.mesh", "missing, but effects.contact is '" +
                                                            std::string(s.effects.contact == ContactModel::kUnilateral ? "unilateral" : "bilateral") + "'");
    Result<TriMesh> body = r.Mesh(b["mesh"], "body.mesh");
    if (!body.ok()) return body.status();
    KGD_RETURN_IF_ERROR(ValidateMesh(body->vertices, body->faces, r.Resolve(b["mesh"].get<std::string>())));
    s.body = std::move(body).value();
  }

  // Attachments of a garment of its own (a cut garment's come from attachments.body_faces).
  if (a.contains("faces")) {
    Result<std::vector<int>> faces = r.Indices(a["faces"], "attachments.faces");
    if (!faces.ok()) return faces.status();
    KGD_RETURN_IF_ERROR(ValidateFaceList(*faces, nf, r.file() + ": attachments.faces"));
    s.attachment_faces = std::move(faces).value();
  }
  if (s.effects.attachments && s.attachment_faces.empty())
    return r.Fail(s.motion ? "attachments.body_faces" : "attachments.faces", "missing or empty, but effects.attachments is true");

  // Clamps.
  if (doc.contains("clamps")) {
    const json& cs = doc["clamps"];
    if (!cs.is_array()) return r.Fail("clamps", "must be an array");
    for (size_t i = 0; i < cs.size(); ++i) {
      const std::string p = "clamps[" + std::to_string(i) + "]";
      const json& c = cs[i];
      KGD_RETURN_IF_ERROR(r.CheckKeys(c, p, {"name", "vertices", "axes", "displacement_m"}));
      Clamp clamp;
      clamp.name = c.contains("name") && c["name"].is_string() ? c["name"].get<std::string>() : "clamp" + std::to_string(i);
      if (!c.contains("vertices")) return r.Fail(p + ".vertices", "missing");
      const json& v = c["vertices"];
      if (v.is_object()) {
        KGD_RETURN_IF_ERROR(r.CheckKeys(v, p + ".vertices", {"box_min", "box_max"}));
        Eigen::Vector3d lo = Eigen::Vector3d::Constant(-1e300), hi = Eigen::Vector3d::Constant(1e300);
        KGD_RETURN_IF_ERROR(r.Vec3(v, p + ".vertices", "box_min", &lo));
        KGD_RETURN_IF_ERROR(r.Vec3(v, p + ".vertices", "box_max", &hi));
        for (Eigen::Index k = 0; k < s.garment.vertices.rows(); ++k) {
          const Eigen::Vector3d x = s.garment.vertices.row(k);
          if ((x.array() >= lo.array()).all() && (x.array() <= hi.array()).all()) clamp.vertices.push_back(k);
        }
        if (clamp.vertices.empty()) return r.Fail(p + ".vertices", "the box selects no vertex of the rest mesh");
      } else {
        Result<std::vector<int>> ids = r.Indices(v, p + ".vertices");
        if (!ids.ok()) return ids.status();
        clamp.vertices = std::move(ids).value();
      }
      if (c.contains("axes")) {
        if (!c["axes"].is_string()) return r.Fail(p + ".axes", "must be a string of x, y, z (e.g. \"xyz\" or \"z\")");
        const std::string axes = c["axes"].get<std::string>();
        clamp.axes = {false, false, false};
        for (char ch : axes) {
          if (ch < 'x' || ch > 'z') return r.Fail(p + ".axes", "'" + axes + "' may contain only x, y and z");
          clamp.axes[ch - 'x'] = true;
        }
      }
      KGD_RETURN_IF_ERROR(r.Vec3(c, p, "displacement_m", &clamp.displacement_m));
      s.clamps.push_back(std::move(clamp));
    }
  }
  if (s.effects.clamps && s.clamps.empty()) return r.Fail("clamps", "missing or empty, but effects.clamps is true");

  // Solver.
  if (doc.contains("solver")) {
    const json& so = doc["solver"];
    KGD_RETURN_IF_ERROR(r.CheckKeys(so, "solver", {"method", "grad_tol", "max_iterations", "reuse_factorization", "lbfgs_history",
                                                   "project_contact_crossings", "local_steps"}));
    std::string method = "newton";
    KGD_RETURN_IF_ERROR(r.Choice(so, "solver", "method", {"newton", "lbfgs"}, &method));
    s.solver.method = method == "newton" ? SolverMethod::kNewton : SolverMethod::kLbfgs;
    KGD_RETURN_IF_ERROR(r.Number(so, "solver", "grad_tol", &s.solver.grad_tol));
    if (!(s.solver.grad_tol > 0)) return r.Fail("solver.grad_tol", "must be > 0");
    double it = s.solver.max_iterations, hist = s.solver.lbfgs_history;
    KGD_RETURN_IF_ERROR(r.Number(so, "solver", "max_iterations", &it));
    KGD_RETURN_IF_ERROR(r.Number(so, "solver", "lbfgs_history", &hist));
    if (it < 0 || it > 1e8) return r.Fail("solver.max_iterations", "must be in [0, 1e8]");
    if (hist < 1 || hist > 1000) return r.Fail("solver.lbfgs_history", "must be in [1, 1000]");
    s.solver.max_iterations = static_cast<int>(it);
    s.solver.lbfgs_history = static_cast<int>(hist);
    KGD_RETURN_IF_ERROR(r.Bool(so, "solver", "reuse_factorization", &s.solver.reuse_factorization));
    KGD_RETURN_IF_ERROR(r.Bool(so, "solver", "project_contact_crossings", &s.solver.project_contact_crossings));
    KGD_RETURN_IF_ERROR(r.Bool(so, "solver", "local_steps", &s.solver.local_steps));
  }

  // Whole-model checks (materials, clamp indices, ...) with the scene file as context.
  Result<GarmentModel> model = BuildGarmentModel(s);
  if (!model.ok()) return Status::Error(path + ": " + model.message());
  return s;
}

Result<GarmentModel> BuildGarmentModel(const SceneSpec& s) {
  GarmentModel m;
  m.faces = s.garment.faces;
  m.rest = s.garment.vertices;
  m.design = s.design;
  m.cloth = s.cloth;
  m.reinforced = s.reinforced;
  m.lame = s.lame;
  m.effects = s.effects;
  m.contact_stiffness_N_per_m = s.contact_stiffness_N_per_m;
  if (s.initial.rows() != s.garment.vertices.rows())
    return Status::Error("initial positions: " + std::to_string(s.initial.rows()) + " rows for " +
                         std::to_string(s.garment.vertices.rows()) + " vertices");
  if (Status st = ValidateMesh(s.initial, s.garment.faces, "garment initial positions"); !st.ok()) return st;
  if (s.effects.attachments) {
    m.attachments.faces = s.attachment_faces;
    m.attachments.stiffness_N_per_m = s.attachment_stiffness_N_per_m;
    if (Status st = ValidateFaceList(s.attachment_faces, s.garment.faces.rows(), "attachments.faces"); !st.ok()) return st;
    m.attachments.anchors = FaceCentroids(s.on_body.rows() ? s.on_body : s.initial, s.garment.faces, s.attachment_faces);
  }
  if (s.effects.clamps) m.clamps = s.clamps;
  if (s.effects.fold_barrier && s.on_body.rows()) m.fold_reference = s.on_body;
  if (s.effects.friction > 0 && s.on_body.rows()) m.friction_anchor = s.on_body;
  if (s.effects.contact != ContactModel::kNone) {
    if (!s.body) return Status::Error("effects.contact is on but the scene has no body");
    BodyFieldSettings bs;
    bs.support_scale = s.body_support_scale;
    Result<std::shared_ptr<const BodyField>> field = BodyField::Build(s.body->vertices, s.body->faces, bs);
    if (!field.ok()) return field.status();
    m.body = *field;
  }
  if (Status st = ValidateModel(m); !st.ok()) return st;
  return m;
}

Status CutGarmentFromMotion(SceneSpec* s, const std::string& region_name, const std::string& attachments_name) {
  if (!s->motion) return Status::Error(region_name + ": the scene has no body motion to cut the garment from");
  const BodyMotion& m = *s->motion;
  Result<GarmentCut> cut = CutGarment(m.faces, m.rest, s->garment_region, s->attachment_body_faces, s->subdivisions,
                                      region_name, attachments_name);
  if (!cut.ok()) return cut.status();
  s->garment = cut->garment;
  s->garment_from_body = cut->from_body;
  s->initial = s->garment_from_body * m.deformed;
  s->on_body = s->initial;
  s->attachment_faces = cut->attachment_faces;
  s->body = TriMesh{m.deformed, m.faces};
  s->design.assign(s->garment.faces.rows(), kCloth);
  if (Status st = ValidateMesh(s->garment.vertices, s->garment.faces, region_name + " (garment in the rest pose)"); !st.ok()) return st;
  return ValidateMesh(s->initial, s->garment.faces, region_name + " (garment in the deformed pose)");
}

SceneSpec SceneAtFrame(const SceneSpec& spec, int frame, const Positions& start) {
  SceneSpec s = spec;
  const Positions& body = spec.motion->frames[frame];
  s.name = spec.name + " frame " + std::to_string(frame + 1);
  s.body = TriMesh{body, spec.motion->faces};
  s.on_body = spec.garment_from_body * body;
  s.initial = start;
  return s;
}

// ---------------------------------------------------------------------------------------------
// Export.

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
const char* ContactName(ContactModel c) {
  return c == ContactModel::kNone ? "none" : c == ContactModel::kUnilateral ? "unilateral" : "bilateral";
}
nlohmann::ordered_json MaterialJson(const Material& m) {
  return {{"youngs_modulus_Pa", m.youngs_modulus_Pa}, {"poisson_ratio", m.poisson_ratio}, {"thickness_m", m.thickness_m}};
}
}  // namespace

Status ExportScene(const SceneSpec& s, const std::string& dir_path) {
  const fs::path dir(dir_path);
  std::error_code ec;
  fs::create_directories(dir, ec);
  if (ec) return Status::Error(dir_path + ": cannot create directory: " + ec.message());
  nlohmann::ordered_json doc;
  doc["name"] = s.name;
  if (!s.description.empty()) doc["description"] = s.description;
  if (s.budget != 1.0) doc["budget"] = s.budget;
  if (s.motion) {
    KGD_RETURN_IF_ERROR(WriteObj((dir / "body_rest.obj").string(), s.motion->rest, s.motion->faces));
    KGD_RETURN_IF_ERROR(WriteObj((dir / "body_deformed.obj").string(), s.motion->deformed, s.motion->faces));
    doc["body"]["rest"] = "body_rest.obj";
    doc["body"]["deformed"] = "body_deformed.obj";
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
      doc["body"]["frames"] = frames;
    }
    doc["body"]["support_scale"] = s.body_support_scale;
    KGD_RETURN_IF_ERROR(WriteIndexList((dir / "garment_region.txt").string(), s.garment_region));
    doc["garment"]["region"] = "garment_region.txt";
    doc["garment"]["subdivisions"] = s.subdivisions;
  } else {
    KGD_RETURN_IF_ERROR(WriteObj((dir / "garment_rest.obj").string(), s.garment.vertices, s.garment.faces));
    doc["garment"]["rest"] = "garment_rest.obj";
    if (s.initial != s.garment.vertices) {
      KGD_RETURN_IF_ERROR(WriteObj((dir / "garment_initial.obj").string(), s.initial, s.garment.faces));
      doc["garment"]["initial"] = "garment_initial.obj";
    }
  }
  std::vector<int> reinforced;
  for (size_t f = 0; f < s.design.size(); ++f)
    if (s.design[f] == kReinforced) reinforced.push_back(f);
  if (reinforced.empty()) doc["garment"]["design"] = "all_cloth";
  else if (reinforced.size() == s.design.size()) doc["garment"]["design"] = "all_reinforced";
  else {
    KGD_RETURN_IF_ERROR(WriteIndexList((dir / "reinforced_faces.txt").string(), reinforced));
    doc["garment"]["design"] = {{"reinforced_faces", "reinforced_faces.txt"}};
  }
  doc["materials"] = {{"lame", s.lame == LameConversion::kSolid3D ? "solid3d" : "plane_stress"},
                      {"cloth", MaterialJson(s.cloth)},
                      {"reinforced", MaterialJson(s.reinforced)}};
  doc["effects"] = {{"membrane", s.effects.membrane}, {"relaxation", RelaxationName(s.effects.relaxation)},
                    {"fold_barrier", s.effects.fold_barrier},
                    {"contact", ContactName(s.effects.contact)}, {"friction", s.effects.friction},
                    {"attachments", s.effects.attachments},
                    {"clamps", s.effects.clamps}};
  if (s.body && !s.motion) {
    KGD_RETURN_IF_ERROR(WriteObj((dir / "body.obj").string(), s.body->vertices, s.body->faces));
    doc["body"] = {{"mesh", "body.obj"}, {"support_scale", s.body_support_scale}};
  }
  if (s.body) doc["contact"] = {{"stiffness_N_per_m", s.contact_stiffness_N_per_m}};
  if (s.motion) {
    if (!s.attachment_body_faces.empty()) {
      KGD_RETURN_IF_ERROR(WriteIndexList((dir / "attachment_body_faces.txt").string(), s.attachment_body_faces));
      doc["attachments"] = {{"body_faces", "attachment_body_faces.txt"}, {"stiffness_N_per_m", s.attachment_stiffness_N_per_m}};
    }
  } else if (!s.attachment_faces.empty()) {
    KGD_RETURN_IF_ERROR(WriteIndexList((dir / "attachment_faces.txt").string(), s.attachment_faces));
    doc["attachments"] = {{"faces", "attachment_faces.txt"}, {"stiffness_N_per_m", s.attachment_stiffness_N_per_m}};
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
      cs.push_back({{"name", c.name}, {"vertices", file}, {"axes", axes},
                    {"displacement_m", {c.displacement_m[0], c.displacement_m[1], c.displacement_m[2]}}});
    }
    doc["clamps"] = cs;
  }
  doc["solver"] = {{"method", s.solver.method == SolverMethod::kNewton ? "newton" : "lbfgs"},
                   {"grad_tol", s.solver.grad_tol},
                   {"max_iterations", s.solver.max_iterations},
                   {"reuse_factorization", s.solver.reuse_factorization},
                   {"lbfgs_history", s.solver.lbfgs_history},
                   {"project_contact_crossings", s.solver.project_contact_crossings},
                   {"local_steps", s.solver.local_steps}};
  std::ofstream out(dir / "scene.json");
  if (!out) return Status::Error((dir / "scene.json").string() + ": cannot open for writing");
  out << doc.dump(2) << '\n';
  return out ? Status::Ok() : Status::Error((dir / "scene.json").string() + ": write failed");
}

// ---------------------------------------------------------------------------------------------
// Built-in scenes.

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
  for (const char* n : {"sleeve_on_limb", "pull_test_all_cloth", "pull_test_all_reinforced", "pull_test_line", "pull_test_x"})
    names.push_back(n);
  return names;
}

Result<SceneSpec> BuiltinScene(const std::string& name, const BodyMeasurements& measurements) {
  for (const PaperMotion& m : PaperMotions())
    if (m.name == name) {
      Result<ParametricBody> body = BuildParametricBody(measurements);
      if (!body.ok()) return body.status();
      return PaperScene(*body, m);
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
  if (name == "sleeve_on_limb") return SleeveOnLimbScene({});
  const std::string prefix = "pull_test_";
  if (name.rfind(prefix, 0) == 0) return PullTestScene(name.substr(prefix.size()));
  std::string list;
  for (const auto& n : BuiltinSceneNames()) list += (list.empty() ? "" : ", ") + n;
  return Status::Error("unknown built-in scene '" + name + "' (built-in scenes: " + list + ")");
}

Result<SceneSpec> ResolveScene(const std::string& arg, const std::vector<std::string>& body_items) {
  Result<std::optional<BodyMeasurements>> body = ParseBodyMeasurements(body_items);
  if (!body.ok()) return body.status();
  if (std::filesystem::exists(arg)) {
    if (*body) return Status::Error(arg + ": --body applies to built-in scenes, not to scene files");
    return LoadScene(arg);
  }
  if (arg.find('/') != std::string::npos || (arg.size() > 5 && arg.substr(arg.size() - 5) == ".json"))
    return Status::Error(arg + ": no such scene file");
  return ResolveBuiltinScene(arg, body_items);
}

Result<SceneSpec> ResolveBuiltinScene(const std::string& name, const std::vector<std::string>& body_items) {
  Result<std::optional<BodyMeasurements>> body = ParseBodyMeasurements(body_items);
  if (!body.ok()) return body.status();
  return *body ? BuiltinScene(name, **body) : BuiltinScene(name);
}


}  // namespace kgd
