// Polygonization of an implicit surface by surface nets: one vertex per grid cell the surface crosses
// (at the mean of the cell's edge crossings), one quad (two triangles) per crossed grid edge. On a
// smooth field whose features are several cells wide the result is a closed, consistently oriented
// 2-manifold with near-uniform edges, which is what a body mesh for simulation wants.
#pragma once

#include <Eigen/Core>
#include <functional>

#include "core/mesh/trimesh.h"

namespace kgd {

// `field` is negative inside, positive outside (m). The surface must lie strictly inside the box
// [lo, hi]; `spacing_m` is the grid cell size. Faces are counter-clockwise seen from outside.
TriMesh SurfaceNets(const std::function<double(const Eigen::Vector3d&)>& field, const Eigen::Vector3d& lo,
                    const Eigen::Vector3d& hi, double spacing_m);

}  // namespace kgd
