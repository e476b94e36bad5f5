#include "core/beso/pressure_limit.h"

#include <algorithm>
#include <cstdio>

#include "core/beso/beso.h"
#include "core/mesh/topology.h"
#include "core/scene/simulate.h"

namespace kgd {

PosePressure PressureInPose(const TriMesh& body, const GarmentModel& model, const Positions& x) {
  PosePressure out;
  if (!model.body || model.effects.contact == ContactModel::kNone) return out;
  const Eigen::VectorXd f = ContactNormalForces(*model.body, x, model.effects.contact, model.contact_stiffness_N_per_m);
  out.garment_Pa = GarmentPressure(x, model.faces, f);
  out.skin = PressureOnBody(body, x, model.faces, out.garment_Pa);
  out.skin.normal_force_N = f.sum();
  return out;
}

std::vector<int> FacesToKeepOut(const Faces& faces, int nv, const std::vector<Eigen::VectorXd>& garment_Pa, double limit_Pa,
                                const std::vector<uint8_t>& design, const std::vector<uint8_t>& may_keep_out) {
  const VertexFaceIncidence around = VertexFaces(faces, nv);
  std::vector<uint8_t> in_ring(nv, 0);
  for (const Eigen::VectorXd& q : garment_Pa)
    for (Eigen::Index v = 0; v < q.size() && v < nv; ++v) in_ring[v] |= q[v] > limit_Pa;
  if (std::find(in_ring.begin(), in_ring.end(), 1) == in_ring.end()) return {};
  std::vector<uint8_t> chosen(faces.rows(), 0);
  bool first = true;
  while (true) {
    bool reinforced = false;
    std::vector<uint8_t> ring_faces(faces.rows(), 0);
    for (int v = 0; v < nv; ++v)
      if (in_ring[v])
        for (int k = around.begin[v]; k < around.begin[v + 1]; ++k) ring_faces[around.face[k]] = 1;
    for (Eigen::Index f = 0; f < faces.rows(); ++f) {
      if (!ring_faces[f] || !may_keep_out[f]) continue;
      if (design[f] == kReinforced) reinforced = true;
      // The first ring: every face that may go; a grown ring: its reinforced faces only.
      if (first || design[f] == kReinforced) chosen[f] = 1;
    }
    if (reinforced) break;
    // Grow: every vertex of the ring's faces.
    bool grew = false;
    for (Eigen::Index f = 0; f < faces.rows(); ++f)
      if (ring_faces[f])
        for (int c = 0; c < 3; ++c)
          if (!in_ring[faces(f, c)]) in_ring[faces(f, c)] = 1, grew = true;
    if (!grew) break;
    first = false;
  }
  std::vector<int> out;
  for (Eigen::Index f = 0; f < faces.rows(); ++f)
    if (chosen[f]) out.push_back(static_cast<int>(f));
  return out;
}

Status CheckClothUnderPressureLimit(const std::vector<PressurePose>& poses, double limit_Pa) {
  char limit[48];
  std::snprintf(limit, sizeof limit, "max_pressure_kPa %.4g", 1e-3 * limit_Pa);
  for (const PressurePose& p : poses) {
    const std::string where = "motion '" + p.motion + "'";
    if (!p.scene->body || p.scene->effects.contact == ContactModel::kNone)
      return Status::Error(std::string(limit) + ": " + where + " has no body in contact with the garment to press on");
    SceneSpec cloth = *p.scene;
    cloth.design.assign(cloth.garment.faces.rows(), kCloth);
    Result<SimulationResult> r = SimulateScene(cloth);
    if (!r.ok()) return r.status().WithContext(std::string(limit) + ": the fully cloth garment in " + where + ": ");
    if (!r->solve.at_equilibrium())
      return Status::Error(std::string(limit) + ": the fully cloth garment in " + where + " did not reach equilibrium (" +
                           ToString(r->solve.status) + ")");
    if (r->skin.peak_Pa > limit_Pa) {
      char what[256];
      std::snprintf(what, sizeof what, "%s: the fully cloth garment already presses the skin %.3g kPa (%.3g mmHg, body vertex %d) in %s",
                    limit, 1e-3 * r->skin.peak_Pa, kMmHgPerPa * r->skin.peak_Pa, r->skin.peak_vertex, where.c_str());
      return Status::Error(std::string(what) + ": no design can keep below the limit (raise it, or loosen the garment)");
    }
  }
  return Status::Ok();
}

}  // namespace kgd
