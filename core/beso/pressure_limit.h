// A skin-pressure limit on a design job (BesoSettings::max_pressure_Pa; scene key max_pressure_kPa;
// docs/MODEL.md, "Pressure limit"). The skin pressure is core/sim/skin_pressure.h's: the garment's
// contact pressure per vertex, q_i = f_n,i / A_i, carried onto the body's vertices.
//
// The rule: once the target area has reached the budget, every design update whose previous design
// pressed the skin above the limit in a resisted motion's deformed pose first keeps out (cloth for the
// rest of the run, as garment.keep_out) the faces around every garment vertex with q_i above the limit.
// The kept-out set only grows, so the run settles: in the worst case on the fully cloth garment, which
// the job checks against the limit before it starts.
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <string>
#include <vector>

#include "core/mesh/trimesh.h"
#include "core/scene/scene.h"
#include "core/sim/skin_pressure.h"
#include "core/util/status.h"

namespace kgd {

// One pose's pressures: the garment's per vertex (Pa) and the skin's on the body.
struct PosePressure {
  Eigen::VectorXd garment_Pa;  // q per garment vertex; empty without contact
  SkinPressure skin;
};

// The pressures of the garment of `model` at x on `body` (the mesh model.body was built from): zero
// (empty garment_Pa) when the model has no contact.
PosePressure PressureInPose(const TriMesh& body, const GarmentModel& model, const Positions& x);

// The faces the limit keeps out next: those around every garment vertex whose pressure exceeds
// `limit_Pa` in any of `garment_Pa` (one per pose; empty ones are skipped), among the faces
// `may_keep_out` allows (not kept out yet, not kept in). When none of them is a reinforced face of
// `design`, the ring around those vertices grows until it holds reinforced faces that may go, which
// are added too: a call with a vertex above the limit removes reinforcement whenever any may go.
// Increasing face order; empty when no vertex presses above the limit.
std::vector<int> FacesToKeepOut(const Faces& faces, int num_vertices, const std::vector<Eigen::VectorXd>& garment_Pa, double limit_Pa,
                                const std::vector<uint8_t>& design, const std::vector<uint8_t>& may_keep_out);

// A resisted motion's scene for the check below: its name and the scene posed in it.
struct PressurePose {
  std::string motion;
  const SceneSpec* scene = nullptr;
};

// Ok when the fully cloth garment presses the skin at most `limit_Pa` in every pose. Else an error
// naming the limit, the peak (kPa and mmHg), its body vertex and the motion: no design can keep below
// a limit the softest garment breaks. Also an error when a pose has no body mesh or no contact.
Status CheckClothUnderPressureLimit(const std::vector<PressurePose>& poses, double limit_Pa);

}  // namespace kgd
