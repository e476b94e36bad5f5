// Attachments: zero-length springs from the centroid of each attached triangle to an anchor, the same
// point on the body in the current pose (anchors move with the body, as in the authors' code):
//   E = (k / n) sum_f |c_f(x) - a_f|^2,   c_f = (x0 + x1 + x2) / 3,   n = number of attached triangles.
// k in N/m. Default 3000 N/m: the authors' weight 0.003 (MJ/m^2, a mean over attached faces) in SI.
// The per-face stiffness k / n is deliberately weak: designs must not rely on pulling the boundary.
#pragma once

#include <Eigen/Core>
#include <vector>

#include "core/mesh/trimesh.h"
#include "core/sim/garment_model.h"

namespace kgd {

// Energy of attached face i (index into attachments.faces) and its 9-gradient; the Hessian is
// (2 k_f / 9) [1 1 1; 1 1 1; 1 1 1] (x) I3, constant and PSD, k_f = k / n.
double EvaluateAttachmentFace(const Attachments& attachments, int i, const Eigen::Vector3d& x0,
                              const Eigen::Vector3d& x1, const Eigen::Vector3d& x2,
                              Eigen::Matrix<double, 9, 1>* grad);
double AttachmentFaceStiffness(const Attachments& attachments);  // k_f = k / n (N/m)

}  // namespace kgd
