#include "server/region_check.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <set>
#include <sstream>

#include "core/beso/design_constraints.h"
#include "core/beso/quality.h"
#include "core/mesh/mesh_io.h"
#include "core/scene/body_garment.h"

namespace kgd::server {
namespace {

std::string Part(const std::string& name) { return "part '" + name + "'"; }

std::string Cut(const std::string& s) { return s.size() > 40 ? s.substr(0, 40) + "..." : s; }

std::string Num(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.6g", v);
  return buf;
}

std::string Vec(const Eigen::Vector3d& v) { return "(" + Num(v.x()) + ", " + Num(v.y()) + ", " + Num(v.z()) + ")"; }

Result<double> Number(const std::string& part, const std::string& text) {
  char* end = nullptr;
  const double v = std::strtod(text.c_str(), &end);
  if (text.empty() || end != text.c_str() + text.size() || !std::isfinite(v))
    return Status::Error(Part(part) + ": '" + Cut(text) + "' is not a finite number");
  return v;
}

Result<int> Integer(const std::string& part, const std::string& text, int lo, int hi) {
  char* end = nullptr;
  const long v = std::strtol(text.c_str(), &end, 10);
  if (text.empty() || end != text.c_str() + text.size() || v < lo || v > hi)
    return Status::Error(Part(part) + ": '" + Cut(text) + "' is not an integer in [" + std::to_string(lo) + ", " + std::to_string(hi) + "]");
  return static_cast<int>(v);
}

Result<bool> Flag(const std::string& part, const std::string& text) {
  if (text.empty() || text == "false") return false;
  if (text == "true") return true;
  return Status::Error(Part(part) + ": '" + Cut(text) + "' is not true or false");
}

// Whitespace-separated body face indices, each in [0, nf); ascending and without repeats.
Result<std::vector<int>> FaceList(const std::string& part, const std::string& text, int nf) {
  std::istringstream in(text);
  std::set<int> out;
  std::string token;
  for (int item = 1; in >> token; ++item) {
    char* end = nullptr;
    const long v = std::strtol(token.c_str(), &end, 10);
    if (end != token.c_str() + token.size() || v < 0 || v > INT32_MAX)
      return Status::Error(Part(part) + ": item " + std::to_string(item) + " '" + Cut(token) + "' is not a face index (an integer >= 0)");
    if (v >= nf)
      return Status::Error(Part(part) + ": face " + std::to_string(v) + " (item " + std::to_string(item) + ") is out of range: the body has " +
                           std::to_string(nf) + " faces (0.." + std::to_string(nf - 1) + ")");
    out.insert(static_cast<int>(v));
  }
  return std::vector<int>(out.begin(), out.end());
}

Result<SymmetryPlane> Plane(const std::string& text) {
  SymmetryPlane plane;  // x = 0
  if (text.empty()) return plane;
  std::vector<double> v;
  std::stringstream in(text);
  for (std::string item; std::getline(in, item, ',');) {
    Result<double> d = Number("symmetryPlane", item);
    if (!d.ok()) return d.status();
    v.push_back(*d);
  }
  if (v.size() != 6) return Status::Error(Part("symmetryPlane") + ": '" + Cut(text) + "' is not X,Y,Z,NX,NY,NZ (six numbers)");
  plane.point_m = {v[0], v[1], v[2]};
  plane.normal = {v[3], v[4], v[5]};
  if (plane.normal.norm() == 0) return Status::Error(Part("symmetryPlane") + ": the normal (" + Cut(text) + ") must not be zero");
  return plane;
}

// Adds to each list its mirror image: for each face f in it the face mirror[f] whose centroid is
// nearest f's mirrored centroid, and each face g whose mirror[g] is in it (on a body symmetric only
// within the tolerance, such as the parametric body, the pairing is not one-to-one, and the first
// alone leaves gaps). mirror: PairMirrorFaces' pairing with a tolerance every face meets; the pairs
// are then held to DefaultMirrorTolerance here (a listed face beyond it is refused, another face
// beyond it is not added), so that a body asymmetric elsewhere still mirrors.
Status MirrorFaces(const TriMesh& body, const std::string& body_name, const SymmetryPlane& plane,
                                     const std::vector<std::vector<int>*>& lists) {
  const Eigen::Vector3d extent = body.vertices.colwise().maxCoeff() - body.vertices.colwise().minCoeff();
  SymmetryPlane loose = plane;
  loose.tolerance_m = 4 * (extent.norm() + (body.vertices.rowwise() - plane.point_m.transpose()).rowwise().norm().maxCoeff()) + 1;
  Result<MirrorPairing> pairing = PairMirrorFaces(body, loose);
  if (!pairing.ok()) return Status::Error(Part("symmetryPlane") + ": " + pairing.message());
  const double tolerance = DefaultMirrorTolerance(body);
  const Eigen::Vector3d n = plane.normal.normalized();
  const Positions centroids = FaceCentroids(body.vertices, body.faces);
  auto image = [&](int f) -> Eigen::Vector3d {
    const Eigen::Vector3d c = centroids.row(f).transpose();
    return c - 2.0 * (c - plane.point_m).dot(n) * n;
  };
  auto paired = [&](int f) { return (centroids.row(pairing->mirror[f]).transpose() - image(f)).norm() <= tolerance; };
  for (std::vector<int>* list : lists) {
    std::set<int> with(list->begin(), list->end());
    for (int f : *list) {
      if (!paired(f))
        return Status::Error(Part("mirror") + ": the body (" + body_name + ") is not mirror symmetric about the plane through " + Vec(plane.point_m) +
                             " with normal " + Vec(n) + ": " + FaceAt(body.vertices, body.faces, f) + " has no mirror face (none within " +
                             Num(tolerance) + " m of its image " + Vec(image(f)) + ")");
      with.insert(pairing->mirror[f]);
    }
    const std::set<int> listed(list->begin(), list->end());
    for (int g = 0; g < static_cast<int>(pairing->mirror.size()); ++g)
      if (listed.count(pairing->mirror[g]) && paired(g)) with.insert(g);
    list->assign(with.begin(), with.end());
  }
  return Status::Ok();
}

// Garment faces (of the cut) whose body face is in `body_faces`.
std::vector<int> GarmentFacesUnder(const GarmentCut& cut, const std::vector<int>& body_faces) {
  const std::set<int> in(body_faces.begin(), body_faces.end());
  std::vector<int> out;
  for (size_t g = 0; g < cut.body_face_of.size(); ++g)
    if (in.count(cut.body_face_of[g])) out.push_back(static_cast<int>(g));
  return out;
}

}  // namespace

Result<RegionCheckAnswer> CheckPaintedRegion(const RegionCheckRequest& r, double machine_factor) {
  const std::string name = r.body_name.empty() ? "body" : r.body_name;
  if (r.body_bytes.empty()) return Status::Error(Part("body") + " (the body mesh in its rest pose, OBJ or PLY) is missing or empty");
  KGD_RETURN_IF_ERROR(CheckMeshBytes(r.body_bytes, name).WithContext(Part("body") + ": "));
  Result<TriMesh> body = ParseMesh(r.body_bytes, name);
  if (!body.ok()) return Status::Error(Part("body") + ": " + body.message());
  KGD_RETURN_IF_ERROR(ValidateMesh(body->vertices, body->faces, name).WithContext(Part("body") + ": "));
  const int nf = static_cast<int>(body->faces.rows());
  auto over = [](const std::string& what, int64_t value, int64_t limit, const char* flag) {
    return Status::Error(what + " " + std::to_string(value) + " is over the limit of " + std::to_string(limit) + " (" + flag + ")");
  };
  if (r.max_mesh_vertices > 0 && body->vertices.rows() > r.max_mesh_vertices)
    return over(Part("body") + ": " + name + ": vertices", body->vertices.rows(), r.max_mesh_vertices, "--max-mesh-vertices");
  if (r.max_mesh_faces > 0 && nf > r.max_mesh_faces) return over(Part("body") + ": " + name + ": faces", nf, r.max_mesh_faces, "--max-mesh-faces");

  Result<bool> mirror = Flag("mirror", r.mirror);
  Result<bool> fill = Flag("fillHoles", r.fill_holes);
  Result<SymmetryPlane> plane = Plane(r.symmetry_plane);
  Result<int> subdivisions = r.subdivisions.empty() ? Result<int>(1) : Integer("subdivisions", r.subdivisions, 0, 4);
  Result<int> frames = r.frames.empty() ? Result<int>(0) : Integer("frames", r.frames, 0, 100000);
  Result<int> motions = r.motions.empty() ? Result<int>(1) : Integer("motions", r.motions, 1, 1000);
  for (const Status& st : {mirror.status(), fill.status(), plane.status(), subdivisions.status(), frames.status(), motions.status()})
    KGD_RETURN_IF_ERROR(st);
  BesoSettings settings;
  if (!r.budget.empty()) {
    Result<double> b = Number("budget", r.budget);
    if (!b.ok()) return b.status();
    if (!(*b > 0 && *b <= 1)) return Status::Error(Part("budget") + ": " + Num(*b) + " is not a fraction in (0, 1]");
    settings.budget = *b;
  }
  std::optional<double> width;
  if (!r.attach_width_m.empty()) {
    Result<double> w = Number("attachWidthM", r.attach_width_m);
    if (!w.ok()) return w.status();
    if (!(*w > 0)) return Status::Error(Part("attachWidthM") + ": " + Num(*w) + " m is not a width above 0 m");
    width = *w;
  }

  Result<std::vector<int>> painted = FaceList("faces", r.faces, nf);
  Result<std::vector<int>> keep_out = FaceList("keepOut", r.keep_out, nf);
  Result<std::vector<int>> keep_in = FaceList("keepIn", r.keep_in, nf);
  for (const Status& st : {painted.status(), keep_out.status(), keep_in.status()}) KGD_RETURN_IF_ERROR(st);
  if (painted->empty()) return Status::Error(Part("faces") + ": the region is empty (no body face painted)");

  RegionCheckAnswer a;
  a.mirrored = *mirror;
  if (*mirror) {
    KGD_RETURN_IF_ERROR(MirrorFaces(*body, name, *plane, {&*painted, &*keep_out, &*keep_in}));
  }
  a.keep_out = *keep_out;
  a.keep_in = *keep_in;
  a.faces = TidyRegionBoundary(body->faces, *painted);

  auto predict = [&](int garment_faces) {
    for (const QualityPreset& q : QualityPresets())
      a.predicted_job_s[q.name] =
          PredictJobCost({.garment_faces = garment_faces, .frames = *frames, .builtin_body = false, .quality = q.quality, .simulations = *motions}, settings)
              .total_s(machine_factor);
  };
  const int per_face = 1 << (2 * *subdivisions);
  if (a.faces.empty()) {
    a.refusal = name + ": the painted faces leave no region once the boundary is tidied (every face was on its own or an ear)";
    predict(0);
    return a;
  }
  Result<Region> region = CheckRegion(*body, a.faces, {kDefaultMaxHoleArea_m2, *fill});
  if (!region.ok()) {
    a.refusal = name + ": " + region.message();  // as `kgd region` prints it
    predict(static_cast<int>(a.faces.size()) * per_face);
    return a;
  }
  a.valid = true;
  a.faces = region->faces;
  a.filled_faces = region->filled_faces;
  for (const auto& [list, part] : {std::pair{&a.keep_out, "keepOut"}, std::pair{&a.keep_in, "keepIn"}})
    for (int f : *list)
      if (!std::binary_search(a.faces.begin(), a.faces.end(), f))
        return Status::Error(Part(part) + ": " + FaceAt(body->vertices, body->faces, f) + " is not in the region");
  for (int f : a.keep_out)
    if (std::binary_search(a.keep_in.begin(), a.keep_in.end(), f))
      return Status::Error(Part("keepOut") + ", " + Part("keepIn") + ": " + FaceAt(body->vertices, body->faces, f) + " is both kept out and kept in");
  if (width) {
    if (region->loops.empty()) return Status::Error(Part("attachWidthM") + ": the region is closed (no boundary loop to attach along)");
    Result<std::vector<AttachmentBand>> bands = AttachmentBands(*body, *region, *width);
    if (!bands.ok()) return Status::Error(Part("attachWidthM") + ": " + name + ": " + bands.message());
    a.bands = std::move(bands).value();
  }
  if (const int64_t n = static_cast<int64_t>(a.faces.size()) * per_face; r.max_mesh_faces > 0 && n > r.max_mesh_faces)
    return over(Part("subdivisions") + ": the garment's faces (" + std::to_string(a.faces.size()) + " x 4^" + std::to_string(*subdivisions) + ")", n,
                r.max_mesh_faces, "--max-mesh-faces");
  Result<GarmentCut> cut = CutGarment(body->faces, body->vertices, a.faces, {}, *subdivisions, Part("faces"), "");
  if (!cut.ok()) return Status::Error(cut.message());
  a.subdivided_vertices = static_cast<int>(cut->garment.vertices.rows());
  a.subdivided_faces = static_cast<int>(cut->garment.faces.rows());
  a.keep_out_garment_faces = GarmentFacesUnder(*cut, a.keep_out);
  a.keep_in_garment_faces = GarmentFacesUnder(*cut, a.keep_in);
  predict(a.subdivided_faces);
  a.region = std::move(region).value();
  return a;
}

}  // namespace kgd::server
