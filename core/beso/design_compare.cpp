#include "core/beso/design_compare.h"

#include <memory>

#include "core/mesh/point_cloud.h"

namespace kgd {

double DesignJaccard(const std::vector<uint8_t>& a, const std::vector<uint8_t>& b, const Eigen::VectorXd& face_area_m2) {
  double both = 0, either = 0;
  for (size_t f = 0; f < a.size(); ++f) {
    const bool ra = a[f] != 0, rb = b[f] != 0;
    if (ra && rb) both += face_area_m2[f];
    if (ra || rb) either += face_area_m2[f];
  }
  return either > 0 ? both / either : 1.0;
}

std::vector<uint8_t> TransferDesign(const TriMesh& from, const std::vector<uint8_t>& design, const TriMesh& to) {
  PointCloud cloud{FaceCentroids(from.vertices, from.faces)};
  PointCloudTree tree(3, cloud, nanoflann::KDTreeSingleIndexAdaptorParams(16));
  tree.buildIndex();
  const Positions targets = FaceCentroids(to.vertices, to.faces);
  std::vector<uint8_t> out(to.faces.rows(), 0);
  for (Eigen::Index f = 0; f < targets.rows(); ++f) {
    const Eigen::Vector3d q = targets.row(f).transpose();
    int nearest = 0;
    double d2 = 0;
    tree.knnSearch(q.data(), 1, &nearest, &d2);
    out[f] = design[nearest];
  }
  return out;
}

}  // namespace kgd
