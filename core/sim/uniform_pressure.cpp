#include "core/sim/uniform_pressure.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <vector>

namespace kgd {

double EvaluateUniformPressureFace(const Eigen::Vector3d& an, double p, const Eigen::Vector3d& x0, const Eigen::Vector3d& x1,
                            const Eigen::Vector3d& x2, Eigen::Matrix<double, 9, 1>* grad) {
  const Eigen::Vector3d f = (p / 3.0) * an;  // each vertex's share of the load (N)
  if (grad)
    for (int v = 0; v < 3; ++v) grad->segment<3>(3 * v) = -f;
  return -f.dot(x0 + x1 + x2);
}

// ---------------------------------------------------------------------------------------------------
// The pressure as an energy term of the garment system (energy_term.h): per face.

namespace {

class UniformPressureFaceTerm final : public EnergyTerm {
 public:
  explicit UniformPressureFaceTerm(const TermContext& context) : pressure_Pa_(context.model.effects.uniform_pressure_Pa) {
    const GarmentModel& m = context.model;
    area_normal_.resize(m.faces.rows());
    for (Eigen::Index f = 0; f < m.faces.rows(); ++f) {
      const Eigen::Vector3d x0 = m.rest.row(m.faces(f, 0)), x1 = m.rest.row(m.faces(f, 1)), x2 = m.rest.row(m.faces(f, 2));
      area_normal_[f] = 0.5 * (x1 - x0).cross(x2 - x0);
    }
  }
  Stencil stencil() const override { return Stencil::kFace; }
  ElementEnergy Evaluate(int f, const int* v, const Positions& x, double* g, double* H) override {
    Eigen::Matrix<double, 9, 1> gp;
    const double e = EvaluateUniformPressureFace(area_normal_[f], pressure_Pa_, x.row(v[0]), x.row(v[1]), x.row(v[2]), g ? &gp : nullptr);
    if (g) std::copy_n(gp.data(), gp.size(), g);
    if (H) std::fill_n(H, 81, 0.0);  // linear in x
    return {e, true};
  }

 private:
  double pressure_Pa_;
  std::vector<Eigen::Vector3d> area_normal_;  // per face: A_f n_f at rest (m^2)
};

}  // namespace

std::unique_ptr<EnergyTerm> MakeUniformPressureTerm(const TermContext& context) {
  return context.model.effects.uniform_pressure_Pa != 0 ? std::make_unique<UniformPressureFaceTerm>(context) : nullptr;
}

}  // namespace kgd
