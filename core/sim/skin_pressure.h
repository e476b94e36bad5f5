// Skin pressure: the contact pressure a garment puts on the skin, per body vertex (Pa).
//
// At an equilibrium, garment vertex i presses on the body with the contact term's force (contact.h):
// f_i = -dE_contact/dx_i, whose normal component f_n,i = f_i . n (n = grad Phi / |grad Phi|, the body
// field's outward normal) is positive where the garment pushes the skin in. Its pressure is that force
// over the vertex's area, q_i = f_n,i / A_i (A_i: a third of the areas of the deformed garment triangles
// around it, LumpedVertexAreas). The skin pressure at a body vertex is the garment's pressure where the
// garment covers it: q interpolated linearly (barycentric) at the point of the garment nearest the body
// vertex, when that point is within half the garment's mean edge length (else the vertex is not covered:
// 0). Interpolating the pressure rather than scattering the forces keeps the field free of the aliasing a
// garment mesh that does not match the body's would cause; the sum of p_j times the body vertex areas
// then equals the total normal force up to the discretization (a tight sleeve: tests).
// With bilateral contact the garment can pull on the skin: p_j < 0 there.
//
// Summaries are over the pressed body vertices (p_j > 0): the peak (largest) and the 95th percentile
// (nearest rank: the smallest p with at least 95 % of the pressed vertices at or below it). Vertices the
// garment does not press are not counted, so covering more skin at the same pressure keeps the p95.
#pragma once

#include <Eigen/Core>

#include "core/body/body_field.h"
#include "core/mesh/trimesh.h"
#include "core/sim/contact.h"

namespace kgd {

// mmHg per Pa, for reports (medical compression classes are given in mmHg).
inline constexpr double kMmHgPerPa = 1.0 / 133.322387415;

struct SkinPressure {
  Eigen::VectorXd pressure_Pa;   // per body vertex
  double peak_Pa = 0;            // largest p_j
  double p95_Pa = 0;             // 95th percentile of p_j over pressed vertices (p_j > 0)
  int peak_vertex = -1;          // body vertex of the peak; -1 when nothing is pressed
  int loaded_vertices = 0;       // body vertices with p_j > 0
  double normal_force_N = 0;     // the garment's total normal contact force (sum of f_n,i)
};

// Per garment vertex, the normal component of the contact term's force at x (N; positive pushing the
// skin in): f_n = -dE/dx . grad Phi / |grad Phi|. Zero outside the field's support and, for unilateral
// contact, off the body.
Eigen::VectorXd ContactNormalForces(const BodyField& field, const Positions& x, ContactModel model, double stiffness_N_per_m);

// The garment's pressure per vertex at x, q_i = f_n,i / A_i (Pa), from its normal forces (N).
Eigen::VectorXd GarmentPressure(const Positions& x, const Faces& garment_faces, const Eigen::VectorXd& normal_force_N);

// The garment's pressure (per garment vertex, Pa) carried onto the body's vertices: interpolated at the
// nearest point of the garment (x, garment_faces) where it lies within half the garment's mean edge
// length, 0 elsewhere. Fills pressure_Pa and the summaries; normal_force_N is left 0.
SkinPressure PressureOnBody(const TriMesh& body, const Positions& x, const Faces& garment_faces, const Eigen::VectorXd& garment_pressure_Pa);

// The peak and 95th percentile of `pressure_Pa` over its positive entries, and the peak's index.
void SummarizePressure(const Eigen::VectorXd& pressure_Pa, SkinPressure* out);

// The skin pressure of a garment (x, garment_faces) on `body`, whose field is `field` (built from the
// same mesh): ContactNormalForces, GarmentPressure, PressureOnBody; normal_force_N is the sum of the
// normal forces.
SkinPressure ComputeSkinPressure(const TriMesh& body, const BodyField& field, const Positions& x, const Faces& garment_faces,
                                 ContactModel model, double stiffness_N_per_m);

}  // namespace kgd
