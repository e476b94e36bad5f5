#include "core/sim/fold_barrier.h"

#include <algorithm>
#include <Eigen/Eigenvalues>
#include <Eigen/Geometry>
#include <cmath>
#include <limits>
#include "core/sim/energy_terms.h"
#include "core/sim/garment_model.h"
#include "core/sim/membrane.h"

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
    // The Gauss-Newton part drops b' times q's second derivative, a stiffness of order mu t |b'(q)|
    // along the turns and shears of the triangle that leave q unchanged to first order. Where |b'| >=
    // kFoldBarrierExactHessianSlope the barrier pushes with tens of times the force that shears the face
    // by 100 %, more than any equilibrium of a garment asks of it: Newton's steps, linear in x, have
    // carried the triangle there by turning or collapsing it, which changes q quadratically and the
    // Gauss-Newton model cannot see. Left so, every later step does the same, ends at the fold-safe
    // length, and q falls towards 0 with the residual growing as 1 / q (the knee at 160 degrees: q 1e-10,
    // residual 1e9 N after 1,000 iterations). There the exact Hessian, projected to positive
    // semi-definite, holds those turns back.
    const bool exact_projected = project_hessian && std::abs(b.db) >= kFoldBarrierExactHessianSlope;
    if (!project_hessian || exact_projected) {
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
    if (exact_projected) {
      Eigen::SelfAdjointEigenSolver<Matrix9d> eig(*hess);
      *hess = eig.eigenvectors() * eig.eigenvalues().cwiseMax(0.0).asDiagonal() * eig.eigenvectors().transpose();
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

// ---------------------------------------------------------------------------------------------------
// The fold barrier as an energy term of the garment system (energy_term.h): per face, scaled by the
// shear modulus and thickness of the face's material and its rest area.

namespace {

class FoldBarrierFaceTerm final : public EnergyTerm {
 public:
  // Folds are measured against the garment on the body (model.fold_reference), or the orientation it
  // starts with.
  explicit FoldBarrierFaceTerm(const TermContext& context) : model_(context.model) {
    const GarmentModel& m = context.model;
    const Positions& ref = m.fold_reference.rows() ? m.fold_reference : context.initial;
    const int nf = static_cast<int>(m.faces.rows());
    reference_.resize(nf);
    area_.resize(nf);
    for (int f = 0; f < nf; ++f) {
      const Eigen::Vector3d a = ref.row(m.faces(f, 0)), b = ref.row(m.faces(f, 1)), c = ref.row(m.faces(f, 2));
      reference_[f] = (b - a).cross(c - a).normalized();
      area_[f] = MakeMembraneElement(m.rest.row(m.faces(f, 0)), m.rest.row(m.faces(f, 1)), m.rest.row(m.faces(f, 2))).rest_area_m2;
    }
    const Material mats[2] = {m.cloth, m.reinforced};
    for (int k = 0; k < 2; ++k) mu_t_[k] = LameParameters(mats[k], m.lame).mu_Pa * mats[k].thickness_m;
  }
  Stencil stencil() const override { return Stencil::kFace; }
  ElementEnergy Evaluate(int f, const int* v, const Positions& x, double* g, double* H) override {
    const Eigen::Vector3d x0 = x.row(v[0]), x1 = x.row(v[1]), x2 = x.row(v[2]);
    const int m = model_.design[f];
    const double area = area_[f];
    Vector9d gb;
    Matrix9d Hb;
    const double eb = EvaluateFoldBarrier(x0, x1, x2, reference_[f], area, mu_t_[m] * area, g ? &gb : nullptr, H ? &Hb : nullptr, true);
    // Inactive faces (eb = 0) add nothing, not even zeros.
    if (!std::isfinite(eb) || !(eb > 0)) return {eb, false};
    if (g) std::copy_n(gb.data(), gb.size(), g);
    if (H) std::copy_n(Hb.data(), Hb.size(), H);
    return {eb, true};
  }
  std::string NonFiniteMeaning() const override { return ": folded over"; }
  // The largest step that goes at most 80 % of the way to folding any triangle over (its projected
  // area reaching zero), as interior-point methods step towards a barrier.
  double MaxSafeStep(const Positions& x, const Positions& d) const override {
    double step = 1.0;
    const int nf = static_cast<int>(model_.faces.rows());
#pragma omp parallel for schedule(static) reduction(min : step)
    for (int f = 0; f < nf; ++f) {
      const int a = model_.faces(f, 0), b = model_.faces(f, 1), c = model_.faces(f, 2);
      const Eigen::Vector3d e1 = x.row(b) - x.row(a), e2 = x.row(c) - x.row(a);
      const Eigen::Vector3d d1 = d.row(b) - d.row(a), d2 = d.row(c) - d.row(a);
      const Eigen::Vector3d& n = reference_[f];
      // Projected area along the step: q(t) = q0 + q1 t + q2 t^2 (unnormalized); first root in (0, 1].
      const double q0 = e1.cross(e2).dot(n), q1 = (d1.cross(e2) + e1.cross(d2)).dot(n), q2 = d1.cross(d2).dot(n);
      if (q0 <= 0) continue;
      double root = 2.0;
      if (std::abs(q2) < 1e-300) {
        if (q1 < 0) root = -q0 / q1;
      } else {
        const double disc = q1 * q1 - 4 * q2 * q0;
        if (disc >= 0) {
          const double sq = std::sqrt(disc);
          // Numerically stable roots of q2 t^2 + q1 t + q0.
          const double t1 = (-q1 - std::copysign(sq, q1)) / (2 * q2);
          const double t2 = t1 != 0 ? q0 / (q2 * t1) : 2.0;
          for (double t : {t1, t2})
            if (t > 0 && t < root) root = t;
        }
      }
      if (root <= 1.0) step = std::min(step, 0.8 * root);
    }
    return step;
  }

 private:
  const GarmentModel& model_;
  std::vector<Eigen::Vector3d> reference_;  // per face: unit normal folds are measured against
  std::vector<double> area_;                // per face: rest area (m^2)
  double mu_t_[2];                          // per material: shear modulus times thickness (N/m)
};

}  // namespace

std::unique_ptr<EnergyTerm> MakeFoldBarrierTerm(const TermContext& context) {
  return context.model.effects.fold_barrier ? std::make_unique<FoldBarrierFaceTerm>(context) : nullptr;
}
}  // namespace kgd
