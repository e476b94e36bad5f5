// Triangle meshes: connectivity (Faces) kept apart from geometry (Positions).
//
// Positions are n x 3, row-major, in metres, so that `positions.data()` is the flat degree-of-freedom
// vector x0 y0 z0 x1 y1 z1 ... used by the simulator. Faces are m x 3 vertex indices, counter-clockwise
// seen from the side the normal points to.
#pragma once

#include <Eigen/Core>
#include <string>
#include <vector>

#include "core/util/status.h"

namespace kgd {

using Positions = Eigen::Matrix<double, Eigen::Dynamic, 3, Eigen::RowMajor>;
using Faces = Eigen::Matrix<int, Eigen::Dynamic, 3, Eigen::RowMajor>;

struct TriMesh {
  Positions vertices;
  Faces faces;
};

// Area of every face (m^2).
Eigen::VectorXd FaceAreas(const Positions& x, const Faces& faces);

// Lumped area of every vertex (m^2): a third of the areas of the faces around it (zero for isolated
// vertices). They sum to the surface area.
Eigen::VectorXd LumpedVertexAreas(const Positions& x, const Faces& faces);

// Volume the surface encloses (m^3), by the divergence theorem: positive when the faces are
// counter-clockwise seen from outside. Precondition: a closed surface (every edge shared by two faces
// of opposite orientation, CheckClosedOrientedManifold); for an open one the value is not a volume.
double EnclosedVolume(const Positions& x, const Faces& faces);

// Mean length of all face edges (m); interior edges count twice, which is what averages over faces want.
double MeanEdgeLength(const Positions& x, const Faces& faces);

// Unit vertex normals: the area-weighted sum of incident face normals, normalized (zero for isolated vertices).
Positions AreaWeightedVertexNormals(const Positions& x, const Faces& faces);

// For every vertex, the mean length of the edges of its one-ring (m); zero for isolated vertices.
Eigen::VectorXd OneRingMeanEdgeLength(const Positions& x, const Faces& faces);

// Centroid of each listed face.
Positions FaceCentroids(const Positions& x, const Faces& faces, const std::vector<int>& face_ids);
// Centroid of every face, in face order.
Positions FaceCentroids(const Positions& x, const Faces& faces);

// Checks what the simulator relies on: finite coordinates, a size that is metres (at most
// kMaxMeshExtent_m across: a larger mesh is taken for one in millimetres or centimetres), indices in
// range, no zero-area (or collinear) faces. `name` (a file name) prefixes the message, which names the
// vertex or face and value.
inline constexpr double kMaxMeshExtent_m = 20.0;
Status ValidateMesh(const Positions& x, const Faces& faces, const std::string& name);

// Checks that a list of face indices is in range and free of duplicates; `what` names the list.
Status ValidateFaceList(const std::vector<int>& face_ids, int num_faces, const std::string& what);

}  // namespace kgd
