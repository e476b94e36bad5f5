#include "core/mesh/region.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <functional>
#include <limits>
#include <queue>
#include <sstream>
#include <unordered_map>

#include "core/mesh/topology.h"

namespace kgd {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

uint64_t EdgeKey(int a, int b) {
  if (a > b) std::swap(a, b);
  return (static_cast<uint64_t>(static_cast<uint32_t>(a)) << 32) | static_cast<uint32_t>(b);
}

std::string Point(const Eigen::Vector3d& p) {
  char buf[96];
  std::snprintf(buf, sizeof buf, "(%.4f, %.4f, %.4f) m", p.x(), p.y(), p.z());
  return buf;
}

std::string Number(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.6g", v);
  return buf;
}

std::string Triple(const Eigen::Vector3d& p) { return Number(p.x()) + "," + Number(p.y()) + "," + Number(p.z()); }

std::string Cm2(double m2) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.1f cm^2", m2 * 1e4);
  return buf;
}

Eigen::Vector3d Centroid(const Positions& x, const Faces& faces, int f) {
  return (x.row(faces(f, 0)) + x.row(faces(f, 1)) + x.row(faces(f, 2))).transpose() / 3.0;
}

// The point of triangle abc nearest p (Ericson, Real-Time Collision Detection, 5.1.5).
Eigen::Vector3d ClosestPointOnTriangle(const Eigen::Vector3d& p, const Eigen::Vector3d& a, const Eigen::Vector3d& b,
                                       const Eigen::Vector3d& c) {
  const Eigen::Vector3d ab = b - a, ac = c - a, ap = p - a;
  const double d1 = ab.dot(ap), d2 = ac.dot(ap);
  if (d1 <= 0 && d2 <= 0) return a;
  const Eigen::Vector3d bp = p - b;
  const double d3 = ab.dot(bp), d4 = ac.dot(bp);
  if (d3 >= 0 && d4 <= d3) return b;
  const double vc = d1 * d4 - d3 * d2;
  if (vc <= 0 && d1 >= 0 && d3 <= 0) return a + ab * (d1 / (d1 - d3));
  const Eigen::Vector3d cp = p - c;
  const double d5 = ab.dot(cp), d6 = ac.dot(cp);
  if (d6 >= 0 && d5 <= d6) return c;
  const double vb = d5 * d2 - d1 * d6;
  if (vb <= 0 && d2 >= 0 && d6 <= 0) return a + ac * (d2 / (d2 - d6));
  const double va = d3 * d6 - d5 * d4;
  if (va <= 0 && (d4 - d3) >= 0 && (d5 - d6) >= 0) return b + (c - b) * ((d4 - d3) / ((d4 - d3) + (d5 - d6)));
  const double denom = 1.0 / (va + vb + vc);
  return a + ab * (vb * denom) + ac * (vc * denom);
}

// The distance at c through triangle abc from a virtual source at distances da from a and db from b,
// on the far side of edge ab from c (the face unfolded into the plane); +infinity when no such source
// exists or the straight path from it to c misses the edge.
double UnfoldedDistance(const Eigen::Vector3d& a, double da, const Eigen::Vector3d& b, double db, const Eigen::Vector3d& c) {
  const Eigen::Vector3d ab = b - a;
  const double e = ab.norm();
  if (e <= 0) return kInf;
  const Eigen::Vector3d ex = ab / e, ac = c - a;
  const double cx = ac.dot(ex), cy = (ac - cx * ex).norm();
  const double sx = (da * da - db * db + e * e) / (2 * e), sy2 = da * da - sx * sx;
  if (sy2 < 0 || cy <= 0) return kInf;
  const double sy = -std::sqrt(sy2);
  const double cross_x = sx + (cx - sx) * (-sy) / (cy - sy);  // where the path crosses the line of ab
  if (cross_x < 0 || cross_x > e) return kInf;
  return std::hypot(cx - sx, cy - sy);
}

// Faces of `in` grouped by edge-connected piece, largest first.
std::vector<std::vector<int>> PiecesBySize(const Faces& faces, const std::vector<char>& in) {
  const FacePieces pieces = EdgeConnectedPieces(faces, in);
  std::vector<std::vector<int>> out(pieces.count);
  for (size_t f = 0; f < pieces.piece.size(); ++f)
    if (pieces.piece[f] >= 0) out[pieces.piece[f]].push_back(static_cast<int>(f));
  std::stable_sort(out.begin(), out.end(), [](const auto& a, const auto& b) { return a.size() > b.size(); });
  return out;
}

// Tidies a region's boundary (region.h, RegionSpec::tidy_boundary).
void Tidy(const Faces& faces, std::vector<char>* in) {
  const std::vector<std::vector<int>> across = FaceNeighbors(faces);
  auto inside_neighbours = [&](int f) {
    int n = 0;
    for (int g : across[f]) n += (*in)[g];
    return n;
  };
  const int nf = static_cast<int>(faces.rows());
  for (int round = 0; round < kTidyRounds; ++round) {
    bool changed = false;
    for (int f = 0; f < nf; ++f)
      if (!(*in)[f] && inside_neighbours(f) >= 2) (*in)[f] = 1, changed = true;
    for (int f = 0; f < nf; ++f)
      if ((*in)[f] && inside_neighbours(f) <= 1) (*in)[f] = 0, changed = true;
    if (!changed) break;
  }
}

// Applies one rule to the group's faces `in`.
Status ApplyRule(const TriMesh& body, const Positions& centroids, const RegionRule& rule, std::vector<char>* in) {
  const Positions& x = body.vertices;
  const Faces& faces = body.faces;
  const int nf = static_cast<int>(faces.rows());
  if (const auto* plane = std::get_if<PlaneRule>(&rule)) {
    if (!plane->point_m.allFinite() || !plane->normal.allFinite() || plane->normal.norm() == 0)
      return Status::Error(DescribeRule(rule) + ": the normal must be finite and not zero");
    for (int f = 0; f < nf; ++f)
      if ((*in)[f] && (centroids.row(f).transpose() - plane->point_m).dot(plane->normal) < 0) (*in)[f] = 0;
  } else if (const auto* geo = std::get_if<GeodesicRule>(&rule)) {
    if (!geo->centre_m.allFinite() || !(geo->radius_m > 0) || !std::isfinite(geo->radius_m))
      return Status::Error(DescribeRule(rule) + ": the radius must be a finite number above 0 m");
    const SurfacePoint s = NearestSurfacePoint(x, faces, geo->centre_m);
    if (s.distance_m > geo->radius_m)
      return Status::Error(DescribeRule(rule) + ": the point lies " + Number(s.distance_m) + " m from the surface (nearest " +
                           FaceAt(x, faces, s.face) + "), farther than the radius");
    std::vector<std::pair<int, double>> sources;
    for (int k = 0; k < 3; ++k) {
      const int v = faces(s.face, k);
      sources.emplace_back(v, (x.row(v).transpose() - s.point_m).norm());
    }
    const Eigen::VectorXd d = GeodesicDistances(x, faces, sources);
    for (int f = 0; f < nf; ++f)
      if ((*in)[f] && !((d[faces(f, 0)] + d[faces(f, 1)] + d[faces(f, 2)]) / 3.0 <= geo->radius_m)) (*in)[f] = 0;
  } else if (const auto* near = std::get_if<NearRule>(&rule)) {
    if (!near->point_m.allFinite()) return Status::Error(DescribeRule(rule) + ": the point must be finite");
    if (std::find(in->begin(), in->end(), 1) == in->end()) return Status::Ok();
    const SurfacePoint s = NearestSurfacePoint(x, faces, near->point_m, *in);
    const FacePieces pieces = EdgeConnectedPieces(faces, *in);
    for (int f = 0; f < nf; ++f)
      if ((*in)[f] && pieces.piece[f] != pieces.piece[s.face]) (*in)[f] = 0;
  }
  return Status::Ok();
}

}  // namespace

std::vector<int> TidyRegionBoundary(const Faces& faces, const std::vector<int>& region) {
  std::vector<char> in(faces.rows(), 0);
  for (int f : region) in.at(f) = 1;
  Tidy(faces, &in);
  std::vector<int> out;
  for (size_t f = 0; f < in.size(); ++f)
    if (in[f]) out.push_back(static_cast<int>(f));
  return out;
}

std::string FaceAt(const Positions& x, const Faces& faces, int face) {
  return "face " + std::to_string(face) + " at " + Point(Centroid(x, faces, face));
}

std::string DescribeRule(const RegionRule& rule) {
  if (const auto* plane = std::get_if<PlaneRule>(&rule)) return "--plane " + Triple(plane->point_m) + "," + Triple(plane->normal);
  if (const auto* geo = std::get_if<GeodesicRule>(&rule))
    return "--geodesic " + Triple(geo->centre_m) + " --radius " + Number(geo->radius_m);
  return "--near " + Triple(std::get<NearRule>(rule).point_m);
}

SurfacePoint NearestSurfacePoint(const Positions& x, const Faces& faces, const Eigen::Vector3d& p, const std::vector<char>& in) {
  SurfacePoint best;
  best.distance_m = kInf;
  for (Eigen::Index f = 0; f < faces.rows(); ++f) {
    if (!in.empty() && !in[f]) continue;
    const Eigen::Vector3d q = ClosestPointOnTriangle(p, x.row(faces(f, 0)), x.row(faces(f, 1)), x.row(faces(f, 2)));
    const double d = (q - p).norm();
    if (d < best.distance_m) best = {static_cast<int>(f), q, d};
  }
  return best;
}

Eigen::VectorXd GeodesicDistances(const Positions& x, const Faces& faces, const std::vector<std::pair<int, double>>& sources) {
  const int nv = static_cast<int>(x.rows());
  const VertexFaceIncidence around = VertexFaces(faces, nv);
  Eigen::VectorXd d = Eigen::VectorXd::Constant(nv, kInf);
  std::vector<char> done(nv, 0);
  using Entry = std::pair<double, int>;
  std::priority_queue<Entry, std::vector<Entry>, std::greater<Entry>> queue;
  auto offer = [&](int v, double dv) {
    if (dv < d[v]) {
      d[v] = dv;
      queue.push({dv, v});
    }
  };
  for (const auto& [v, d0] : sources) offer(v, d0);
  while (!queue.empty()) {
    const auto [dv, v] = queue.top();
    queue.pop();
    if (done[v] || dv > d[v]) continue;
    done[v] = 1;
    const Eigen::Vector3d xv = x.row(v);
    for (int i = around.begin[v]; i < around.begin[v + 1]; ++i) {
      const int f = around.face[i];
      for (int k = 0; k < 3; ++k) {
        const int c = faces(f, k);
        if (done[c]) continue;
        int b = -1;  // the face's third corner
        for (int j = 0; j < 3; ++j)
          if (faces(f, j) != v && faces(f, j) != c) b = faces(f, j);
        const Eigen::Vector3d xc = x.row(c);
        double best = d[v] + (xc - xv).norm();
        if (b >= 0 && done[b]) {
          const Eigen::Vector3d xb = x.row(b);
          best = std::min({best, d[b] + (xc - xb).norm(), UnfoldedDistance(xv, d[v], xb, d[b], xc)});
        }
        offer(c, best);
      }
    }
  }
  return d;
}

Result<std::vector<int>> SelectRegion(const TriMesh& body, const RegionSpec& spec) {
  if (spec.groups.empty()) return Status::Error("no rule given (--plane, --geodesic with --radius, --near)");
  const int nf = static_cast<int>(body.faces.rows());
  const Positions centroids = FaceCentroids(body.vertices, body.faces);
  std::vector<char> region(nf, 0);
  for (size_t g = 0; g < spec.groups.size(); ++g) {
    const RegionGroup& group = spec.groups[g];
    const std::string where = spec.groups.size() > 1 ? "group " + std::to_string(g + 1) + ": " : "";
    if (group.rules.empty())
      return Status::Error(where + "no rule after " + (group.op == RegionOp::kUnion ? "--union" : "--subtract"));
    std::vector<char> in(nf, 1);
    for (size_t r = 0; r < group.rules.size(); ++r) {
      KGD_RETURN_IF_ERROR(ApplyRule(body, centroids, group.rules[r], &in).WithContext(where));
      if (std::find(in.begin(), in.end(), 1) == in.end())
        return Status::Error(where + DescribeRule(group.rules[r]) +
                             (r == 0 ? ": selects no face of the body" : ": leaves no face of those the rules before it keep"));
    }
    const bool add = g == 0 || group.op == RegionOp::kUnion;
    for (int f = 0; f < nf; ++f)
      if (in[f]) region[f] = add;
  }
  if (std::find(region.begin(), region.end(), 1) == region.end())
    return Status::Error("the rules select no face: the groups after --subtract remove every face");
  if (spec.tidy_boundary) Tidy(body.faces, &region);
  std::vector<int> out;
  for (int f = 0; f < nf; ++f)
    if (region[f]) out.push_back(f);
  if (out.empty()) return Status::Error("the rules select no face once the boundary is tidied (every face selected was a face on its own or an ear)");
  return out;
}

Result<Region> CheckRegion(const TriMesh& body, const std::vector<int>& face_list, const RegionCheckOptions& options) {
  const Positions& x = body.vertices;
  const Faces& faces = body.faces;
  const int nf = static_cast<int>(faces.rows()), nv = static_cast<int>(x.rows());
  KGD_RETURN_IF_ERROR(ValidateFaceList(face_list, nf, "the region"));
  if (face_list.empty()) return Status::Error("the region has no face");
  std::vector<char> in(nf, 0);
  for (int f : face_list) in[f] = 1;
  auto at = [&](int f) { return FaceAt(x, faces, f); };

  // Every body edge with its faces.
  std::unordered_map<uint64_t, std::vector<int>> edge_faces;
  edge_faces.reserve(3 * nf);
  for (int f = 0; f < nf; ++f)
    for (int k = 0; k < 3; ++k) edge_faces[EdgeKey(faces(f, k), faces(f, (k + 1) % 3))].push_back(f);
  auto region_faces_of = [&](int a, int b) {
    int n = 0;
    for (int f : edge_faces[EdgeKey(a, b)]) n += in[f];
    return n;
  };

  // Manifold edges.
  for (int f : face_list)
    for (int k = 0; k < 3; ++k) {
      const int a = faces(f, k), b = faces(f, (k + 1) % 3);
      if (const int n = region_faces_of(a, b); n > 2)
        return Status::Error("the region is not manifold: edge (" + std::to_string(a) + ", " + std::to_string(b) + ") at " +
                             Point(0.5 * (x.row(a) + x.row(b)).transpose()) + " has " + std::to_string(n) + " of its faces, one is " + at(f));
    }

  // One piece.
  if (const auto pieces = PiecesBySize(faces, in); pieces.size() > 1) {
    std::string m = "the region is " + std::to_string(pieces.size()) + " edge-connected pieces, not one:";
    for (size_t p = 0; p < pieces.size() && p < 5; ++p)
      m += std::string(p ? ";" : "") + " " + std::to_string(pieces[p].size()) + " faces with " + at(pieces[p].front());
    if (pieces.size() > 5) m += "; ...";
    return Status::Error(m + " (keep one with --near X,Y,Z)");
  }

  // Pinches: a vertex where the region's faces meet in more than one fan has more than two boundary edges.
  std::vector<int> boundary_edges(nv, 0);
  std::vector<int> a_face(nv, -1);
  for (int f : face_list)
    for (int k = 0; k < 3; ++k) {
      const int a = faces(f, k), b = faces(f, (k + 1) % 3);
      a_face[a] = f;
      if (region_faces_of(a, b) == 1) ++boundary_edges[a], ++boundary_edges[b];
    }
  for (int v = 0; v < nv; ++v)
    if (boundary_edges[v] > 2)
      return Status::Error("the region is pinched at vertex " + std::to_string(v) + " at " + Point(x.row(v).transpose()) +
                           ": its faces there meet at that vertex only (one is " + at(a_face[v]) + ")");

  // Boundary loops and what lies outside each.
  const SubMesh sub = ExtractFaces(faces, face_list);
  std::vector<std::vector<int>> loops = BoundaryLoops(sub.faces);
  for (auto& loop : loops)
    for (int& v : loop) v = sub.vertex_ids[v];
  std::vector<char> out(nf);
  for (int f = 0; f < nf; ++f) out[f] = !in[f];
  const FacePieces outside = EdgeConnectedPieces(faces, out);
  const Eigen::VectorXd areas = FaceAreas(x, faces);
  std::vector<double> outside_area(outside.count, 0.0);
  for (int f = 0; f < nf; ++f)
    if (out[f]) outside_area[outside.piece[f]] += areas[f];
  Region region;
  std::vector<int> filled;
  for (size_t l = 0; l < loops.size(); ++l) {
    const std::vector<int>& loop = loops[l];
    int outside_face = -1;
    for (size_t i = 0; i < loop.size() && outside_face < 0; ++i)
      for (int f : edge_faces[EdgeKey(loop[i], loop[(i + 1) % loop.size()])])
        if (!in[f]) outside_face = f;
    RegionLoop rl;
    rl.vertices = loop;
    for (size_t i = 0; i < loop.size(); ++i) {
      const Eigen::Vector3d a = x.row(loop[i]), b = x.row(loop[(i + 1) % loop.size()]);
      rl.length_m += (b - a).norm();
      rl.centre_m += 0.5 * (a + b) * (b - a).norm();
    }
    if (rl.length_m > 0) rl.centre_m /= rl.length_m;
    char length[32];
    std::snprintf(length, sizeof length, "%.1f cm long", rl.length_m * 100);
    const std::string which = "boundary loop " + std::to_string(l + 1) + " (" + length + ", centre " + Point(rl.centre_m) + ")";
    if (outside_face < 0)
      return Status::Error("the region has a hole: " + which + " runs along the body mesh's own boundary (an opening in the mesh, next to " +
                           at(a_face[loop.front()]) + "); close the mesh there or keep the region off it");
    rl.outside_area_m2 = outside_area[outside.piece[outside_face]];
    if (rl.outside_area_m2 < options.max_hole_area_m2) {
      if (!options.fill_holes)
        return Status::Error("the region has a hole: " + which + " encloses " + Cm2(rl.outside_area_m2) +
                             " outside the region (less than --hole-area, " + Cm2(options.max_hole_area_m2) + "), " + at(outside_face) +
                             " among them (--fill-holes adds them to the region)");
      for (int f = 0; f < nf; ++f)
        if (out[f] && outside.piece[f] == outside.piece[outside_face]) filled.push_back(f);
    }
    region.loops.push_back(std::move(rl));
  }
  if (!filled.empty()) {
    std::vector<int> grown = face_list;
    grown.insert(grown.end(), filled.begin(), filled.end());
    std::sort(grown.begin(), grown.end());
    grown.erase(std::unique(grown.begin(), grown.end()), grown.end());
    Result<Region> again = CheckRegion(body, grown, options);
    if (!again.ok()) return again.status();
    std::sort(filled.begin(), filled.end());
    filled.erase(std::unique(filled.begin(), filled.end()), filled.end());
    again->filled_faces = std::move(filled);
    return again;
  }

  // Slivers: an interior edge whose ends lie on the boundary far apart round their loop, or on two loops.
  std::vector<int> loop_of(nv, -1), step_of(nv, -1);
  for (size_t l = 0; l < loops.size(); ++l)
    for (size_t i = 0; i < loops[l].size(); ++i) loop_of[loops[l][i]] = static_cast<int>(l), step_of[loops[l][i]] = static_cast<int>(i);
  for (int f : face_list)
    for (int k = 0; k < 3; ++k) {
      const int a = faces(f, k), b = faces(f, (k + 1) % 3);
      if (loop_of[a] < 0 || loop_of[b] < 0 || region_faces_of(a, b) != 2) continue;
      bool sliver = loop_of[a] != loop_of[b];
      if (!sliver) {
        const int n = static_cast<int>(loops[loop_of[a]].size()), steps = std::abs(step_of[a] - step_of[b]);
        sliver = std::min(steps, n - steps) > kSliverLoopSteps;
      }
      if (sliver)
        return Status::Error("the region has a sliver: it is one face wide at " + at(f) + ", across edge (" + std::to_string(a) + ", " +
                             std::to_string(b) + ") whose ends both lie on its boundary" +
                             (loop_of[a] != loop_of[b] ? " (on two boundary loops)" : ""));
    }

  region.faces = face_list;
  std::sort(region.faces.begin(), region.faces.end());
  region.vertices = static_cast<int>(sub.vertex_ids.size());
  for (int f : face_list) region.area_m2 += areas[f];
  return region;
}

Result<std::vector<AttachmentBand>> AttachmentBands(const TriMesh& body, const Region& region, double width_m) {
  if (!(width_m > 0) || !std::isfinite(width_m)) return Status::Error("the attachment width must be a finite number above 0 m");
  const SubMesh sub = ExtractFaces(body.faces, region.faces);
  Positions xs(static_cast<Eigen::Index>(sub.vertex_ids.size()), 3);
  std::unordered_map<int, int> local;
  for (size_t i = 0; i < sub.vertex_ids.size(); ++i) {
    xs.row(i) = body.vertices.row(sub.vertex_ids[i]);
    local[sub.vertex_ids[i]] = static_cast<int>(i);
  }
  const Eigen::VectorXd areas = FaceAreas(xs, sub.faces);
  std::vector<AttachmentBand> bands;
  for (size_t l = 0; l < region.loops.size(); ++l) {
    std::vector<std::pair<int, double>> sources;
    for (int v : region.loops[l].vertices) sources.emplace_back(local.at(v), 0.0);
    const Eigen::VectorXd d = GeodesicDistances(xs, sub.faces, sources);
    AttachmentBand band;
    band.loop = static_cast<int>(l);
    double nearest = kInf;
    for (Eigen::Index f = 0; f < sub.faces.rows(); ++f) {
      const double df = (d[sub.faces(f, 0)] + d[sub.faces(f, 1)] + d[sub.faces(f, 2)]) / 3.0;
      nearest = std::min(nearest, df);
      if (df <= width_m) {
        band.faces.push_back(region.faces[f]);
        band.area_m2 += areas[f];
      }
    }
    if (band.faces.empty())
      return Status::Error("the attachment band along boundary loop " + std::to_string(l + 1) + " (centre " + Point(region.loops[l].centre_m) +
                           ") has no face: its nearest face centroid lies " + Number(nearest) + " m from the loop, beyond the width " +
                           Number(width_m) + " m");
    bands.push_back(std::move(band));
  }
  return bands;
}

}  // namespace kgd
