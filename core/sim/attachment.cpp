#include "core/sim/attachment.h"

namespace kgd {

double AttachmentFaceStiffness(const Attachments& a) {
  return a.faces.empty() ? 0.0 : a.stiffness_N_per_m / static_cast<double>(a.faces.size());
}

double EvaluateAttachmentFace(const Attachments& a, int i, const Eigen::Vector3d& x0, const Eigen::Vector3d& x1,
                              const Eigen::Vector3d& x2, Eigen::Matrix<double, 9, 1>* grad) {
  const double kf = AttachmentFaceStiffness(a);
  const Eigen::Vector3d d = (x0 + x1 + x2) / 3.0 - a.anchors.row(i).transpose();
  if (grad) {
    const Eigen::Vector3d g = (2.0 * kf / 3.0) * d;
    for (int v = 0; v < 3; ++v) grad->segment<3>(3 * v) = g;
  }
  return kf * d.squaredNorm();
}

}  // namespace kgd
