// A set of points in 3D (metres) as a nanoflann k-d tree: nearest-point and radius queries over face
// centroids, body vertices and the like. Build once, query many times; the tree keeps a reference to
// the cloud, so the cloud must outlive it.
#pragma once

#include <nanoflann.hpp>

#include "core/mesh/trimesh.h"

namespace kgd {

// nanoflann's dataset adaptor over a Positions matrix (one point per row).
struct PointCloud {
  Positions points;
  size_t kdtree_get_point_count() const { return static_cast<size_t>(points.rows()); }
  double kdtree_get_pt(size_t i, size_t dim) const { return points(static_cast<Eigen::Index>(i), static_cast<Eigen::Index>(dim)); }
  template <class BBox>
  bool kdtree_get_bbox(BBox&) const { return false; }
};

// The k-d tree over a PointCloud (indices are rows): PointCloudTree tree(3, cloud, {16});
using PointCloudTree = nanoflann::KDTreeSingleIndexAdaptor<nanoflann::L2_Simple_Adaptor<double, PointCloud>, PointCloud, 3, int>;

}  // namespace kgd
