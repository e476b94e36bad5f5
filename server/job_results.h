// A stored job's results in the forms the doors serve beside the kgd.v1 messages: the strain energy
// per rest area of each face, and an iteration as the garment PLY (core/mesh/mesh_io.h,
// WriteGarmentPly). Pure functions of the messages JobService returns; errors are ServiceStatus codes.
#pragma once

#include <string>
#include <vector>

#include "kgd/v1/kgd.pb.h"
#include "server/job_service.h"

namespace kgd::server {

// Strain energy per rest area (J/m^2) of each face: its energy density (J/m^3) times the thickness of
// its material by `design` (one byte per face, 1 = reinforced). FAILED_PRECONDITION when the garment
// does not store the thicknesses (a design file of an older kgd); INTERNAL when the sizes disagree.
ServiceStatus EnergyPerArea(const v1::Garment& garment, const std::string& design,
                            const google::protobuf::RepeatedField<double>& energy_density_Pa, std::vector<float>* out);

// Iteration `iteration` (a response with its garment) as binary PLY; `name` is for messages.
// INTERNAL when the garment or the record is malformed.
ServiceStatus IterationPly(const v1::GetIterationResponse& iteration, const std::string& name, std::string* ply);

}  // namespace kgd::server
