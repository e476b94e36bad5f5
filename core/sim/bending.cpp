#include "core/sim/bending.h"

#include <Eigen/Geometry>
#include <unsupported/Eigen/AutoDiff>

#include <algorithm>
#include <cmath>
#include <limits>

#include "core/sim/energy_terms.h"
#include "core/sim/garment_model.h"

namespace kgd {
namespace {

template <typename T>
using V3 = Eigen::Matrix<T, 3, 1>;

// The gradient of the hinge angle with respect to a, b, c, d (Bridson, Marino & Fedkiw 2003): with
// e = b - a, N1 = e x (c - a) and N2 = (d - a) x e the normals of the two triangles,
//   dtheta/dc = -|e| N1 / |N1|^2,  dtheta/dd = -|e| N2 / |N2|^2,
//   dtheta/da = -((c - b).e / |e|) N1 / |N1|^2 - ((d - b).e / |e|) N2 / |N2|^2,
//   dtheta/db =  ((c - a).e / |e|) N1 / |N1|^2 + ((d - a).e / |e|) N2 / |N2|^2,
// the four summing to zero. Templated so that forward-mode differentiation of it gives the Hessian.
template <typename T>
Eigen::Matrix<T, 12, 1> AngleGradient(const V3<T>& a, const V3<T>& b, const V3<T>& c, const V3<T>& d) {
  using std::sqrt;
  const V3<T> e = b - a;
  const V3<T> n1 = e.cross(c - a), n2 = (d - a).cross(e);
  const T len = sqrt(e.squaredNorm());
  const T w1 = T(1) / n1.squaredNorm(), w2 = T(1) / n2.squaredNorm();
  const V3<T> gc = -len * w1 * n1, gd = -len * w2 * n2;
  const V3<T> ga = -((c - b).dot(e) / len) * w1 * n1 - ((d - b).dot(e) / len) * w2 * n2;
  const V3<T> gb = ((c - a).dot(e) / len) * w1 * n1 + ((d - a).dot(e) / len) * w2 * n2;
  Eigen::Matrix<T, 12, 1> g;
  g << ga, gb, gc, gd;
  return g;
}

}  // namespace

double BendingStiffness(const Material& m) {
  return m.youngs_modulus_Pa * m.thickness_m * m.thickness_m * m.thickness_m / (12.0 * (1.0 - m.poisson_ratio * m.poisson_ratio));
}

double HingeAngle(const Eigen::Vector3d& a, const Eigen::Vector3d& b, const Eigen::Vector3d& c, const Eigen::Vector3d& d) {
  const Eigen::Vector3d e = b - a;
  const Eigen::Vector3d n1 = e.cross(c - a), n2 = (d - a).cross(e);
  return std::atan2(n1.cross(n2).dot(e) / e.norm(), n1.dot(n2));
}

double EvaluateHingeBending(const Vector12d& x, double rest_angle, double k, Vector12d* grad, Matrix12d* hess, bool project) {
  const Eigen::Vector3d a = x.segment<3>(0), b = x.segment<3>(3), c = x.segment<3>(6), d = x.segment<3>(9);
  const Eigen::Vector3d e = b - a;
  if (!(e.cross(c - a).squaredNorm() > 0) || !(e.cross(d - a).squaredNorm() > 0)) return std::numeric_limits<double>::infinity();
  const double theta = HingeAngle(a, b, c, d), dt = theta - rest_angle;
  if (!grad && !hess) return k * dt * dt;
  const Vector12d g = AngleGradient<double>(a, b, c, d);
  if (grad) *grad = 2.0 * k * dt * g;
  if (hess) {
    *hess = 2.0 * k * g * g.transpose();
    if (!project) {
      // Hess theta: forward-mode differentiation of the analytic gradient.
      using AD = Eigen::AutoDiffScalar<Vector12d>;
      V3<AD> p[4];
      for (int v = 0; v < 4; ++v)
        for (int i = 0; i < 3; ++i) p[v][i] = AD(x[3 * v + i], 12, 3 * v + i);
      const Eigen::Matrix<AD, 12, 1> ga = AngleGradient<AD>(p[0], p[1], p[2], p[3]);
      for (int r = 0; r < 12; ++r) hess->row(r) += 2.0 * k * dt * ga[r].derivatives().transpose();
    }
  }
  return k * dt * dt;
}

// ---------------------------------------------------------------------------------------------------
// Bending as an energy term of the garment system (energy_term.h): per hinge, with its rest angle and
// weight from the garment's rest shape and the stiffness of its faces' materials.

namespace {

class BendingHingeTerm final : public EnergyTerm {
 public:
  explicit BendingHingeTerm(const TermContext& context) : model_(context.model), hinges_(context.hinges) {
    const Hinges& h = context.hinges;
    const Positions& rest = context.model.rest;
    rest_angle_.resize(h.vertices.size());
    weight_.resize(h.vertices.size());
    for (size_t i = 0; i < h.vertices.size(); ++i) {
      const auto& v = h.vertices[i];
      rest_angle_[i] = HingeAngle(rest.row(v[0]), rest.row(v[1]), rest.row(v[2]), rest.row(v[3]));
      const double area = RestArea(rest, context.model.faces, h.faces[i][0]) + RestArea(rest, context.model.faces, h.faces[i][1]);
      weight_[i] = 0.5 * 3.0 * (rest.row(v[1]) - rest.row(v[0])).squaredNorm() / area;
    }
    stiffness_[0] = BendingStiffness(context.model.cloth);
    stiffness_[1] = BendingStiffness(context.model.reinforced);
  }
  Stencil stencil() const override { return Stencil::kHinge; }
  ElementEnergy Evaluate(int e, const int* v, const Positions& x, double* g, double* H) override {
    Vector12d q;
    for (int a = 0; a < 4; ++a) q.segment<3>(3 * a) = x.row(v[a]).transpose();
    const auto& faces = hinges_.faces[e];
    const double D = 0.5 * (stiffness_[model_.design[faces[0]]] + stiffness_[model_.design[faces[1]]]);
    Vector12d gb;
    Matrix12d Hb;
    const double energy = EvaluateHingeBending(q, rest_angle_[e], D * weight_[e], g ? &gb : nullptr, H ? &Hb : nullptr, true);
    if (!std::isfinite(energy)) return {energy, false};
    if (g) std::copy_n(gb.data(), gb.size(), g);
    if (H) std::copy_n(Hb.data(), Hb.size(), H);
    return {energy, true};
  }
  std::string NonFiniteMeaning() const override { return ": a triangle of the hinge collapsed"; }

 private:
  // The membrane's rest area of face f (MakeMembraneElement).
  static double RestArea(const Positions& rest, const Faces& faces, int f) {
    return MakeMembraneElement(rest.row(faces(f, 0)), rest.row(faces(f, 1)), rest.row(faces(f, 2))).rest_area_m2;
  }
  const GarmentModel& model_;
  const Hinges& hinges_;
  std::vector<double> rest_angle_, weight_;
  double stiffness_[2];
};

}  // namespace

std::unique_ptr<EnergyTerm> MakeBendingTerm(const TermContext& context) {
  return context.model.effects.bending ? std::make_unique<BendingHingeTerm>(context) : nullptr;
}

}  // namespace kgd
