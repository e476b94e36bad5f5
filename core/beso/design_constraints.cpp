#include "core/beso/design_constraints.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <numeric>

#include "core/beso/beso.h"
#include "core/mesh/point_cloud.h"
#include "core/sim/garment_system.h"

namespace kgd {
namespace {

std::string Vec(const Eigen::Vector3d& v) {
  char buf[96];
  std::snprintf(buf, sizeof buf, "[%.6g, %.6g, %.6g]", v.x(), v.y(), v.z());
  return buf;
}

// "3, 17, 20 (and 5 more)"
std::string FaceList(const std::vector<int>& faces, size_t shown = 20) {
  std::string s;
  for (size_t i = 0; i < faces.size() && i < shown; ++i) s += (i ? ", " : "") + std::to_string(faces[i]);
  if (faces.size() > shown) s += " (and " + std::to_string(faces.size() - shown) + " more)";
  return s;
}

int Find(std::vector<int>& parent, int a) {
  while (parent[a] != a) a = parent[a] = parent[parent[a]];
  return a;
}

}  // namespace

double DefaultMirrorTolerance(const TriMesh& rest) {
  double sum = 0;
  for (Eigen::Index f = 0; f < rest.faces.rows(); ++f)
    for (int k = 0; k < 3; ++k) sum += (rest.vertices.row(rest.faces(f, k)) - rest.vertices.row(rest.faces(f, (k + 1) % 3))).norm();
  return rest.faces.rows() ? 2.0 * sum / (3.0 * rest.faces.rows()) : 0.0;
}

Result<MirrorPairing> PairMirrorFaces(const TriMesh& rest, const SymmetryPlane& plane) {
  const double length = plane.normal.norm();
  if (!(length > 0) || !plane.normal.allFinite() || !plane.point_m.allFinite())
    return Status::Error("symmetry: the plane's normal " + Vec(plane.normal) + " must be finite and non-zero");
  if (!(plane.tolerance_m >= 0) || !std::isfinite(plane.tolerance_m))
    return Status::Error("symmetry: tolerance_m = " + std::to_string(plane.tolerance_m) + " must be finite and >= 0");
  const Eigen::Vector3d n = plane.normal / length;
  MirrorPairing p;
  p.tolerance_m = plane.tolerance_m > 0 ? plane.tolerance_m : DefaultMirrorTolerance(rest);
  const int nf = static_cast<int>(rest.faces.rows());
  PointCloud cloud{FaceCentroids(rest.vertices, rest.faces)};
  PointCloudTree tree(3, cloud, nanoflann::KDTreeSingleIndexAdaptorParams(16));
  tree.buildIndex();
  p.mirror.assign(nf, -1);
  std::vector<int> unmatched;
  constexpr int kNearest = 4;
  for (int f = 0; f < nf; ++f) {
    const Eigen::Vector3d c = cloud.points.row(f).transpose();
    const Eigen::Vector3d q = c - 2.0 * (c - plane.point_m).dot(n) * n;
    int idx[kNearest];
    double d2[kNearest];
    const size_t found = tree.knnSearch(q.data(), std::min(kNearest, nf), idx, d2);
    int best = -1;
    double best_d2 = 0;
    for (size_t k = 0; k < found; ++k)  // the nearest; among equally near ones, the lowest index
      if (best < 0 || d2[k] < best_d2 || (d2[k] == best_d2 && idx[k] < best)) best = idx[k], best_d2 = d2[k];
    const double d = std::sqrt(best_d2);
    if (best < 0 || d > p.tolerance_m) {
      unmatched.push_back(f);
      continue;
    }
    p.mirror[f] = best;
    p.max_distance_m = std::max(p.max_distance_m, d);
  }
  if (!unmatched.empty()) {
    char tol[48];
    std::snprintf(tol, sizeof tol, "%.3g m", p.tolerance_m);
    return Status::Error("symmetry: the garment is not symmetric about the plane through " + Vec(plane.point_m) + " with normal " +
                         Vec(n) + ": " + std::to_string(unmatched.size()) + " of " + std::to_string(nf) +
                         " faces have no face within " + tol + " of their mirror image: faces " + FaceList(unmatched));
  }
  std::vector<int> parent(nf);
  std::iota(parent.begin(), parent.end(), 0);
  for (int f = 0; f < nf; ++f) {
    const int a = Find(parent, f), b = Find(parent, p.mirror[f]);
    if (a != b) parent[std::max(a, b)] = std::min(a, b);
  }
  std::vector<int> group_of(nf, -1);
  for (int f = 0; f < nf; ++f) {
    const int root = Find(parent, f);
    if (group_of[root] < 0) {
      group_of[root] = static_cast<int>(p.groups.size());
      p.groups.emplace_back();
    }
    p.groups[group_of[root]].push_back(f);
  }
  return p;
}

Result<DesignUnits> MakeDesignUnits(int nf, const std::vector<int>& keep_out, const std::vector<int>& keep_in,
                                    const std::vector<int>& locked_faces, const MirrorPairing* pairing) {
  KGD_RETURN_IF_ERROR(ValidateFaceList(keep_out, nf, "garment.keep_out"));
  KGD_RETURN_IF_ERROR(ValidateFaceList(keep_in, nf, "garment.keep_in"));
  if (pairing && static_cast<int>(pairing->mirror.size()) != nf)
    return Status::Error("symmetry: the pairing has " + std::to_string(pairing->mirror.size()) + " faces, the garment " + std::to_string(nf));
  // Groups: mirror groups, or single faces.
  std::vector<std::vector<int>> groups;
  if (pairing) {
    groups = pairing->groups;
  } else {
    groups.resize(nf);
    for (int f = 0; f < nf; ++f) groups[f] = {f};
  }
  std::vector<int> group_of(nf);
  for (size_t g = 0; g < groups.size(); ++g)
    for (int f : groups[g]) group_of[f] = static_cast<int>(g);
  std::vector<int> out_face(groups.size(), -1), in_face(groups.size(), -1), locked_face(groups.size(), -1);
  for (int f : keep_out) out_face[group_of[f]] = out_face[group_of[f]] < 0 ? f : out_face[group_of[f]];
  for (int f : keep_in) in_face[group_of[f]] = in_face[group_of[f]] < 0 ? f : in_face[group_of[f]];
  for (int f : locked_faces) locked_face[group_of[f]] = locked_face[group_of[f]] < 0 ? f : locked_face[group_of[f]];
  DesignUnits u;
  u.pairing = pairing;
  u.keep_out.assign(nf, 0);
  u.unit_of.assign(nf, -1);
  for (size_t g = 0; g < groups.size(); ++g) {
    if (out_face[g] >= 0 && in_face[g] >= 0)
      return Status::Error(out_face[g] == in_face[g] ? "garment.keep_out and garment.keep_in both hold face " + std::to_string(out_face[g])
                                                     : "garment.keep_out face " + std::to_string(out_face[g]) + " and garment.keep_in face " +
                                                           std::to_string(in_face[g]) + " are mirror images of each other (one mirror group: faces " +
                                                           FaceList(groups[g]) + ")");
    if (out_face[g] >= 0 && locked_face[g] >= 0)
      return Status::Error("garment.keep_out face " + std::to_string(out_face[g]) + " and kept attachment face " + std::to_string(locked_face[g]) +
                           (out_face[g] == locked_face[g] ? "" : " (its mirror image)") + ": a kept attachment cannot be kept out");
    if (out_face[g] >= 0) {
      for (int f : groups[g]) u.keep_out[f] = 1;
      continue;
    }
    for (int f : groups[g]) u.unit_of[f] = static_cast<int>(u.members.size());
    u.members.push_back(groups[g]);
    u.locked.push_back(in_face[g] >= 0 || locked_face[g] >= 0);
  }
  return u;
}

std::vector<uint8_t> FullDesign(const DesignUnits& units) {
  std::vector<uint8_t> d(units.keep_out.size(), kReinforced);
  for (size_t f = 0; f < d.size(); ++f)
    if (units.keep_out[f]) d[f] = kCloth;
  return d;
}

Eigen::VectorXd SymmetrizeOverGroups(const Eigen::VectorXd& s, const Eigen::VectorXd& area, const DesignUnits& units) {
  Eigen::VectorXd out = s;
  if (!units.pairing) return out;
  for (const std::vector<int>& g : units.pairing->groups) {
    if (g.size() < 2) continue;
    double num = 0, den = 0;
    for (int f : g) num += area[f] * s[f], den += area[f];
    for (int f : g) out[f] = num / den;
  }
  return out;
}

std::vector<uint8_t> UpdateDesignOnUnits(const DesignUnits& units, const Eigen::VectorXd& s, const Eigen::VectorXd& area,
                                         const std::vector<uint8_t>& design, double target, double max_admitted) {
  const int nu = static_cast<int>(units.members.size());
  Eigen::VectorXd us(nu), ua(nu);
  std::vector<uint8_t> ud(nu);
  for (int u = 0; u < nu; ++u) {
    const std::vector<int>& m = units.members[u];
    if (m.size() == 1) {
      us[u] = s[m[0]];
      ua[u] = area[m[0]];
    } else {
      double num = 0, den = 0;
      for (int f : m) num += area[f] * s[f], den += area[f];
      us[u] = num / den;
      ua[u] = den;
    }
    ud[u] = design[m[0]];
  }
  const std::vector<uint8_t> next = UpdateDesign(us, ua, ud, target, max_admitted, &units.locked);
  std::vector<uint8_t> out(design.size(), kCloth);
  for (int u = 0; u < nu; ++u)
    for (int f : units.members[u]) out[f] = next[u];
  return out;
}

double LockedArea(const DesignUnits& units, const Eigen::VectorXd& area) {
  double a = 0;
  for (size_t u = 0; u < units.members.size(); ++u)
    if (units.locked[u])
      for (int f : units.members[u]) a += area[f];
  return a;
}

double KeptOutArea(const DesignUnits& units, const Eigen::VectorXd& area) {
  double a = 0;
  for (size_t f = 0; f < units.keep_out.size(); ++f)
    if (units.keep_out[f]) a += area[f];
  return a;
}

Status CheckDesignConstraints(const DesignUnits& units, const std::vector<uint8_t>& design) {
  if (design.size() != units.keep_out.size())
    return Status::Error("the design has " + std::to_string(design.size()) + " faces, the garment " + std::to_string(units.keep_out.size()));
  for (size_t f = 0; f < design.size(); ++f)
    if (units.keep_out[f] && design[f] != kCloth) return Status::Error("kept-out face " + std::to_string(f) + " is reinforced");
  for (size_t u = 0; u < units.members.size(); ++u) {
    const std::vector<int>& m = units.members[u];
    for (int f : m) {
      if (units.locked[u] && design[f] != kReinforced) return Status::Error("kept-in face " + std::to_string(f) + " is cloth");
      if (design[f] != design[m[0]])
        return Status::Error("faces " + std::to_string(m[0]) + " and " + std::to_string(f) + " of one mirror group differ");
    }
  }
  return Status::Ok();
}

}  // namespace kgd
