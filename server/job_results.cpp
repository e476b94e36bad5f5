#include "server/job_results.h"

#include <sstream>

#include "core/mesh/mesh_io.h"
#include "proto/records.h"

namespace kgd::server {

ServiceStatus EnergyPerArea(const v1::Garment& g, const std::string& design, const google::protobuf::RepeatedField<double>& energy_density_Pa,
                            std::vector<float>* out) {
  const int nf = energy_density_Pa.size();
  if (g.cloth_thickness_m() <= 0 || g.reinforced_thickness_m() <= 0)
    return {ServiceCode::kFailedPrecondition,
            "the job's design file does not store the material thicknesses (written by an older kgd): energy per area is unknown"};
  if (static_cast<int>(design.size()) != nf)
    return {ServiceCode::kInternal, std::to_string(design.size()) + " design values for " + std::to_string(nf) + " faces"};
  out->resize(nf);
  for (int f = 0; f < nf; ++f)
    (*out)[f] = static_cast<float>(energy_density_Pa[f] * (design[f] ? g.reinforced_thickness_m() : g.cloth_thickness_m()));
  return ServiceStatus::Ok();
}

ServiceStatus IterationPly(const v1::GetIterationResponse& iteration, const std::string& name, std::string* ply) {
  DesignFileHeader h;
  if (Status st = GarmentFromProto(iteration.garment(), &h); !st.ok()) return {ServiceCode::kInternal, st.message()};
  Result<BesoIteration> it = RecordFromProto(iteration.record(), static_cast<int>(h.garment.faces.rows()), static_cast<int>(h.garment.vertices.rows()));
  if (!it.ok()) return {ServiceCode::kInternal, it.message()};
  std::ostringstream out;
  if (Status st = WriteGarmentPly(out, name, it->positions, h.garment.faces, it->design, it->energy_density_Pa); !st.ok())
    return {ServiceCode::kInternal, st.message()};
  *ply = std::move(out).str();
  return ServiceStatus::Ok();
}

}  // namespace kgd::server
