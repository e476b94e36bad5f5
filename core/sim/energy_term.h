// An energy term of the garment system, as a plug-in. A term is a sum over the elements of one
// stencil (faces, hinges or vertices); for each element it gives the energy (J) and, on request, the
// gradient (N) and a positive semi-definite Hessian (N/m) on the stencil's coordinates. The garment
// system (garment_system.h) does the rest for every term alike: assembly into the sparse Hessian,
// parallel colouring, local re-evaluation (EvaluateFrom), the energy breakdown by the term's name and
// the messages that name a non-finite element.
//
// A new term is its own files (the element's energy and derivatives, a class deriving from EnergyTerm,
// a factory that returns nullptr when the scene's effects leave it off, a finite-difference test with
// core/testing/finite_difference_check.h) plus one line in the term list (term_list.h) and its proto
// fields. What else the system needs of a particular term (a safe step, a lagged pass, per-face
// densities, a projection of line-search trials) is an optional hook below; the system knows no term.
#pragma once

#include <Eigen/Core>
#include <array>
#include <memory>
#include <string>
#include <vector>

#include "core/mesh/topology.h"
#include "core/mesh/trimesh.h"

namespace kgd {

enum class MembraneRegime;  // membrane.h

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

  // Optional hooks: what the system and its solvers may ask of a term beyond its energy. The defaults
  // say the term has nothing to add.

  // The largest step length in [0, 1] from x along `direction` (all coordinates) the term allows a
  // line search to try (a barrier's distance to its wall): 1 when it sets no bound.
  virtual double MaxSafeStep(const Positions& x, const Positions& direction) const { return 1.0; }
  // A lagged term (lagged() true) takes its lagged data at x when asked (held until the next call);
  // solvers then solve again with the data of the new equilibrium (SolveLagged).
  virtual bool lagged() const { return false; }
  virtual void Lag(const Positions& x) {}
  // A term that is the garment's strain energy writes each face's energy density (Pa) and, with
  // `regime`, its regime; false when the term has none.
  virtual bool FaceDensities(const Positions& x, Eigen::VectorXd* density_Pa, std::vector<MembraneRegime>* regime) const {
    return false;
  }
  // Per element, values of the latest Evaluate with a gradient that an evaluation record keeps
  // (RecordWidth per element; 0: none), for the term's ProjectTrial from that record.
  virtual int RecordWidth() const { return 0; }
  virtual void RecordElement(int e, double* out) const {}
  // Corrects a line-search trial `trial` of a step from `x_from`, given what the evaluation at x_from
  // recorded for this term (`recorded`: RecordWidth values per element), moving only vertices whose
  // three coordinates are free (free_index >= 0). Returns the number of vertices moved.
  virtual int ProjectTrial(const std::vector<double>& recorded, const Positions& x_from, const std::vector<int>& free_index,
                           Positions* trial) {
    return 0;
  }
};

}  // namespace kgd
