#include "core/mesh/topology.h"

#include <algorithm>
#include <map>
#include <numeric>
#include <unordered_map>

namespace kgd {
namespace {

uint64_t EdgeKey(int a, int b) {
  if (a > b) std::swap(a, b);
  return (static_cast<uint64_t>(static_cast<uint32_t>(a)) << 32) | static_cast<uint32_t>(b);
}

int Find(std::vector<int>& parent, int i) {
  while (parent[i] != i) i = parent[i] = parent[parent[i]];
  return i;
}

}  // namespace

std::vector<std::vector<int>> VertexNeighbors(const Faces& faces, int num_vertices) {
  std::vector<std::vector<int>> nbrs(num_vertices);
  for (Eigen::Index f = 0; f < faces.rows(); ++f)
    for (int e = 0; e < 3; ++e) {
      const int a = faces(f, e), b = faces(f, (e + 1) % 3);
      nbrs[a].push_back(b);
      nbrs[b].push_back(a);
    }
  for (auto& n : nbrs) {
    std::sort(n.begin(), n.end());
    n.erase(std::unique(n.begin(), n.end()), n.end());
  }
  return nbrs;
}

VertexFaceIncidence VertexFaces(const Faces& faces, int num_vertices) {
  VertexFaceIncidence r;
  r.begin.assign(num_vertices + 1, 0);
  for (Eigen::Index f = 0; f < faces.rows(); ++f)
    for (int k = 0; k < 3; ++k) ++r.begin[faces(f, k) + 1];
  for (int v = 0; v < num_vertices; ++v) r.begin[v + 1] += r.begin[v];
  r.face.resize(r.begin[num_vertices]);
  std::vector<int> next(r.begin.begin(), r.begin.end() - 1);
  for (Eigen::Index f = 0; f < faces.rows(); ++f)
    for (int k = 0; k < 3; ++k) r.face[next[faces(f, k)]++] = static_cast<int>(f);
  return r;
}

FacePieces EdgeConnectedPieces(const Faces& faces, const std::vector<char>& in) {
  const int nf = static_cast<int>(faces.rows());
  auto member = [&](int f) { return in.empty() || in[f]; };
  std::vector<int> parent(nf);
  std::iota(parent.begin(), parent.end(), 0);
  std::unordered_map<uint64_t, int> first_face;
  first_face.reserve(3 * nf);
  for (int f = 0; f < nf; ++f) {
    if (!member(f)) continue;
    for (int k = 0; k < 3; ++k) {
      auto [it, inserted] = first_face.emplace(EdgeKey(faces(f, k), faces(f, (k + 1) % 3)), f);
      if (!inserted) {
        const int a = Find(parent, f), b = Find(parent, it->second);
        if (a != b) parent[std::max(a, b)] = std::min(a, b);
      }
    }
  }
  FacePieces out;
  out.piece.assign(nf, -1);
  std::vector<int> id_of_root(nf, -1);
  for (int f = 0; f < nf; ++f) {
    if (!member(f)) continue;
    const int root = Find(parent, f);
    if (id_of_root[root] < 0) id_of_root[root] = out.count++;
    out.piece[f] = id_of_root[root];
  }
  return out;
}

std::vector<std::vector<int>> FaceNeighbors(const Faces& faces) {
  std::vector<std::vector<int>> out(faces.rows());
  for (const std::array<int, 2>& pair : MeshHinges(faces).faces) {
    out[pair[0]].push_back(pair[1]);
    out[pair[1]].push_back(pair[0]);
  }
  return out;
}

std::vector<std::vector<int>> BoundaryLoops(const Faces& faces) {
  std::unordered_map<uint64_t, int> count;
  for (Eigen::Index f = 0; f < faces.rows(); ++f)
    for (int k = 0; k < 3; ++k) ++count[EdgeKey(faces(f, k), faces(f, (k + 1) % 3))];
  std::map<int, int> next;  // boundary edge a -> b in face orientation
  for (Eigen::Index f = 0; f < faces.rows(); ++f)
    for (int k = 0; k < 3; ++k) {
      const int a = faces(f, k), b = faces(f, (k + 1) % 3);
      if (count[EdgeKey(a, b)] == 1) next[a] = b;
    }
  std::vector<std::vector<int>> loops;
  while (!next.empty()) {
    std::vector<int> loop;
    int v = next.begin()->first;
    while (true) {
      auto it = next.find(v);
      if (it == next.end()) break;
      loop.push_back(v);
      v = it->second;
      next.erase(it);
    }
    loops.push_back(std::move(loop));
  }
  return loops;
}

Status CheckClosedOrientedManifold(const Faces& faces, const std::string& name) {
  std::unordered_map<uint64_t, std::pair<int, int>> dir;  // (count a<b direction, count a>b direction)
  for (Eigen::Index f = 0; f < faces.rows(); ++f)
    for (int k = 0; k < 3; ++k) {
      const int a = faces(f, k), b = faces(f, (k + 1) % 3);
      auto& d = dir[EdgeKey(a, b)];
      (a < b ? d.first : d.second)++;
    }
  for (const auto& [key, d] : dir) {
    const int a = static_cast<int>(key >> 32), b = static_cast<int>(key & 0xffffffffu);
    const std::string edge = "edge (" + std::to_string(a) + ", " + std::to_string(b) + ")";
    if (d.first + d.second == 1) return Status::Error(name + ": " + edge + " is on a boundary (the surface is not closed)");
    if (d.first + d.second > 2)
      return Status::Error(name + ": " + edge + " has " + std::to_string(d.first + d.second) + " faces (non-manifold)");
    if (d.first != 1 || d.second != 1) return Status::Error(name + ": " + edge + " is traversed twice in the same direction (inconsistent orientation)");
  }
  return Status::Ok();
}

int EulerCharacteristic(const Faces& faces) {
  std::vector<int> used(faces.data(), faces.data() + faces.size());
  std::sort(used.begin(), used.end());
  const long v = std::unique(used.begin(), used.end()) - used.begin();
  std::unordered_map<uint64_t, int> edges;
  for (Eigen::Index f = 0; f < faces.rows(); ++f)
    for (int k = 0; k < 3; ++k) edges[EdgeKey(faces(f, k), faces(f, (k + 1) % 3))] = 1;
  return static_cast<int>(v - static_cast<long>(edges.size()) + faces.rows());
}

SubMesh ExtractFaces(const Faces& faces, const std::vector<int>& face_ids) {
  SubMesh out;
  for (int f : face_ids)
    for (int k = 0; k < 3; ++k) out.vertex_ids.push_back(faces(f, k));
  std::sort(out.vertex_ids.begin(), out.vertex_ids.end());
  out.vertex_ids.erase(std::unique(out.vertex_ids.begin(), out.vertex_ids.end()), out.vertex_ids.end());
  std::unordered_map<int, int> local;
  for (size_t i = 0; i < out.vertex_ids.size(); ++i) local[out.vertex_ids[i]] = static_cast<int>(i);
  out.faces.resize(static_cast<Eigen::Index>(face_ids.size()), 3);
  for (size_t i = 0; i < face_ids.size(); ++i)
    for (int k = 0; k < 3; ++k) out.faces(i, k) = local[faces(face_ids[i], k)];
  return out;
}

Subdivision SubdivideMidpoint(const Faces& faces, int num_vertices) {
  std::unordered_map<uint64_t, int> midpoint;
  std::vector<Eigen::Triplet<double>> p;
  for (int v = 0; v < num_vertices; ++v) p.emplace_back(v, v, 1.0);
  int next = num_vertices;
  auto mid = [&](int a, int b) {
    auto [it, inserted] = midpoint.emplace(EdgeKey(a, b), next);
    if (inserted) {
      p.emplace_back(next, a, 0.5);
      p.emplace_back(next, b, 0.5);
      ++next;
    }
    return it->second;
  };
  Subdivision out;
  out.faces.resize(4 * faces.rows(), 3);
  for (Eigen::Index f = 0; f < faces.rows(); ++f) {
    const int a = faces(f, 0), b = faces(f, 1), c = faces(f, 2);
    const int ab = mid(a, b), bc = mid(b, c), ca = mid(c, a);
    out.faces.row(4 * f + 0) << a, ab, ca;
    out.faces.row(4 * f + 1) << ab, b, bc;
    out.faces.row(4 * f + 2) << ca, bc, c;
    out.faces.row(4 * f + 3) << ab, bc, ca;
  }
  out.prolongation.resize(next, num_vertices);
  out.prolongation.setFromTriplets(p.begin(), p.end());
  return out;
}

Hinges MeshHinges(const Faces& faces) {
  // Each undirected edge with the faces around it, in face order.
  std::map<std::pair<int, int>, std::vector<std::pair<int, int>>> edges;  // (a, b) -> (face, opposite vertex)
  for (Eigen::Index f = 0; f < faces.rows(); ++f)
    for (int k = 0; k < 3; ++k) {
      const int a = faces(f, k), b = faces(f, (k + 1) % 3), c = faces(f, (k + 2) % 3);
      edges[{std::min(a, b), std::max(a, b)}].push_back({static_cast<int>(f), c});
    }
  Hinges h;
  for (const auto& [edge, around] : edges) {
    if (around.size() != 2) continue;
    h.vertices.push_back({edge.first, edge.second, around[0].second, around[1].second});
    h.faces.push_back({around[0].first, around[1].first});
  }
  return h;
}

}  // namespace kgd
