// How far apart two designs are: the area-weighted Jaccard index of their reinforced sets, on one mesh
// or, through the surface both meshes cover, across meshes of different resolution.
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <vector>

#include "core/mesh/trimesh.h"

namespace kgd {

// Area of the faces reinforced in both designs / area of those reinforced in either (1 when neither
// reinforces anything). Preconditions: a, b and face_area_m2 have one entry per face.
double DesignJaccard(const std::vector<uint8_t>& a, const std::vector<uint8_t>& b, const Eigen::VectorXd& face_area_m2);

// `design` (per face of `from`) carried to `to`, a mesh of the same surface at another resolution: each
// face of `to` takes the design of the face of `from` whose centroid is nearest its own (positions as
// given, e.g. both rest shapes on the body).
std::vector<uint8_t> TransferDesign(const TriMesh& from, const std::vector<uint8_t>& design, const TriMesh& to);

}  // namespace kgd
