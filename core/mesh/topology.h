// Connectivity queries on face lists: pieces, boundary loops, closed-manifold checks, sub-meshes and
// midpoint subdivision. Connectivity only; geometry enters only where a function takes Positions.
#pragma once

#include <Eigen/SparseCore>
#include <array>
#include <vector>

#include "core/mesh/trimesh.h"
#include "core/util/status.h"

namespace kgd {

// For every vertex, its neighbours along mesh edges (sorted, each once).
std::vector<std::vector<int>> VertexNeighbors(const Faces& faces, int num_vertices);

// The interior edges of a mesh, each with the two faces that share it (a hinge): edge a-b, c the third
// vertex of the first face, d that of the second. Edges of one face (boundary) or of more than two
// (non-manifold) are left out.
struct Hinges {
  std::vector<std::array<int, 4>> vertices;  // a, b, c, d
  std::vector<std::array<int, 2>> faces;     // the face with c, the face with d
};
Hinges MeshHinges(const Faces& faces);

// The faces around each vertex, compressed: those of v are face[begin[v]] .. face[begin[v + 1] - 1], in
// increasing order (a face that names v twice is listed twice).
struct VertexFaceIncidence {
  std::vector<int> begin;  // num_vertices + 1 entries
  std::vector<int> face;
};
VertexFaceIncidence VertexFaces(const Faces& faces, int num_vertices);

// For every face, the faces that share an interior edge with it (MeshHinges: edges of exactly two
// faces). A face with fewer than three has an edge on the boundary (or a non-manifold one).
std::vector<std::vector<int>> FaceNeighbors(const Faces& faces);

// Edge-connected pieces: `piece[f]` in [0, count) for every face; pieces are numbered by their
// smallest face index. With `in` (one entry per face), the pieces of the faces with in[f] only,
// connected through edges between two such faces; piece[f] = -1 for the others.
struct FacePieces {
  std::vector<int> piece;
  int count = 0;
};
FacePieces EdgeConnectedPieces(const Faces& faces, const std::vector<char>& in = {});

// Closed loops of boundary edges (edges with one incident face), each as its vertex sequence in
// the faces' orientation. Precondition: the boundary is made of simple loops (no vertex on two loops).
std::vector<std::vector<int>> BoundaryLoops(const Faces& faces);

// Checks that `faces` form a closed, consistently oriented 2-manifold: every undirected edge has
// exactly two faces that traverse it in opposite directions. Names the first offending edge.
Status CheckClosedOrientedManifold(const Faces& faces, const std::string& name);

// V - E + F over the vertices referenced by `faces`.
int EulerCharacteristic(const Faces& faces);

// The faces `face_ids` of a mesh as a mesh of their own: `faces` re-indexed to `vertex_ids`, the
// parent vertices they use (ascending).
struct SubMesh {
  Faces faces;
  std::vector<int> vertex_ids;
};
SubMesh ExtractFaces(const Faces& faces, const std::vector<int>& face_ids);

// One level of midpoint subdivision: every triangle splits into four (corner triangles first, then
// the middle one, so child f*4+k descends from parent f). New vertices sit at edge midpoints; the
// returned `prolongation` P (new_vertices x old_vertices) gives new positions as P * old positions.
struct Subdivision {
  Faces faces;
  Eigen::SparseMatrix<double, Eigen::RowMajor> prolongation;
};
Subdivision SubdivideMidpoint(const Faces& faces, int num_vertices);

}  // namespace kgd
