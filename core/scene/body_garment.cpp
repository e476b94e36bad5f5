#include "core/scene/body_garment.h"

#include <algorithm>
#include <cmath>
#include <cstdio>

#include "core/mesh/topology.h"

namespace kgd {

std::optional<BodyVolumeChange> MotionVolumeChange(const BodyMotion& motion) {
  if (!CheckClosedOrientedManifold(motion.faces, "body").ok()) return std::nullopt;
  BodyVolumeChange c;
  c.rest_m3 = EnclosedVolume(motion.rest, motion.faces);
  if (!(c.rest_m3 > 0)) return std::nullopt;  // inside out
  c.pose_m3 = EnclosedVolume(motion.deformed, motion.faces);
  for (size_t k = 0; k < motion.frames.size(); ++k) {
    const double v = EnclosedVolume(motion.frames[k], motion.faces);
    if (std::abs(v - c.rest_m3) > std::abs(c.pose_m3 - c.rest_m3)) {
      c.pose_m3 = v;
      c.frame = static_cast<int>(k) + 1;
    }
  }
  return c;
}

std::string DescribeBodyVolume(const BodyVolumeChange& c) {
  char buf[160];
  const std::string where = c.frame == 0 ? "deformed" : "in frame " + std::to_string(c.frame);
  std::snprintf(buf, sizeof buf, "%.4g m^3 at rest, %.4g m^3 %s (%+.1f %%)", c.rest_m3, c.pose_m3, where.c_str(), 100 * c.Relative());
  return buf;
}

std::string BodyVolumeNote(const BodyVolumeChange& c) {
  const double rel = c.Relative();
  if (std::abs(rel) <= kBodyVolumeNoticeFraction) return "";
  char buf[320];
  std::snprintf(buf, sizeof buf,
                "the posed body %s %.1f %% of its volume; flesh keeps its volume, so the posed meshes are %s (linear-blend "
                "skinning collapses bent joints) and the garment is stretched %s than on the body they stand for",
                rel < 0 ? "loses" : "gains", 100 * std::abs(rel), rel < 0 ? "collapsed" : "swollen", rel < 0 ? "less" : "more");
  return buf;
}

Status ValidateBodyMotion(const BodyMotion& m, const std::vector<std::string>& names) {
  auto name = [&](size_t i) { return i < names.size() ? names[i] : "pose " + std::to_string(i); };
  std::vector<const Positions*> poses = {&m.rest, &m.deformed};
  for (const Positions& f : m.frames) poses.push_back(&f);
  for (size_t i = 0; i < poses.size(); ++i) {
    if (poses[i]->rows() != m.rest.rows())
      return Status::Error(name(i) + ": has " + std::to_string(poses[i]->rows()) + " vertices but " + name(0) + " has " +
                           std::to_string(m.rest.rows()) + " (all poses must share one topology)");
    if (Status st = ValidateMesh(*poses[i], m.faces, name(i)); !st.ok()) return st;
  }
  return Status::Ok();
}

Result<GarmentCut> CutGarment(const Faces& body_faces, const Positions& body_rest, const std::vector<int>& region,
                              const std::vector<int>& attachments, int subdivisions, const std::string& region_name,
                              const std::string& attachments_name) {
  const int nbf = static_cast<int>(body_faces.rows());
  if (region.empty()) return Status::Error(region_name + ": the garment region is empty");
  if (Status st = ValidateFaceList(region, nbf, region_name); !st.ok()) return st;
  if (Status st = ValidateFaceList(attachments, nbf, attachments_name); !st.ok()) return st;
  if (subdivisions < 0 || subdivisions > 4)
    return Status::Error(region_name + ": subdivisions = " + std::to_string(subdivisions) + " is outside [0, 4]");
  std::vector<int> position_in_region(nbf, -1);
  for (size_t i = 0; i < region.size(); ++i) position_in_region[region[i]] = static_cast<int>(i);
  for (size_t i = 0; i < attachments.size(); ++i)
    if (position_in_region[attachments[i]] < 0)
      return Status::Error(attachments_name + ": entry " + std::to_string(i + 1) + ": body face " + std::to_string(attachments[i]) +
                           " is not part of the garment region (" + region_name + ")");

  const SubMesh sub = ExtractFaces(body_faces, region);
  const FacePieces pieces = EdgeConnectedPieces(sub.faces);
  if (pieces.count > 1) {
    std::vector<int> size(pieces.count, 0), first(pieces.count, -1);
    for (size_t f = 0; f < region.size(); ++f) {
      ++size[pieces.piece[f]];
      if (first[pieces.piece[f]] < 0) first[pieces.piece[f]] = region[f];
    }
    std::string list;
    for (int p = 0; p < pieces.count && p < 10; ++p)
      list += (p ? "; " : "") + std::to_string(size[p]) + " faces including body face " + std::to_string(first[p]);
    if (pieces.count > 10) list += "; ...";
    return Status::Error(region_name + ": the garment region is " + std::to_string(pieces.count) +
                         " separate pieces, not one: " + list);
  }

  GarmentCut cut;
  const int nsub = static_cast<int>(sub.vertex_ids.size());
  // Selection of the region's vertices, then one prolongation per subdivision level.
  Eigen::SparseMatrix<double, Eigen::RowMajor> p(nsub, body_rest.rows());
  std::vector<Eigen::Triplet<double>> t;
  for (int i = 0; i < nsub; ++i) t.emplace_back(i, sub.vertex_ids[i], 1.0);
  p.setFromTriplets(t.begin(), t.end());
  Faces faces = sub.faces;
  std::vector<int> parent = region;
  for (int level = 0; level < subdivisions; ++level) {
    const Subdivision s = SubdivideMidpoint(faces, static_cast<int>(p.rows()));
    p = (s.prolongation * p).pruned();
    faces = s.faces;
    std::vector<int> next(4 * parent.size());
    for (size_t f = 0; f < parent.size(); ++f)
      for (int k = 0; k < 4; ++k) next[4 * f + k] = parent[f];
    parent.swap(next);
  }
  cut.from_body = p;
  cut.garment.faces = faces;
  cut.garment.vertices = p * body_rest;
  cut.body_face_of = parent;
  std::vector<char> attached(nbf, 0);
  for (int f : attachments) attached[f] = 1;
  for (size_t f = 0; f < parent.size(); ++f)
    if (attached[parent[f]]) cut.attachment_faces.push_back(static_cast<int>(f));
  return cut;
}

}  // namespace kgd
