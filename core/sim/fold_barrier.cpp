#include "core/sim/fold_barrier.h"

#include <Eigen/Geometry>
#include <cmath>
#include <limits>

namespace kgd {

FoldBarrierValue FoldBarrierFunction(double q, double qh) {
  FoldBarrierValue v;
  if (q >= qh) return v;
  if (q <= 0) {
    v.b = std::numeric_limits<double>::infinity();
    return v;
  }
  const double d = q - qh, l = std::log(q / qh);
  v.b = -d * d * l;
  v.db = -2.0 * d * l - d * d / q;
  v.ddb = -2.0 * l - 4.0 * d / q + d * d / (q * q);
  return v;
}

double EvaluateFoldBarrier(const Eigen::Vector3d& x0, const Eigen::Vector3d& x1, const Eigen::Vector3d& x2,
                           const Eigen::Vector3d& n, double rest_area_m2, double scale_J, Vector9d* grad, Matrix9d* hess,
                           bool project_hessian) {
  const Eigen::Vector3d e1 = x1 - x0, e2 = x2 - x0;
  const double inv = 1.0 / (2.0 * rest_area_m2);
  const double q = e1.cross(e2).dot(n) * inv;
  const FoldBarrierValue b = FoldBarrierFunction(q);
  if (grad) grad->setZero();
  if (hess) hess->setZero();
  if (b.b == 0 || !std::isfinite(b.b)) return scale_J * b.b;
  // q = e1^T M e2 with M = -[n]x / (2 A): dq/dx1 = M e2 = (e2 x n) / 2A, dq/dx2 = M^T e1 = (n x e1) / 2A.
  Vector9d dq;
  dq.segment<3>(3) = e2.cross(n) * inv;
  dq.segment<3>(6) = n.cross(e1) * inv;
  dq.segment<3>(0) = -dq.segment<3>(3) - dq.segment<3>(6);
  if (grad) *grad = scale_J * b.db * dq;
  if (hess) {
    *hess = scale_J * b.ddb * dq * dq.transpose();
    if (!project_hessian) {
      Eigen::Matrix3d M;
      M << 0, n.z(), -n.y(), -n.z(), 0, n.x(), n.y(), -n.x(), 0;  // -[n]x
      M *= inv;
      // Blocks d2q/dxa dxb: (0,1) = M, (0,2) = -M, (1,2) = M and their transposes; diagonal blocks 0.
      Matrix9d d2q = Matrix9d::Zero();
      d2q.block<3, 3>(0, 3) = M;
      d2q.block<3, 3>(0, 6) = -M;
      d2q.block<3, 3>(3, 6) = M;
      d2q.block<3, 3>(3, 0) = M.transpose();
      d2q.block<3, 3>(6, 0) = -M.transpose();
      d2q.block<3, 3>(6, 3) = M.transpose();
      *hess += scale_J * b.db * d2q;
    }
  }
  return scale_J * b.b;
}

int CountFoldedFaces(const Positions& reference, const Positions& x, const Faces& faces) {
  int folded = 0;
  for (Eigen::Index f = 0; f < faces.rows(); ++f) {
    const Eigen::Vector3d r0 = reference.row(faces(f, 0)), r1 = reference.row(faces(f, 1)), r2 = reference.row(faces(f, 2));
    const Eigen::Vector3d x0 = x.row(faces(f, 0)), x1 = x.row(faces(f, 1)), x2 = x.row(faces(f, 2));
    if ((r1 - r0).cross(r2 - r0).dot((x1 - x0).cross(x2 - x0)) <= 0) ++folded;
  }
  return folded;
}

}  // namespace kgd
