// An energy term of the garment system, as a plug-in. A term is a sum over the elements of one
// stencil (faces, hinges or vertices); for each element it gives the energy (J) and, on request, the
// gradient (N) and a positive semi-definite Hessian (N/m) on the stencil's coordinates. The garment
// system (garment_system.h) does the rest for every term alike: assembly into the sparse Hessian,
// parallel colouring, local re-evaluation (EvaluateFrom), the energy breakdown by the term's name and
// the messages that name a non-finite element.
//
// A new term is its own files (the element's energy and derivatives, a class deriving from EnergyTerm,
// a factory that returns nullptr when the scene's effects leave it off, a finite-difference test with
// core/sim/finite_difference_check.h) plus one line in the registry (energy_terms.cpp) and, if the
// scene switches it, its key in the scene schema.
#pragma once

#include <Eigen/Core>
#include <array>
#include <memory>
#include <string>
#include <vector>

#include "core/mesh/topology.h"
#include "core/mesh/trimesh.h"

namespace kgd {

enum class Stencil {
  kFace,    // a triangle: its 3 vertices
  kHinge,   // an interior edge with its two triangles: edge a-b, then c (first triangle), d (second)
  kVertex,  // one vertex
};
inline constexpr int StencilSize(Stencil s) { return s == Stencil::kFace ? 3 : s == Stencil::kHinge ? 4 : 1; }

struct ElementEnergy {
  double energy_J = 0;
  // The element wrote its gradient and Hessian (when asked for); false: it adds nothing to them.
  bool derivatives = false;
};

class EnergyTerm {
 public:
  virtual ~EnergyTerm() = default;
  virtual Stencil stencil() const = 0;
  // Element `e` (a face, hinge or vertex index) with stencil vertices `v` (StencilSize entries) at x.
  // `g` (3k values) and `H` (3k x 3k, column-major) are null when not wanted; when the result says
  // `derivatives`, the term has written every value of both (their contents on entry are undefined).
  // Called for distinct elements from several threads at once.
  virtual ElementEnergy Evaluate(int e, const int* v, const Positions& x, double* g, double* H) = 0;
  // What a non-finite energy of an element means, for messages, e.g. ": folded over".
  virtual std::string NonFiniteMeaning() const { return ""; }
};

}  // namespace kgd
