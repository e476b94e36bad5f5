// Baseline designs of the paper's evaluation ("User Evaluation", and the Line and X of the 2D
// validation): a straight band (Line) and two crossing bands (X) running between a garment's two
// attachment bands, of a given reinforced area. They are what a designer would draw by hand; an
// optimized design of the same area should store more energy than either.
//
// Geometry, on the rest shape: a harmonic coordinate s (0 on one attachment band, 1 on the other)
// runs along the garment; an angle theta around the local axis (the centre line of the level sets of
// s) runs around it. Line = the faces within a half-width of theta0; X = the faces within a
// half-width of either helix theta0 +- pi (s - 1/2), which cross at s = 1/2 and end half a turn apart,
// like the diagonals of the 2D X wrapped around the front of the limb. The half-width is found by
// bisection so the area matches.
#pragma once

#include <Eigen/Core>
#include <optional>
#include <string>
#include <vector>

#include "core/mesh/trimesh.h"
#include "core/scene/scene.h"
#include "core/scene/simulate.h"
#include "core/util/status.h"

namespace kgd {

struct GarmentCoordinates {
  Eigen::VectorXd s;      // per face, in [0, 1] from the first attachment band to the second
  Eigen::VectorXd theta;  // per face, radians in (-pi, pi]
};

// Preconditions: the attachment faces form exactly two edge-connected bands (the message says how many
// there are otherwise) and the garment is connected.
Result<GarmentCoordinates> ComputeGarmentCoordinates(const TriMesh& garment, const std::vector<int>& attachment_faces);

enum class BaselineShape { kLine, kX };
const char* ToString(BaselineShape shape);

// The baseline of `shape` centred on angle theta0 with reinforced rest area as close to `area_m2` as
// the faces allow. `face_area` holds the rest areas.
std::vector<uint8_t> BaselineDesign(const GarmentCoordinates& c, const Eigen::VectorXd& face_area, BaselineShape shape,
                                    double theta0, double area_m2);

// The angle where the garment works hardest: the circular mean of theta weighted by `weight` (e.g. the
// energy of each face in the fully reinforced design). A hand designer puts the Line there.
double WeightedMeanAngle(const GarmentCoordinates& c, const Eigen::VectorXd& weight);

// A design beside the Line and the X of the same reinforced area, each simulated in the scene's
// deformed pose from the same start (the garment on the body). theta0: `angle_rad` if given, else
// WeightedMeanAngle of `full_energy_per_face` (the fully reinforced design's face energies).
struct BaselineComparison {
  double theta0_rad = 0;
  double area_m2 = 0;
  std::vector<uint8_t> line, x;
  SimulationResult optimized_result, line_result, x_result;
};
Result<BaselineComparison> CompareWithBaselines(const SceneSpec& scene, const std::vector<uint8_t>& optimized,
                                                const Eigen::VectorXd& full_energy_per_face,
                                                std::optional<double> angle_rad = std::nullopt);

}  // namespace kgd
