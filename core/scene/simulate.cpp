#include "core/scene/simulate.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>

#include "core/sim/fold_barrier.h"

namespace kgd {

SimulationResult Summarize(GarmentSystem& sys, const Positions& x, const Positions& reference, const SolveReport& report) {
  SimulationResult r;
  r.solve = report;
  r.positions = x;
  const GarmentModel& m = sys.model();
  sys.FaceDensities(x, &r.face_density_Pa, nullptr);
  r.face_energy_J.resize(sys.num_faces());
  for (int f = 0; f < sys.num_faces(); ++f) {
    const double t = m.design[f] == kReinforced ? m.reinforced.thickness_m : m.cloth.thickness_m;
    const double a = sys.rest_areas_m2()[f];
    r.face_energy_J[f] = t * a * r.face_density_Pa[f];
    r.garment_area_m2 += a;
    if (m.design[f] == kReinforced) {
      r.reinforced_energy_J += r.face_energy_J[f];
      r.reinforced_area_m2 += a;
    }
  }
  r.inverted_faces = CountFoldedFaces(reference, x, m.faces);
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

SkinPressure SceneSkinPressure(const SceneSpec& scene, const GarmentModel& model, const Positions& x) {
  if (!scene.body || !model.body || model.effects.contact == ContactModel::kNone) return {};
  return ComputeSkinPressure(*scene.body, *model.body, x, model.faces, model.effects.contact, model.contact_stiffness_N_per_m);
}

Result<SimulationResult> SimulateScene(const SceneSpec& scene) {
  Result<GarmentModel> model = BuildGarmentModel(scene);
  if (!model.ok()) return model.status();
  GarmentSystem sys(std::move(model).value(), scene.initial);
  Simulator sim(&sys);
  Positions x = scene.initial;
  const SolveReport report = SolveLagged(sim, sys, &x, scene.solver);
  // Inversion is judged against the garment lying on the body where the scene has one.
  SimulationResult r = Summarize(sys, x, scene.on_body.rows() ? scene.on_body : scene.initial, report);
  r.skin = SceneSkinPressure(scene, sys.model(), x);
  return r;
}

Result<std::vector<SimulationResult>> SimulateFrames(const SceneSpec& scene,
                                                     const std::function<void(int, const SimulationResult&)>& on_frame) {
  if (!scene.motion || scene.motion->frames.empty())
    return Status::Error("scene '" + scene.name + "' has no motion frames (give body.frames with garment.region)");
  const int n = static_cast<int>(scene.motion->frames.size());
  std::vector<SimulationResult> out;
  Positions previous_on_body;
  for (int k = 0; k < n; ++k) {
    Result<SceneSpec> frame = SceneAtFrame(scene, k);
    if (!frame.ok()) return frame.status();
    const Positions& on_body = frame->on_body;
    if (k > 0) {
      // The previous equilibrium moved with the body.
      Positions start = out.back().positions + (on_body - previous_on_body);
      // Where the garment slid or lifted off, the body's displacement can fold a compressed triangle
      // over; then this frame starts on the body instead.
      if (scene.effects.fold_barrier && CountFoldedFaces(on_body, start, scene.garment.faces) > 0) start = on_body;
      // With friction every frame is the garment put on in that pose and released (the definition the
      // design loop uses for the deformed pose): a warm start would drag the friction's history along.
      if (scene.effects.friction > 0) start = on_body;
      frame->initial = std::move(start);
    }
    previous_on_body = on_body;
    Result<SimulationResult> r = SimulateScene(*frame);
    if (!r.ok()) return r.status().WithContext("frame " + std::to_string(k + 1) + ": ");
    if (on_frame) on_frame(k, *r);
    out.push_back(std::move(r).value());
  }
  return out;
}

Result<std::vector<BodyEvaluation>> EvaluateOnBodies(const SceneSpec& scene, const std::vector<uint8_t>& design) {
  if (static_cast<Eigen::Index>(design.size()) != scene.garment.faces.rows())
    return Status::Error("the design has " + std::to_string(design.size()) + " faces, the garment of scene '" + scene.name + "' " +
                         std::to_string(scene.garment.faces.rows()));
  KGD_RETURN_IF_ERROR(ValidateSceneBodies(scene));
  std::vector<BodyEvaluation> out;
  const int bodies = std::max<int>(1, static_cast<int>(scene.bodies.size()));
  for (int b = 0; b < bodies; ++b) {
    Result<SceneSpec> on = SceneOnBody(scene, b);
    if (!on.ok()) return on.status();
    BodyEvaluation e;
    e.name = scene.bodies.empty() ? scene.name : scene.bodies[b].name;
    for (auto [d, result] : {std::pair{&design, &e.designed}, std::pair<const std::vector<uint8_t>*, SimulationResult*>{nullptr, &e.full}}) {
      on->design = d ? *d : std::vector<uint8_t>(design.size(), kReinforced);
      Result<SimulationResult> r = SimulateScene(*on);
      if (!r.ok()) return r.status().WithContext("body '" + e.name + "': ");
      if (!r->solve.at_equilibrium())
        return Status::Error("body '" + e.name + "': the simulation did not converge (" + ToString(r->solve.status) + ")");
      *result = std::move(r).value();
    }
    e.density_ratio = e.full.reinforced_density_J_per_m2 > 0 ? e.designed.reinforced_density_J_per_m2 / e.full.reinforced_density_J_per_m2 : 0.0;
    out.push_back(std::move(e));
  }
  return out;
}

}  // namespace kgd
