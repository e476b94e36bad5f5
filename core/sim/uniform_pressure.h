// Uniform pressure: a pressure p (Pa) on every garment face along the face's rest normal, as a dead
// load (its direction and the area it acts on fixed at rest; small-displacement loading, as a pull
// test's weight). The load on a face is the force p A_f n_f, A_f n_f = (x1 - x0) x (x2 - x0) / 2 at
// rest, shared equally by its three vertices, so its potential is the work it does, linear in x:
//   E_f = -p A_f n_f . (x0 + x1 + x2) / 3,
// with gradient -p A_f n_f / 3 on each vertex and a zero Hessian. Over a flat piece of area A and
// normal n the load sums to p A n; over a closed surface to zero. Off by default ("effects":
// {"uniform_pressure_Pa": p} turns it on; a negative p pulls).
#pragma once

#include <Eigen/Core>

#include "core/sim/energy_terms.h"
#include "core/sim/garment_model.h"

namespace kgd {

// E_f (J) of one face with rest vector area `area_normal_m2` (A_f n_f) at x0, x1, x2; with `grad`,
// its 9-gradient (N).
double EvaluateUniformPressureFace(const Eigen::Vector3d& area_normal_m2, double pressure_Pa, const Eigen::Vector3d& x0,
                            const Eigen::Vector3d& x1, const Eigen::Vector3d& x2, Eigen::Matrix<double, 9, 1>* grad);

}  // namespace kgd
