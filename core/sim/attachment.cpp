#include "core/sim/attachment.h"

#include <algorithm>

#include "core/sim/energy_terms.h"

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

// ---------------------------------------------------------------------------------------------------
// Attachments as an energy term of the garment system (energy_term.h): on the attached faces only.

namespace {

using Vector9d = Eigen::Matrix<double, 9, 1>;
using Matrix9d = Eigen::Matrix<double, 9, 9>;

class AttachmentFaceTerm final : public EnergyTerm {
 public:
  explicit AttachmentFaceTerm(const TermContext& context) : model_(context.model), index_(context.model.faces.rows(), -1) {
    const Attachments& a = context.model.attachments;
    for (size_t i = 0; i < a.faces.size(); ++i) index_[a.faces[i]] = static_cast<int>(i);
  }
  Stencil stencil() const override { return Stencil::kFace; }
  ElementEnergy Evaluate(int f, const int* v, const Positions& x, double* g, double* H) override {
    if (index_[f] < 0) return {0.0, false};
    const Attachments& a = model_.attachments;
    const Eigen::Vector3d x0 = x.row(v[0]), x1 = x.row(v[1]), x2 = x.row(v[2]);
    Vector9d ga;
    const double e = EvaluateAttachmentFace(a, index_[f], x0, x1, x2, g ? &ga : nullptr);
    if (g) std::copy_n(ga.data(), ga.size(), g);
    if (H) {
      // (2 k_f / 9) on the diagonal of every 3x3 block: constant and PSD.
      Eigen::Map<Matrix9d> h(H);
      h.setZero();
      const double c = 2.0 * AttachmentFaceStiffness(a) / 9.0;
      for (int r = 0; r < 3; ++r)
        for (int s = 0; s < 3; ++s) h.block<3, 3>(3 * r, 3 * s).diagonal().array() += c;
    }
    return {e, true};
  }

 private:
  const GarmentModel& model_;
  std::vector<int> index_;  // per face: its index in attachments.faces, or -1
};

}  // namespace

std::unique_ptr<EnergyTerm> MakeAttachmentTerm(const TermContext& context) {
  const bool on = context.model.effects.attachments && !context.model.attachments.faces.empty();
  return on ? std::make_unique<AttachmentFaceTerm>(context) : nullptr;
}
}  // namespace kgd
