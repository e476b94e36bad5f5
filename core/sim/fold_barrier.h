// Fold barrier: keeps garment triangles from folding over. The paper's membrane has no bending and no
// self-contact, and its relaxed energy is flat in compression, so a compressed region of the garment
// can fold into pleats -- triangles turned over onto their neighbours -- at no cost. This term (an
// extension of the paper's model, on by default in scenes, "effects": {"fold_barrier": false} turns it
// off) measures each triangle's area projected on its orientation at the start of the solve,
//   q = ((x1 - x0) x (x2 - x0)) . n_ref / (2 A_rest),
// and adds the smooth log barrier of incremental potential contact on it:
//   E = mu t A_rest b(q),  b(q) = -(q - q^)^2 ln(q / q^) for 0 < q < q^, 0 for q >= q^, +inf for q <= 0,
// with q^ = 0.1: nothing changes until a triangle's projected area falls below a tenth of its rest area
// (a tenfold compression or a triangle turning past ~84 degrees), then folding costs more and more and
// turning over costs infinitely much. C2 in q; line searches reject steps that fold a triangle.
#pragma once

#include <Eigen/Core>

#include "core/mesh/trimesh.h"

namespace kgd {

inline constexpr double kFoldBarrierActivation = 0.1;  // q^
// |b'(q)| from which the projected Hessian is the exact one projected, not its Gauss-Newton part: q below
// 1.0e-4 (see EvaluateFoldBarrier). The design loops of the built-in arm and knee scenes reach |b'| 11.6
// at most.
inline constexpr double kFoldBarrierExactHessianSlope = 100.0;

using Vector9d = Eigen::Matrix<double, 9, 1>;
using Matrix9d = Eigen::Matrix<double, 9, 9>;

// b(q) and its first two derivatives.
struct FoldBarrierValue {
  double b = 0, db = 0, ddb = 0;
};
FoldBarrierValue FoldBarrierFunction(double q, double activation = kFoldBarrierActivation);

// Energy (J) of one triangle; `scale_J` = mu t A_rest. `reference_normal` is a unit normal,
// `rest_area_m2` > 0. With `hess`: exact when `project_hessian` is false, else positive semi-definite:
// the Gauss-Newton part scale b''(q) grad q grad q^T while |b'(q)| < kFoldBarrierExactHessianSlope (the
// dropped part, b' times the constant indefinite second derivative of q, is small beside the face's
// shear stiffness), and the exact Hessian with its negative eigenvalues clamped to zero from there on.
double EvaluateFoldBarrier(const Eigen::Vector3d& x0, const Eigen::Vector3d& x1, const Eigen::Vector3d& x2,
                           const Eigen::Vector3d& reference_normal, double rest_area_m2, double scale_J, Vector9d* grad,
                           Matrix9d* hess, bool project_hessian);

// Number of faces whose normal at `x` is turned by 90 degrees or more from their normal at `reference`
// (folded over, or collapsed).
int CountFoldedFaces(const Positions& reference, const Positions& x, const Faces& faces);

}  // namespace kgd
