#include "core/scene/scene.h"

namespace kgd {
namespace {

Result<std::shared_ptr<const BodyField>> BuildBodyField(const SceneSpec& s, const Positions& vertices, const Faces& faces) {
  BodyFieldSettings bs;
  bs.support_scale = s.body_support_scale;
  return BodyField::Build(vertices, faces, bs);
}

}  // namespace

Result<GarmentModel> BuildGarmentModel(const SceneSpec& s) {
  GarmentModel m;
  m.faces = s.garment.faces;
  m.rest = s.garment.vertices;
  m.design = s.design;
  m.cloth = s.cloth;
  m.reinforced = s.reinforced;
  m.lame = s.lame;
  m.effects = s.effects;
  m.contact_stiffness_N_per_m = s.contact_stiffness_N_per_m;
  if (s.initial.rows() != s.garment.vertices.rows())
    return Status::Error("initial positions: " + std::to_string(s.initial.rows()) + " rows for " +
                         std::to_string(s.garment.vertices.rows()) + " vertices");
  if (Status st = ValidateMesh(s.initial, s.garment.faces, "garment initial positions"); !st.ok()) return st;
  if (s.effects.attachments) {
    m.attachments.faces = s.attachment_faces;
    m.attachments.stiffness_N_per_m = s.attachment_stiffness_N_per_m;
    if (Status st = ValidateFaceList(s.attachment_faces, s.garment.faces.rows(), "attachments.faces"); !st.ok()) return st;
    m.attachments.anchors = FaceCentroids(s.on_body.rows() ? s.on_body : s.initial, s.garment.faces, s.attachment_faces);
  }
  if (s.effects.clamps) m.clamps = s.clamps;
  if (s.effects.fold_barrier && s.on_body.rows()) m.fold_reference = s.on_body;
  if (s.effects.friction > 0 && s.on_body.rows()) m.friction_anchor = s.on_body;
  if (s.effects.contact != ContactModel::kNone) {
    if (!s.body) return Status::Error("effects.contact is on but the scene has no body");
    if (s.body_field && s.body_field->num_vertices() == s.body->vertices.rows()) {
      m.body = s.body_field;
    } else {
      Result<std::shared_ptr<const BodyField>> field = BuildBodyField(s, s.body->vertices, s.body->faces);
      if (!field.ok()) return field.status();
      m.body = *field;
    }
  }
  if (Status st = ValidateModel(m); !st.ok()) return st;
  return m;
}

Result<Positions> GarmentOnBody(const SceneSpec& s, const Positions& body_pose, std::shared_ptr<const BodyField>* field_out) {
  if (!s.motion || s.garment_from_body.cols() != body_pose.rows())
    return Status::Error("scene '" + s.name + "': the garment is not cut from a body with " + std::to_string(body_pose.rows()) + " vertices");
  const Positions cut = s.garment_from_body * body_pose;
  if (s.effects.contact == ContactModel::kNone) return cut;
  Result<std::shared_ptr<const BodyField>> field = BuildBodyField(s, body_pose, s.motion->faces);
  if (!field.ok()) return field.status();
  if (field_out) *field_out = *field;
  return PlaceOnZeroSet(**field, cut, "garment vertex");
}

Status CutGarmentFromMotion(SceneSpec* s, const std::string& region_name, const std::string& attachments_name) {
  if (!s->motion) return Status::Error(region_name + ": the scene has no body motion to cut the garment from");
  const BodyMotion& m = *s->motion;
  Result<GarmentCut> cut = CutGarment(m.faces, m.rest, s->garment_region, s->attachment_body_faces, s->subdivisions,
                                      region_name, attachments_name);
  if (!cut.ok()) return cut.status();
  s->garment_from_body = cut->from_body;
  s->attachment_faces = cut->attachment_faces;
  s->body = TriMesh{m.deformed, m.faces};
  s->body_field = nullptr;
  Result<Positions> rest = GarmentOnBody(*s, m.rest);
  if (!rest.ok()) return rest.status().WithContext(region_name + " (rest pose): ");
  Result<Positions> on_body = GarmentOnBody(*s, m.deformed, &s->body_field);
  if (!on_body.ok()) return on_body.status().WithContext(region_name + " (deformed pose): ");
  s->garment = TriMesh{std::move(rest).value(), cut->garment.faces};
  s->on_body = std::move(on_body).value();
  s->initial = s->on_body;
  s->design.assign(s->garment.faces.rows(), kCloth);
  if (Status st = ValidateMesh(s->garment.vertices, s->garment.faces, region_name + " (garment in the rest pose)"); !st.ok()) return st;
  return ValidateMesh(s->initial, s->garment.faces, region_name + " (garment in the deformed pose)");
}

Result<SceneSpec> SceneAtFrame(const SceneSpec& spec, int frame) {
  SceneSpec s = spec;
  const Positions& body = spec.motion->frames[frame];
  s.name = spec.name + " frame " + std::to_string(frame + 1);
  s.body = TriMesh{body, spec.motion->faces};
  s.body_field = nullptr;
  Result<Positions> on_body = GarmentOnBody(spec, body, &s.body_field);
  if (!on_body.ok()) return on_body.status().WithContext(s.name + ": ");
  s.on_body = std::move(on_body).value();
  s.initial = s.on_body;
  return s;
}

}  // namespace kgd
