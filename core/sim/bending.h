// Discrete-shell bending (Grinspun, Hirani, Desbrun & Schroeder 2003): an opt-in extension of the
// paper's model, whose membrane has none. Per interior edge (hinge) with vertices a, b (the edge) and
// c, d (the opposite vertices of its two triangles):
//   E = k (theta - theta_rest)^2,   k = (D / 2) * 3 |e_rest|^2 / (A1 + A2),   D = E t^3 / (12 (1 - nu^2)),
// theta the signed dihedral angle between the triangles' normals about the edge, A1, A2 the rest areas
// of the two triangles, D (N m) the bending stiffness of the material (the mean over the two faces'
// materials when they differ). The sum scales as (D / 2) times the integral of (kappa1 + kappa2 - rest)^2
// over the surface, with a factor that depends on the mesh, as hinge energies do: a right-triangle grid
// rolled onto a cylinder of radius R stores 2.9 (D / 2) A / R^2.
// The rest angles are those of the garment's rest shape (a garment cut from the body is curved at rest).
//
// Units: positions m, energies J, gradients N, Hessians N/m. The exact Hessian is 2 k (g g^T +
// (theta - theta_rest) Hess theta); the solver gets its positive semi-definite Gauss-Newton part
// 2 k g g^T, as for the fold barrier.
#pragma once

#include <Eigen/Core>

#include "core/sim/membrane.h"

namespace kgd {

using Vector12d = Eigen::Matrix<double, 12, 1>;
using Matrix12d = Eigen::Matrix<double, 12, 12>;

// D = E t^3 / (12 (1 - nu^2)) (N m).
double BendingStiffness(const Material& material);

// The signed dihedral angle (rad) of the hinge (a, b, c, d): 0 when flat, in (-pi, pi].
double HingeAngle(const Eigen::Vector3d& a, const Eigen::Vector3d& b, const Eigen::Vector3d& c, const Eigen::Vector3d& d);

// Energy k (theta - rest_angle)^2 of one hinge (x: a, b, c, d stacked) and, on request, its gradient
// and Hessian (exact, or with `project` the PSD Gauss-Newton part). Degenerate triangles (zero area)
// give an infinite energy.
double EvaluateHingeBending(const Vector12d& x, double rest_angle_rad, double k_J, Vector12d* grad, Matrix12d* hess, bool project);

}  // namespace kgd
