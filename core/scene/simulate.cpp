#include "core/scene/simulate.h"

#include <Eigen/Geometry>
#include <cmath>

namespace kgd {

SimulationResult Summarize(GarmentSystem& sys, const Positions& x, const Positions& initial, const SolveReport& report) {
  SimulationResult r;
  r.solve = report;
  r.positions = x;
  const GarmentModel& m = sys.model();
  sys.FaceDensities(x, &r.face_density_Pa, nullptr);
  r.face_energy_J.resize(sys.num_faces());
  for (int f = 0; f < sys.num_faces(); ++f) {
    const double t = m.design[f] == kReinforced ? m.reinforced.thickness_m : m.cloth.thickness_m;
    const double a = sys.elements()[f].rest_area_m2;
    r.face_energy_J[f] = t * a * r.face_density_Pa[f];
    r.garment_area_m2 += a;
    if (m.design[f] == kReinforced) {
      r.reinforced_energy_J += r.face_energy_J[f];
      r.reinforced_area_m2 += a;
    }
    // Inversion: the deformed normal turned more than 90 degrees from the initial one.
    const Eigen::Vector3d n0 = (initial.row(m.faces(f, 1)) - initial.row(m.faces(f, 0)))
                                   .cross(initial.row(m.faces(f, 2)) - initial.row(m.faces(f, 0)));
    const Eigen::Vector3d n1 =
        (x.row(m.faces(f, 1)) - x.row(m.faces(f, 0))).cross(x.row(m.faces(f, 2)) - x.row(m.faces(f, 0)));
    if (n0.dot(n1) <= 0) ++r.inverted_faces;
  }
  r.reinforced_density_J_per_m2 = r.reinforced_area_m2 > 0 ? r.reinforced_energy_J / r.reinforced_area_m2 : 0.0;
  if (m.effects.clamps) {
    Eigen::VectorXd g;
    sys.Evaluate(x, &g, nullptr);
    for (size_t c = 0; c < m.clamps.size(); ++c) r.clamp_forces.push_back({m.clamps[c].name, sys.ClampReaction(c, g)});
  }
  if (m.effects.contact != ContactModel::kNone) {
    r.has_contact = true;
    const Eigen::VectorXd phi = sys.VertexPhi(x);
    r.min_phi_m = 1e300;
    r.max_phi_m = -1e300;
    for (Eigen::Index v = 0; v < phi.size(); ++v)
      if (std::isfinite(phi[v])) {
        r.min_phi_m = std::min(r.min_phi_m, phi[v]);
        r.max_phi_m = std::max(r.max_phi_m, phi[v]);
      }
  }
  return r;
}

Result<SimulationResult> SimulateScene(const SceneSpec& scene) {
  Result<GarmentModel> model = BuildGarmentModel(scene);
  if (!model.ok()) return model.status();
  GarmentSystem sys(std::move(model).value(), scene.initial);
  Simulator sim(&sys);
  Positions x = scene.initial;
  const SolveReport report = sim.Solve(&x, scene.solver);
  return Summarize(sys, x, scene.initial, report);
}

}  // namespace kgd
