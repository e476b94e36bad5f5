// Garment-body contact: a penalty on the body field Phi at each garment vertex (paper eq. BodyEnergy).
//   unilateral (default): E_i = k min(Phi(x_i), 0)^2   -- keeps cloth out, allows lift-off
//   bilateral:            E_i = k Phi(x_i)^2           -- glues cloth to the surface (for comparison)
// k in N/m (J/m^2). Default 5000 N/m: the authors' weight 0.005 in MPa-based code units (MJ/m^2) in SI.
// A vertex outside the field's support (farther than ~h from the body) carries no energy.
#pragma once

#include <Eigen/Core>
#include <vector>

#include "core/body/body_field.h"
#include "core/sim/energy_terms.h"
#include "core/sim/garment_model.h"

namespace kgd {

struct ContactEvaluation {
  double energy_J = 0;
  double phi_m = 0;
  Eigen::Vector3d phi_grad = Eigen::Vector3d::Zero();  // grad Phi where supported, when a gradient was asked for
  bool supported = false;
};

// Energy of one vertex and, on request, gradient (N) and Hessian (N/m); with `project_hessian` the
// Hessian is projected to positive semi-definite.
ContactEvaluation EvaluateContactVertex(const BodyField& field, const Eigen::Vector3d& x, NeighborCache* cache,
                                        ContactModel model, double stiffness_N_per_m, Eigen::Vector3d* grad,
                                        Eigen::Matrix3d* hess, bool project_hessian);

// Contact as an energy term of the garment system (energy_term.h), per vertex. It also keeps, per
// vertex, Phi (NaN where unsupported) and grad Phi of its latest evaluation, which evaluation records
// keep (RecordElement: Phi, then grad Phi) for the line search's projection (ProjectTrial).
//
// ProjectTrial, unilateral contact only (otherwise it moves nothing): corrects a line-search trial of a
// step from x_from where the Newton model's linear view of the skin fails, moving fully free vertices
// along the field gradient (a few Newton iterations on Phi):
//  - a vertex off the body at the start (Phi >= 0) has no contact stiffness in the Hessian, so the
//    step may carry it deep into the body and the penalty then cuts the whole step to a sliver (a wasted
//    factorization): if it ends inside, it goes back to just inside the surface
//    (Phi = -kContactProjectionDepth_m), where the next Hessian sees its contact stiffness;
//  - a vertex in contact (Phi < 0) that slides along the curved skin ends micrometres deeper (concave
//    skin) or shallower (convex) than the linear model's Phi + grad Phi . step: it goes to that depth,
//    from either side (if the model predicts lift-off, it is treated as a crossing). Without this, cloth
//    sliding on a limb spends most Newton iterations of a BESO re-solve undoing micrometre penetrations
//    and lift-offs.
inline constexpr double kContactProjectionDepth_m = 1e-10;

class ContactTerm final : public EnergyTerm {
 public:
  explicit ContactTerm(const TermContext& context);
  Stencil stencil() const override { return Stencil::kVertex; }
  ElementEnergy Evaluate(int v, const int* stencil, const Positions& x, double* g, double* H) override;
  int RecordWidth() const override { return 4; }
  void RecordElement(int v, double* out) const override;
  int ProjectTrial(const std::vector<double>& recorded, const Positions& x_from, const std::vector<int>& free_index,
                   Positions* trial) override;

 private:
  const GarmentModel& model_;
  std::vector<NeighborCache>& caches_;
  std::vector<double> phi_;
  std::vector<Eigen::Vector3d> phi_grad_;
};

}  // namespace kgd
