#include "core/scene/scene.h"

#include <cmath>
#include <cstdio>

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

namespace {
std::string Number(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%g", v);
  return buf;
}
}  // namespace

const char* ToString(MotionRole role) { return role == MotionRole::kAllow ? "allow" : "resist"; }

Result<MotionRole> MotionRoleFromName(const std::string& name, const std::string& what) {
  if (name == "resist") return MotionRole::kResist;
  if (name == "allow") return MotionRole::kAllow;
  return Status::Error(what + ": role '" + name + "' is neither \"resist\" nor \"allow\"");
}

const char* ToString(BodyObjective objective) { return objective == BodyObjective::kWorst ? "worst" : "mean"; }

Result<BodyObjective> BodyObjectiveFromName(const std::string& name, const std::string& what) {
  if (name == "mean") return BodyObjective::kMean;
  if (name == "worst") return BodyObjective::kWorst;
  return Status::Error(what + ": '" + name + "' is neither \"mean\" nor \"worst\"");
}

std::vector<SceneMotion> MotionsOf(const SceneSpec& s) {
  if (!s.bodies.empty()) {
    std::vector<SceneMotion> out;
    for (const SceneBody& b : s.bodies) out.push_back({b.name, MotionRole::kResist, b.weight, b.pose});
    return out;
  }
  if (!s.motions.empty()) return s.motions;
  SceneMotion m;
  m.name = s.name;
  if (s.motion) m.pose = *s.motion;
  return {m};
}

Status ValidateSceneMotions(const SceneSpec& s) {
  if (s.motions.empty()) return Status::Ok();
  if (!s.motion || s.garment_from_body.rows() == 0)
    return Status::Error("motions: scene '" + s.name + "' lists motions, but its garment is not cut from a body (garment.region)");
  const BodyMotion& own = *s.motion;
  for (size_t i = 0; i < s.motions.size(); ++i) {
    const SceneMotion& m = s.motions[i];
    const std::string what = "motion '" + m.name + "'";
    if (m.name.empty()) return Status::Error("motions[" + std::to_string(i) + "]: a motion needs a name");
    for (size_t j = 0; j < i; ++j)
      if (s.motions[j].name == m.name) return Status::Error(what + ": two motions have this name");
    if (!(m.weight >= 0 && std::isfinite(m.weight)))
      return Status::Error(what + ": weight " + Number(m.weight) + " must be finite and >= 0");
    const BodyMotion& p = m.pose;
    if (p.rest.rows() != own.rest.rows() || p.faces.rows() != own.faces.rows() || !(p.faces == own.faces))
      return Status::Error(what + ": its rest pose has another topology (" + std::to_string(p.rest.rows()) + " vertices, " +
                           std::to_string(p.faces.rows()) + " faces; the scene's body " + std::to_string(own.rest.rows()) + " and " +
                           std::to_string(own.faces.rows()) + " with the same faces): the motions share one rest body and garment");
    if (!(p.rest == own.rest)) return Status::Error(what + ": its rest pose differs from the scene's (the motions share one rest body and garment)");
    if (p.deformed.rows() != own.rest.rows()) return Status::Error(what + ": its deformed pose has " + std::to_string(p.deformed.rows()) + " vertices, the rest pose " + std::to_string(own.rest.rows()));
    for (size_t k = 0; k < p.frames.size(); ++k)
      if (p.frames[k].rows() != own.rest.rows()) return Status::Error(what + ": frame " + std::to_string(k + 1) + " has another vertex count than the rest pose");
  }
  const SceneMotion& first = s.motions.front();
  if (first.role != MotionRole::kResist || !(first.weight > 0))
    return Status::Error("motion '" + first.name + "': the first motion is the scene's own and must be resisted with a weight > 0 (role " +
                         ToString(first.role) + ", weight " + Number(first.weight) + ")");
  if (!(first.pose.deformed.rows() == own.deformed.rows() && first.pose.deformed == own.deformed))
    return Status::Error("motion '" + first.name + "': the first motion's deformed pose must be the scene's own (body.deformed)");
  return Status::Ok();
}

Status ValidateSceneBodies(const SceneSpec& s) {
  if (s.bodies.empty()) return Status::Ok();
  if (!s.motion || s.garment_from_body.rows() == 0)
    return Status::Error("bodies: scene '" + s.name + "' lists bodies, but its garment is not cut from a body (garment.region)");
  if (!s.motions.empty())
    return Status::Error("bodies: scene '" + s.name + "' lists bodies and motions; a design weighs several motions of one body or one motion of several bodies");
  const BodyMotion& own = *s.motion;
  for (size_t i = 0; i < s.bodies.size(); ++i) {
    const SceneBody& b = s.bodies[i];
    const std::string what = "body '" + b.name + "'";
    if (b.name.empty()) return Status::Error("bodies[" + std::to_string(i) + "]: a body needs a name");
    for (size_t j = 0; j < i; ++j)
      if (s.bodies[j].name == b.name) return Status::Error(what + ": two bodies have this name");
    if (!(b.weight >= 0 && std::isfinite(b.weight)))
      return Status::Error(what + ": weight " + Number(b.weight) + " must be finite and >= 0");
    const BodyMotion& p = b.pose;
    if (p.rest.rows() != own.rest.rows() || p.faces.rows() != own.faces.rows() || !(p.faces == own.faces))
      return Status::Error(what + ": its mesh has another topology (" + std::to_string(p.rest.rows()) + " vertices, " +
                           std::to_string(p.faces.rows()) + " faces; the scene's body " + std::to_string(own.rest.rows()) + " and " +
                           std::to_string(own.faces.rows()) + " with the same faces): the bodies must share one mesh topology, so that "
                           "the garment is the same on each");
    if (p.deformed.rows() != own.rest.rows())
      return Status::Error(what + ": its deformed pose has " + std::to_string(p.deformed.rows()) + " vertices, the rest pose " + std::to_string(own.rest.rows()));
    for (size_t k = 0; k < p.frames.size(); ++k)
      if (p.frames[k].rows() != own.rest.rows()) return Status::Error(what + ": frame " + std::to_string(k + 1) + " has another vertex count than the rest pose");
  }
  const SceneBody& first = s.bodies.front();
  if (!(first.weight > 0))
    return Status::Error("body '" + first.name + "': the first body is the scene's own and must have a weight > 0 (weight " + Number(first.weight) + ")");
  if (!(first.pose.rest == own.rest) || !(first.pose.deformed == own.deformed))
    return Status::Error("body '" + first.name + "': the first body must be the scene's own (its rest and deformed poses)");
  return Status::Ok();
}

Result<SceneSpec> SceneOnBody(const SceneSpec& spec, int b) {
  if (b == 0) return spec;
  const SceneBody& body = spec.bodies.at(b);
  const std::string what = "body '" + body.name + "'";
  SceneSpec s = spec;
  s.motion = body.pose;
  KGD_RETURN_IF_ERROR(CutGarmentFromMotion(&s, what + ": garment.region", what + ": attachments.body_faces"));
  if (!(s.garment.faces.rows() == spec.garment.faces.rows() && s.garment.faces == spec.garment.faces))
    return Status::Error(what + ": the garment cut from it has other faces than the scene's");
  s.design = spec.design;
  return s;
}

Result<SceneSpec> SceneInMotion(const SceneSpec& spec, int m) {
  SceneSpec s = spec;
  if (m == 0) return s;
  const SceneMotion& motion = spec.motions.at(m);
  s.motion->deformed = motion.pose.deformed;
  s.motion->frames = motion.pose.frames;
  s.body = TriMesh{motion.pose.deformed, spec.motion->faces};
  s.body_field = nullptr;
  Result<Positions> on_body = GarmentOnBody(spec, motion.pose.deformed, &s.body_field);
  if (!on_body.ok()) return on_body.status().WithContext("motion '" + motion.name + "' (deformed pose): ");
  s.on_body = std::move(on_body).value();
  s.initial = s.on_body;
  if (Status st = ValidateMesh(s.initial, s.garment.faces, "motion '" + motion.name + "' (garment in the deformed pose)"); !st.ok()) return st;
  return s;
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
