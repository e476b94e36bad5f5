#include "core/fabrication/pattern.h"

// CGAL's parameterization with Eigen's sparse solvers.
#ifndef CGAL_EIGEN3_ENABLED
#define CGAL_EIGEN3_ENABLED
#endif
#include <CGAL/Polygon_mesh_processing/measure.h>
#include <CGAL/Simple_cartesian.h>
#include <CGAL/Surface_mesh.h>
#include <CGAL/Surface_mesh_parameterization/LSCM_parameterizer_3.h>
#include <CGAL/Surface_mesh_parameterization/Error_code.h>
#include <CGAL/Surface_mesh_parameterization/parameterize.h>

#include <algorithm>
#include <cmath>
#include <functional>
#include <limits>
#include <map>
#include <optional>
#include <array>
#include <queue>
#include <set>

#include <Eigen/SVD>
#include <Eigen/SparseCholesky>

#include "core/mesh/topology.h"

namespace kgd {
namespace {

using Kernel = CGAL::Simple_cartesian<double>;
using SurfaceMesh = CGAL::Surface_mesh<Kernel::Point_3>;
namespace SMP = CGAL::Surface_mesh_parameterization;

double CornerAngle(const Eigen::Vector3d& a, const Eigen::Vector3d& b, const Eigen::Vector3d& c) {
  const Eigen::Vector3d u = b - a, v = c - a;
  return std::atan2(u.cross(v).norm(), u.dot(v));
}

using EdgeKey = std::pair<int, int>;
EdgeKey Key(int a, int b) { return a < b ? EdgeKey{a, b} : EdgeKey{b, a}; }

// Shortest path along edges from any vertex of `from` to any vertex of `to` (vertex sequence), with
// edge cost = length x (1 + weight of the faces beside it).
std::vector<int> ShortestPath(const Positions& x, const std::vector<std::vector<std::pair<int, double>>>& graph, const std::vector<char>& from,
                              const std::vector<char>& to) {
  const int n = static_cast<int>(graph.size());
  std::vector<double> dist(n, std::numeric_limits<double>::infinity());
  std::vector<int> prev(n, -1);
  using Item = std::pair<double, int>;
  std::priority_queue<Item, std::vector<Item>, std::greater<>> queue;
  for (int v = 0; v < n; ++v)
    if (from[v]) dist[v] = 0, queue.push({0, v});
  while (!queue.empty()) {
    const auto [d, v] = queue.top();
    queue.pop();
    if (d > dist[v]) continue;
    if (to[v]) {
      std::vector<int> path;
      for (int u = v; u >= 0; u = prev[u]) path.push_back(u);
      std::reverse(path.begin(), path.end());
      return path;
    }
    for (const auto& [u, w] : graph[v])
      if (d + w < dist[u]) dist[u] = d + w, prev[u] = v, queue.push({dist[u], u});
  }
  (void)x;
  return {};
}

// The flat coordinates of a planar piece in its own plane (exact), or nothing if it is not planar.
std::optional<FlatPositions> InPlane(const Positions& x) {
  const Eigen::RowVector3d c = x.colwise().mean();
  const Eigen::MatrixXd centred = x.rowwise() - c;
  Eigen::JacobiSVD<Eigen::MatrixXd> svd(centred, Eigen::ComputeThinV);
  const double size = svd.singularValues()(0);
  if (!(size > 0) || svd.singularValues()(2) > 1e-12 * size) return std::nullopt;
  FlatPositions uv = centred * svd.matrixV().leftCols(2);
  return uv;
}

// As-rigid-as-possible refinement (Liu et al. 2008, local/global) with a free boundary and free scale:
// every triangle's flat image is as close to a rotation of its rest shape as the mesh allows.
void RefineArap(const Positions& x, const Faces& faces, FlatPositions* uv, int iterations) {
  const int nv = static_cast<int>(x.rows()), nf = static_cast<int>(faces.rows());
  // Each triangle in a 2D frame of its own (an isometric copy), and its cotangent weights.
  std::vector<std::array<Eigen::Vector2d, 3>> local(nf);
  std::vector<std::array<double, 3>> cot(nf);  // cot[k]: the angle opposite edge (k, k+1)
  std::vector<Eigen::Triplet<double>> triplets;
  for (int f = 0; f < nf; ++f) {
    const Eigen::Vector3d a = x.row(faces(f, 0)), b = x.row(faces(f, 1)), c = x.row(faces(f, 2));
    const Eigen::Vector3d e1 = (b - a).normalized(), n = (b - a).cross(c - a);
    const Eigen::Vector3d e2 = n.cross(b - a).normalized();
    local[f] = {Eigen::Vector2d(0, 0), Eigen::Vector2d((b - a).norm(), 0), Eigen::Vector2d((c - a).dot(e1), (c - a).dot(e2))};
    for (int k = 0; k < 3; ++k) {
      const Eigen::Vector2d& p = local[f][(k + 2) % 3];
      const Eigen::Vector2d u = local[f][k] - p, v = local[f][(k + 1) % 3] - p;
      const double cross = u.x() * v.y() - u.y() * v.x();
      cot[f][k] = cross != 0 ? 0.5 * u.dot(v) / std::abs(cross) : 0;
      const int i = faces(f, k), j = faces(f, (k + 1) % 3);
      triplets.push_back({i, i, cot[f][k]});
      triplets.push_back({j, j, cot[f][k]});
      triplets.push_back({i, j, -cot[f][k]});
      triplets.push_back({j, i, -cot[f][k]});
    }
  }
  // Vertex 0 stays put (translation); rotation and scale are free.
  triplets.push_back({0, 0, 1e8});
  Eigen::SparseMatrix<double> laplacian(nv, nv);
  laplacian.setFromTriplets(triplets.begin(), triplets.end());
  Eigen::SimplicialLDLT<Eigen::SparseMatrix<double>> solver(laplacian);
  if (solver.info() != Eigen::Success) return;
  std::vector<Eigen::Matrix2d> rotation(nf);
  for (int it = 0; it < iterations; ++it) {
    for (int f = 0; f < nf; ++f) {
      Eigen::Matrix2d s = Eigen::Matrix2d::Zero();
      for (int k = 0; k < 3; ++k) {
        const int i = faces(f, k), j = faces(f, (k + 1) % 3);
        const Eigen::Vector2d du = uv->row(i) - uv->row(j);
        s += cot[f][k] * du * (local[f][k] - local[f][(k + 1) % 3]).transpose();
      }
      Eigen::JacobiSVD<Eigen::Matrix2d> svd(s, Eigen::ComputeFullU | Eigen::ComputeFullV);
      Eigen::Matrix2d r = svd.matrixU() * svd.matrixV().transpose();
      if (r.determinant() < 0) {
        Eigen::Matrix2d u = svd.matrixU();
        u.col(1) *= -1;
        r = u * svd.matrixV().transpose();
      }
      rotation[f] = r;
    }
    Eigen::MatrixX2d rhs = Eigen::MatrixX2d::Zero(nv, 2);
    for (int f = 0; f < nf; ++f)
      for (int k = 0; k < 3; ++k) {
        const int i = faces(f, k), j = faces(f, (k + 1) % 3);
        const Eigen::Vector2d r = cot[f][k] * rotation[f] * (local[f][k] - local[f][(k + 1) % 3]);
        rhs.row(i) += r.transpose();
        rhs.row(j) -= r.transpose();
      }
    rhs.row(0) += 1e8 * uv->row(0);
    const Eigen::MatrixX2d next = solver.solve(rhs);
    if (!next.allFinite()) return;
    const double change = (next - Eigen::MatrixX2d(*uv)).cwiseAbs().maxCoeff();
    *uv = next;
    // Converged to a micrometre: far below what a cutter resolves.
    if (change < 1e-6) break;
  }
}

}  // namespace

double SignedArea(const FlatPositions& p) {
  double a = 0;
  for (Eigen::Index i = 0; i < p.rows(); ++i) {
    const Eigen::Index j = (i + 1) % p.rows();
    a += p(i, 0) * p(j, 1) - p(j, 0) * p(i, 1);
  }
  return 0.5 * a;
}

Distortion MeasureDistortion(const Positions& x, const Faces& faces, const FlatPositions& uv) {
  Distortion d;
  double total = 0;
  for (Eigen::Index f = 0; f < faces.rows(); ++f) {
    Eigen::Vector3d p[3], q[3];
    for (int k = 0; k < 3; ++k) {
      p[k] = x.row(faces(f, k)).transpose();
      q[k] = Eigen::Vector3d(uv(faces(f, k), 0), uv(faces(f, k), 1), 0);
    }
    const double a3 = 0.5 * (p[1] - p[0]).cross(p[2] - p[0]).norm();
    const double a2 = 0.5 * (q[1] - q[0]).cross(q[2] - q[0]).z();
    if (!(a3 > 0)) continue;
    const double area = std::abs(a2 / a3 - 1);
    double angle = 0;
    for (int k = 0; k < 3; ++k)
      angle = std::max(angle, std::abs(CornerAngle(p[k], p[(k + 1) % 3], p[(k + 2) % 3]) - CornerAngle(q[k], q[(k + 1) % 3], q[(k + 2) % 3])));
    angle *= 180 / M_PI;
    if (a2 <= 0) angle = 180;  // a flipped triangle
    // Round-off of an exact (planar) piece is no distortion.
    const double area_noise = 1e-12, angle_noise = 1e-9;
    const double area_d = area < area_noise ? 0 : area;
    if (angle < angle_noise) angle = 0;
    d.area_mean += a3 * area_d;
    d.angle_mean_deg += a3 * angle;
    d.area_max = std::max(d.area_max, area_d);
    d.angle_max_deg = std::max(d.angle_max_deg, angle);
    total += a3;
  }
  if (total > 0) d.area_mean /= total, d.angle_mean_deg /= total;
  return d;
}

Result<FlatPositions> FlattenDisk(const Positions& x, const Faces& faces) {
  if (faces.rows() == 0) return Status::Error("flatten: the piece has no faces");
  if (EulerCharacteristic(faces) != 1 || BoundaryLoops(faces).size() != 1)
    return Status::Error("flatten: the piece is not a disk (Euler characteristic " + std::to_string(EulerCharacteristic(faces)) + ", " +
                         std::to_string(BoundaryLoops(faces).size()) + " boundary loops)");
  // A flat piece is its own pattern, exactly.
  if (std::optional<FlatPositions> plane = InPlane(x)) {
    double signed_area = 0;
    for (Eigen::Index f = 0; f < faces.rows(); ++f) {
      const Eigen::Vector2d a = plane->row(faces(f, 0)), b = plane->row(faces(f, 1)), c = plane->row(faces(f, 2));
      signed_area += (b - a).x() * (c - a).y() - (b - a).y() * (c - a).x();
    }
    if (signed_area < 0) plane->col(0) *= -1;
    return *plane;
  }
  SurfaceMesh sm;
  std::vector<SurfaceMesh::Vertex_index> vs(x.rows());
  for (Eigen::Index v = 0; v < x.rows(); ++v) vs[v] = sm.add_vertex(Kernel::Point_3(x(v, 0), x(v, 1), x(v, 2)));
  for (Eigen::Index f = 0; f < faces.rows(); ++f)
    if (sm.add_face(vs[faces(f, 0)], vs[faces(f, 1)], vs[faces(f, 2)]) == SurfaceMesh::null_face())
      return Status::Error("flatten: face " + std::to_string(f) + " makes the piece non-manifold");
  const auto bhd = CGAL::Polygon_mesh_processing::longest_border(sm).first;
  auto uv = sm.add_property_map<SurfaceMesh::Vertex_index, Kernel::Point_2>("v:uv").first;
  // Least-squares conformal maps (one linear solve) give the start; the as-rigid-as-possible refinement
  // below then trades angles for areas, as fabric does.
  SMP::LSCM_parameterizer_3<SurfaceMesh> lscm;
  const SMP::Error_code err = SMP::parameterize(sm, lscm, bhd, uv);
  if (err != SMP::OK) return Status::Error(std::string("flatten: CGAL LSCM failed: ") + SMP::get_error_message(err));
  FlatPositions out(x.rows(), 2);
  for (Eigen::Index v = 0; v < x.rows(); ++v) out(v, 0) = uv[vs[v]].x(), out(v, 1) = uv[vs[v]].y();
  // Counter-clockwise faces stay counter-clockwise (the parameterization may come out mirrored).
  double signed_area = 0;
  for (Eigen::Index f = 0; f < faces.rows(); ++f) {
    const Eigen::Vector2d a = out.row(faces(f, 0)), b = out.row(faces(f, 1)), c = out.row(faces(f, 2));
    signed_area += (b - a).x() * (c - a).y() - (b - a).y() * (c - a).x();
  }
  if (signed_area < 0) out.col(0) *= -1;
  // LSCM pins two vertices, which fixes an arbitrary scale; the refinement frees it.
  Positions flat3(out.rows(), 3);
  flat3 << out, Eigen::VectorXd::Zero(out.rows());
  const double area3 = FaceAreas(x, faces).sum(), area2 = FaceAreas(flat3, faces).sum();
  if (area2 > 0) out *= std::sqrt(area3 / area2);
  RefineArap(x, faces, &out, 200);
  for (Eigen::Index v = 0; v < out.rows(); ++v)
    if (!std::isfinite(out(v, 0)) || !std::isfinite(out(v, 1))) return Status::Error("flatten: vertex " + std::to_string(v) + " got no flat position");
  return out;
}

// Cuts `garment` along `seams` and flattens every piece.
Result<Pattern> CutAlong(const TriMesh& garment, const std::vector<Seam>& seams, std::map<EdgeKey, std::vector<int>>& edge_faces) {
  const Positions& x = garment.vertices;
  const Faces& faces = garment.faces;
  const int nv = static_cast<int>(x.rows()), nf = static_cast<int>(faces.rows());
  // Cut edges: the seams' edges, each checked to be a mesh edge inside the cloth.
  std::set<EdgeKey> cut;
  for (size_t s = 0; s < seams.size(); ++s) {
    const std::vector<int>& p = seams[s].vertices;
    if (p.size() < 2) return Status::Error("pattern: seam " + std::to_string(s + 1) + " has fewer than two vertices");
    for (size_t i = 0; i + 1 < p.size(); ++i) {
      if (p[i] < 0 || p[i] >= nv || p[i + 1] < 0 || p[i + 1] >= nv)
        return Status::Error("pattern: seam " + std::to_string(s + 1) + " names vertex " + std::to_string(std::max(p[i], p[i + 1])) +
                             ", not a garment vertex");
      const auto it = edge_faces.find(Key(p[i], p[i + 1]));
      if (it == edge_faces.end())
        return Status::Error("pattern: seam " + std::to_string(s + 1) + " is not a path along edges: vertices " + std::to_string(p[i]) + " and " +
                             std::to_string(p[i + 1]) + " share no edge");
      if (it->second.size() != 2)
        return Status::Error("pattern: seam " + std::to_string(s + 1) + " runs along the garment's edge at vertices " + std::to_string(p[i]) +
                             "-" + std::to_string(p[i + 1]));
      cut.insert(Key(p[i], p[i + 1]));
    }
  }

  // Faces connected across uncut edges form the pieces.
  std::vector<int> piece_of(nf, -1);
  int pieces = 0;
  for (int f0 = 0; f0 < nf; ++f0) {
    if (piece_of[f0] >= 0) continue;
    std::vector<int> stack = {f0};
    piece_of[f0] = pieces;
    while (!stack.empty()) {
      const int f = stack.back();
      stack.pop_back();
      for (int k = 0; k < 3; ++k) {
        const EdgeKey e = Key(faces(f, k), faces(f, (k + 1) % 3));
        if (cut.count(e)) continue;
        for (int g : edge_faces[e])
          if (piece_of[g] < 0) piece_of[g] = pieces, stack.push_back(g);
      }
    }
    ++pieces;
  }

  // Each piece's vertices: a garment vertex gets one copy per fan of the piece's faces around it that
  // is connected across uncut edges (so a seam through a piece opens it).
  const VertexFaceIncidence vf = VertexFaces(faces, nv);
  Pattern pattern;
  pattern.seams = seams;
  pattern.pieces.resize(pieces);
  std::vector<std::map<int, int>> copy_of_face_corner(nf);  // face -> (garment vertex -> piece vertex)
  for (int v = 0; v < nv; ++v) {
    std::vector<int> around;
    for (int i = vf.begin[v]; i < vf.begin[v + 1]; ++i) around.push_back(vf.face[i]);
    std::map<int, int> fan;  // face -> fan id
    int fans = 0;
    for (int f0 : around) {
      if (fan.count(f0)) continue;
      std::vector<int> stack = {f0};
      fan[f0] = fans;
      while (!stack.empty()) {
        const int f = stack.back();
        stack.pop_back();
        for (int k = 0; k < 3; ++k) {
          const int a = faces(f, k), b = faces(f, (k + 1) % 3);
          if (a != v && b != v) continue;
          const EdgeKey e = Key(a, b);
          if (cut.count(e)) continue;
          for (int g : edge_faces[e])
            if (!fan.count(g) && piece_of[g] == piece_of[f0]) fan[g] = fans, stack.push_back(g);
        }
      }
      ++fans;
    }
    std::vector<int> vertex_of_fan(fans, -1);
    for (const auto& [f, id] : fan) {
      PatternPiece& p = pattern.pieces[piece_of[f]];
      if (vertex_of_fan[id] < 0) {
        vertex_of_fan[id] = static_cast<int>(p.garment_vertex.size());
        p.garment_vertex.push_back(v);
      }
      copy_of_face_corner[f][v] = vertex_of_fan[id];
    }
  }
  for (int f = 0; f < nf; ++f) pattern.pieces[piece_of[f]].garment_faces.push_back(f);

  for (size_t i = 0; i < pattern.pieces.size(); ++i) {
    PatternPiece& p = pattern.pieces[i];
    p.faces.resize(p.garment_faces.size(), 3);
    for (size_t j = 0; j < p.garment_faces.size(); ++j)
      for (int k = 0; k < 3; ++k) p.faces(j, k) = copy_of_face_corner[p.garment_faces[j]].at(faces(p.garment_faces[j], k));
    p.rest.resize(p.garment_vertex.size(), 3);
    for (size_t v = 0; v < p.garment_vertex.size(); ++v) p.rest.row(v) = x.row(p.garment_vertex[v]);
    Result<FlatPositions> flat = FlattenDisk(p.rest, p.faces);
    if (!flat.ok()) return flat.status().WithContext("pattern piece " + std::to_string(i + 1) + ": ");
    p.flat = std::move(flat).value();
    p.distortion = MeasureDistortion(p.rest, p.faces, p.flat);
    const std::vector<std::vector<int>> outline = BoundaryLoops(p.faces);
    p.outline = outline.front();
    FlatPositions polygon(p.outline.size(), 2);
    for (size_t k = 0; k < p.outline.size(); ++k) polygon.row(k) = p.flat.row(p.outline[k]);
    if (SignedArea(polygon) < 0) std::reverse(p.outline.begin(), p.outline.end());
  }
  return pattern;
}

static Pattern SplitOpposite(const TriMesh& garment, const std::vector<std::vector<int>>& loops, const std::vector<std::vector<std::pair<int, double>>>& graph,
                      std::map<EdgeKey, std::vector<int>>& edge_faces, const PatternOptions& options, Pattern pattern);

Result<Pattern> CutPattern(const TriMesh& garment, const PatternOptions& options) {
  const Positions& x = garment.vertices;
  const Faces& faces = garment.faces;
  const int nv = static_cast<int>(x.rows()), nf = static_cast<int>(faces.rows());
  if (nf == 0) return Status::Error("pattern: the garment has no faces");
  if (EdgeConnectedPieces(faces).count != 1) return Status::Error("pattern: the garment is not one connected piece");
  const std::vector<std::vector<int>> loops = BoundaryLoops(faces);
  if (loops.empty()) return Status::Error("pattern: the garment is closed (no boundary): it cannot be cut into pieces along seams from its edges");
  const int chi = EulerCharacteristic(faces);
  if (chi != 2 - static_cast<int>(loops.size()))
    return Status::Error("pattern: the garment has handles (Euler characteristic " + std::to_string(chi) + " with " +
                         std::to_string(loops.size()) + " boundary loops); give its seams");

  // Edges and their faces.
  std::map<EdgeKey, std::vector<int>> edge_faces;
  for (int f = 0; f < nf; ++f)
    for (int k = 0; k < 3; ++k) edge_faces[Key(faces(f, k), faces(f, (k + 1) % 3))].push_back(f);

  // Seams: given, or shortest paths joining every loop to the ones joined before.
  std::vector<Seam> seams = options.seams;
  // Edge graphs through the cloth (not along its edge): by length, and by length weighted by strain.
  std::vector<std::vector<std::pair<int, double>>> graph(nv), by_length(nv);
  double mean_strain = 0;
  if (options.strain.size() == nf) mean_strain = options.strain.cwiseAbs().mean();
  for (const auto& [e, fs] : edge_faces) {
    if (fs.size() != 2) continue;
    const double length = (x.row(e.first) - x.row(e.second)).norm();
    double w = length;
    if (mean_strain > 0) w *= 1 + 0.5 * (std::abs(options.strain[fs[0]]) + std::abs(options.strain[fs[1]])) / mean_strain;
    graph[e.first].push_back({e.second, w});
    graph[e.second].push_back({e.first, w});
    by_length[e.first].push_back({e.second, length});
    by_length[e.second].push_back({e.first, length});
  }
  if (seams.empty() && loops.size() > 1) {
    // Boundary vertices may start or end a seam; the edges between them stay out of the graph.
    std::vector<char> joined(nv, 0);
    for (int v : loops[0]) joined[v] = 1;
    for (size_t l = 1; l < loops.size(); ++l) {
      std::vector<char> from(nv, 0);
      for (int v : loops[l]) from[v] = 1;
      std::vector<int> path = ShortestPath(x, graph, from, joined);
      if (path.size() < 2) return Status::Error("pattern: no seam joins boundary loop " + std::to_string(l + 1) + " to the others");
      seams.push_back({path});
      for (int v : path) joined[v] = 1;
      for (int v : loops[l]) joined[v] = 1;
    }
  }

  Result<Pattern> pattern = CutAlong(garment, seams, edge_faces);
  if (!pattern.ok() || !options.seams.empty()) return pattern;
  // The second seam runs straight across, whatever the strain.
  if (loops.size() == 2) return SplitOpposite(garment, loops, by_length, edge_faces, options, std::move(pattern).value());
  return pattern;
}

namespace {

bool OverLimits(const Pattern& p, const PatternOptions& o) {
  for (const PatternPiece& piece : p.pieces)
    if (piece.distortion.area_mean > o.max_area_distortion_mean || piece.distortion.area_max > o.max_area_distortion_max) return true;
  return false;
}

}  // namespace

static Pattern SplitOpposite(const TriMesh& garment, const std::vector<std::vector<int>>& loops, const std::vector<std::vector<std::pair<int, double>>>& graph,
                      std::map<EdgeKey, std::vector<int>>& edge_faces, const PatternOptions& options, Pattern pattern) {
  const int nv = static_cast<int>(garment.vertices.rows());
  const Positions& x = garment.vertices;
  const std::vector<Seam>& seams = pattern.seams;
  // A sleeve whose one piece stretches more than the limits opens along a second seam, opposite the
  // first: two halves, each closer to developable.
  if (!OverLimits(pattern, options)) return pattern;
  auto opposite = [&](const std::vector<int>& loop, int v) {
    const auto at = std::find(loop.begin(), loop.end(), v);
    if (at == loop.end()) return -1;
    return loop[((at - loop.begin()) + loop.size() / 2) % loop.size()];
  };
  const std::vector<int>& first = seams.front().vertices;
  const bool starts_on_0 = std::find(loops[0].begin(), loops[0].end(), first.front()) != loops[0].end();
  const int a = opposite(loops[0], starts_on_0 ? first.front() : first.back());
  const int b = opposite(loops[1], starts_on_0 ? first.back() : first.front());
  if (a < 0 || b < 0) return pattern;
  std::vector<char> from(nv, 0), to(nv, 0);
  from[a] = 1;
  to[b] = 1;
  std::vector<int> path = ShortestPath(x, graph, from, to);
  for (int v : path)
    if (std::find(first.begin(), first.end(), v) != first.end()) return pattern;  // the seams would cross
  if (path.size() < 2) return pattern;
  std::vector<Seam> two = seams;
  two.push_back({path});
  Result<Pattern> halves = CutAlong(garment, two, edge_faces);
  return halves.ok() ? std::move(halves).value() : pattern;
}


}  // namespace kgd
