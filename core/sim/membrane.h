// Membrane energy of the garment: compressible neo-Hookean on constant-strain triangles, with the
// tension-field relaxation that lets cloth wrinkle instead of resisting compression.
//
// Vocabulary (paper, "Garment and Reinforcements"): each triangle has a rest shape in its own 2D frame,
// F = Ds Dm^-1 (3 x 2), C = F^T F (2 x 2) with eigenvalues s1^2 <= s2^2 (s_i: principal stretches),
//   W(s1, s2) = mu/2 (s1^2 + s2^2 - 2) - mu ln J + lambda/2 (ln J)^2,   J = s1 s2      [Pa = J/m^3]
// and the element energy is thickness * rest area * W [J].
//
// Relaxation of compression:
//  - kExact (default): the tension-field energy. Where the smaller stretch is below r(s2), the lateral
//    stretch of free uniaxial contraction (dW/ds1 (r, s2) = 0), it is replaced by r(s2); where s2 <= 1
//    the triangle is slack and carries no energy. The result is continuously differentiable.
//  - kAuthors: the authors' code: s2 < 1 slack; s1 < s2^-1/2 replaced by s2^-1/2 (incompressible
//    contraction). Continuous but with a gradient jump on s1 = s2^-1/2.
//  - kNone: plain neo-Hookean; resists compression; infinite energy as J -> 0.
//
// Derivatives use the analytic eigensystem of d2W/dF2 for isotropic energies of a 3 x 2 deformation
// gradient: a 2 x 2 block of stretch modes, one twist and one flip mode in the plane, and two
// out-of-plane modes. Projecting to positive semi-definite is clamping those six eigenvalues.
#pragma once

#include <Eigen/Core>

#include "core/sim/garment_model.h"

namespace kgd {

enum class MembraneRegime { kTaut, kWrinkled, kSlack };

struct Lame {
  double lambda_Pa = 0;
  double mu_Pa = 0;
};

// Preconditions: E > 0, -1 < nu < 0.5.
Lame LameParameters(const Material& material, LameConversion conversion);

// W and its derivatives with respect to the principal stretches (Pa); precondition 0 <= s1 <= s2.
struct StretchEnergy {
  double W = 0, W1 = 0, W2 = 0, W11 = 0, W12 = 0, W22 = 0;
  MembraneRegime regime = MembraneRegime::kTaut;
};
StretchEnergy EnergyOfStretches(double s1, double s2, const Lame& lame, Relaxation relaxation);

// r(s2): the lateral stretch of free uniaxial contraction, the root of dW/ds1 (r, s2) = 0. Precondition s2 > 0.
double FreeContractionStretch(double s2, const Lame& lame);

// Rest data of one triangle: inverse of the rest edge matrix in the triangle's own 2D frame, rest area.
struct MembraneElement {
  Eigen::Matrix2d dm_inv = Eigen::Matrix2d::Identity();
  double rest_area_m2 = 0;
};
// Precondition: non-degenerate rest triangle (see ValidateMesh).
MembraneElement MakeMembraneElement(const Eigen::Vector3d& x0, const Eigen::Vector3d& x1, const Eigen::Vector3d& x2);

// Deformation gradient (3 x 2) of a triangle.
Eigen::Matrix<double, 3, 2> DeformationGradient(const MembraneElement& element, const Eigen::Vector3d& x0,
                                                const Eigen::Vector3d& x1, const Eigen::Vector3d& x2);

using Vector9d = Eigen::Matrix<double, 9, 1>;
using Matrix9d = Eigen::Matrix<double, 9, 9>;

struct ElementEvaluation {
  double energy_J = 0;       // thickness * area * W; +infinity where the energy is undefined (kNone with J <= 0)
  double density_Pa = 0;     // W
  MembraneRegime regime = MembraneRegime::kTaut;
};

// Energy of one triangle and, when `grad` / `hess` are given, its gradient (N) and Hessian (N/m) with
// respect to the nine vertex coordinates (x0, x1, x2). With `project_hessian` the Hessian is the
// positive semi-definite projection (negative eigenvalues of d2W/dF2 clamped to zero).
ElementEvaluation EvaluateMembraneElement(const MembraneElement& element, const Eigen::Vector3d& x0,
                                          const Eigen::Vector3d& x1, const Eigen::Vector3d& x2, const Lame& lame,
                                          double thickness_m, Relaxation relaxation, Vector9d* grad, Matrix9d* hess,
                                          bool project_hessian);

}  // namespace kgd
