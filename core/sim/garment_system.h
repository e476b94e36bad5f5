// The garment-on-body system: the total potential energy of a garment, a sum of energy terms
// (membrane, contact with the body field, attachments, fold barrier, friction, ...: the term list in
// term_list.h), over the free degrees of freedom left by the clamps, with its gradient and a
// projected (positive semi-definite) Hessian assembled into a fixed sparse pattern.
//
// Effects are opt-in: only the terms the model's effects switch on are made and evaluated. A model
// without contact needs no body field and none is built. The system knows no particular term (it
// includes no term's header): every term is handled alike, through energy_term.h's interface and its
// optional hooks: elements of
// its stencil (faces, hinges, vertices) are coloured so that no two of a colour share a vertex and
// evaluated in parallel colour by colour, their local gradients and Hessians scattered in a fixed
// order, so results are bit-identical whatever the thread count.
//
// Units: positions m, energies J, gradients N, Hessians N/m.
#pragma once

#include <Eigen/Core>
#include <Eigen/SparseCore>
#include <array>
#include <memory>
#include <string>
#include <string_view>
#include <vector>

#include "core/body/body_field.h"
#include "core/mesh/topology.h"
#include "core/mesh/trimesh.h"
#include "core/sim/energy_terms.h"
#include "core/sim/garment_model.h"
#include "core/util/status.h"

namespace kgd {

// Checks sizes, indices, materials and that the effects have what they need. Names the offending item.
Status ValidateModel(const GarmentModel& model);

// The energy of each registered term (J), in the term list's order, 0 for a term that is off.
struct EnergyBreakdown {
  struct Term {
    const char* name;
    double energy_J;
  };
  std::vector<Term> terms;
  // The energy of the term named `name` ("membrane", ...); 0 when there is none.
  double operator[](std::string_view name) const;
  // The sum in the term list's order.
  double total_J() const;
};

// What one evaluation leaves for a later one near it (GarmentSystem::EvaluateFrom): where it was made and
// each term's energy there. Valid for the system that made it while its design and lagged friction stay.
struct EvaluationRecord {
  Positions x;
  // Per term of the system (GarmentSystem::terms() order), per element of its stencil.
  std::vector<std::vector<double>> energy_J;
  // Per term of the system, what it records per element (EnergyTerm::RecordWidth values each, e.g.
  // the contact term's Phi and grad Phi per vertex); empty when no gradient was evaluated.
  std::vector<std::vector<double>> recorded;
  std::vector<uint8_t> design;  // the system's design it was made with (per face)
  int lag_version = -1;          // the system's lagged data it was made with
};

class GarmentSystem {
 public:
  // Precondition: ValidateModel(model).ok(), and `initial` has one row per rest vertex. Clamp targets
  // are taken from `initial`.
  GarmentSystem(GarmentModel model, const Positions& initial);

  const GarmentModel& model() const { return model_; }
  int num_vertices() const { return static_cast<int>(model_.rest.rows()); }
  int num_faces() const { return static_cast<int>(model_.faces.rows()); }
  int num_free_dofs() const { return num_free_; }
  // For each of the 3n coordinates, its index among the free ones, or -1 if clamped.
  const std::vector<int>& free_index() const { return free_index_; }
  // Per face: its rest area (m^2).
  const std::vector<double>& rest_areas_m2() const { return rest_area_; }
  // The terms the model switched on, in evaluation order: their registry names, and the index of one
  // by name (-1 when off).
  const std::vector<const char*>& term_names() const { return term_names_; }
  int term_index(std::string_view name) const;

  // Evaluation time per built term (evaluation order), summed over every Evaluate and EvaluateFrom since
  // the system was made: a stencil's loop is timed as a whole and split among the terms summed over it
  // in proportion to the time each took on a sample of the elements (one in kTermTimeSample), so the
  // terms add up to the measured loops. The contact term's time includes its body-field queries.
  struct TermTime {
    const char* name;
    double seconds = 0;
    long long elements = 0;  // element evaluations
  };
  static constexpr int kTermTimeSample = 16;
  std::vector<TermTime> term_times() const;
  // Time in body-field queries outside the terms (VertexPhi: the line search's contact projection), s.
  double body_field_query_s() const { return body_field_query_s_; }

  // Changes the material of faces (the BESO loop does this between solves); the pattern is unchanged.
  void SetDesign(const std::vector<uint8_t>& design);

  // Sets the clamped coordinates of x to their targets.
  void ApplyClamps(Positions* x) const;

  // Moves clamped coordinates to their targets and carries the same displacement into the free
  // coordinates by harmonic extension over the mesh graph. Starting a pull from a state where only the
  // jaws moved would leave the interior slack, with no stiffness to guide Newton.
  void ApplyClampsSmoothly(Positions* x) const;

  // The largest step length in [0, 1] along `direction` (all coordinates) every term allows
  // (EnergyTerm::MaxSafeStep; the fold barrier's goes at most 80 % of the way to folding a triangle
  // over, as interior-point methods step towards a barrier). 1 when no term sets a bound.
  double MaxSafeStep(const Positions& x, const Positions& direction) const;

  // Total energy at x (+infinity where undefined) and, on request, the gradient over all 3n coordinates
  // and the projected Hessian over the free ones. `hessian` must be a copy of hessian_pattern().
  // With `record`, also leaves there what EvaluateFrom needs.
  double Evaluate(const Positions& x, Eigen::VectorXd* gradient, Eigen::SparseMatrix<double>* hessian,
                  EnergyBreakdown* breakdown = nullptr, EvaluationRecord* record = nullptr);

  // Why the energy at x is not finite, for the solvers' error message: a non-finite coordinate, or each
  // term whose energy is not finite with its first face or vertex and that element's energy. Empty when
  // the energy at x is finite.
  std::string DescribeNonFiniteEnergy(const Positions& x);

  // Evaluate(x, gradient, hessian, breakdown, record), given an evaluation at base.x with its record and,
  // when a gradient or Hessian is wanted here, its gradient and Hessian (`base_gradient`, `base_hessian`;
  // they may be the same objects as `gradient`, `hessian`, and `record` may be `&base`). Only the terms
  // of the vertices that moved, and the gradient and Hessian entries they touch, are computed again; the
  // rest is the base's. Faces whose design changed since the base count as touched too. Each entry sums
  // the same terms in the same order as Evaluate, so the results are bit-identical to it. Newton's local
  // steps move a tenth to a third of the vertices, and a BESO re-solve starts where the last one ended
  // with a few per cent of the faces changed: these evaluations cost a fraction of a full one. Runs
  // Evaluate when more than a third of the vertices moved or lie on changed faces, or when the base
  // cannot serve (other lagged friction, or no gradient where one is wanted).
  double EvaluateFrom(const EvaluationRecord& base, const Eigen::VectorXd* base_gradient,
                      const Eigen::SparseMatrix<double>* base_hessian, const Positions& x, Eigen::VectorXd* gradient,
                      Eigen::SparseMatrix<double>* hessian, EnergyBreakdown* breakdown = nullptr,
                      EvaluationRecord* record = nullptr);

  // Upper triangle (free dofs, column-major) of the Hessian's sparsity; values are zero.
  const Eigen::SparseMatrix<double>& hessian_pattern() const { return pattern_; }

  // Per-face energy density W (Pa) and regime at x, from the first term that has them
  // (EnergyTerm::FaceDensities: the membrane); zeros when none has.
  void FaceDensities(const Positions& x, Eigen::VectorXd* density_Pa, std::vector<MembraneRegime>* regime) const;

  // True when a term is lagged (EnergyTerm::lagged: friction): Lag(x) then has something to take.
  bool lagged() const { return lagged_; }
  // Every lagged term takes its lagged data at x (friction: the normal forces and tangent planes of
  // the contact there), held until the next call. Before any call the friction term is zero.
  void Lag(const Positions& x);

  // Phi at each vertex (m); NaN where the field has no support; with `grad`, the field's gradient there
  // (a zero row where unsupported). Requires contact.
  Eigen::VectorXd VertexPhi(const Positions& x, Positions* grad = nullptr);

  // Corrects a line-search trial `trial` of a step from `from.x` by every term's ProjectTrial, given
  // the record of an evaluation at from.x with a gradient (unilateral contact moves vertices the step
  // carries across the skin back onto it: contact.h). Neither changes an equilibrium, only the path to
  // it. Returns the number of vertices moved; 0 when the record has no gradient.
  int ProjectTrial(const EvaluationRecord& from, Positions* trial);

  // Force the clamp exerts on the garment at x (N): the sum of dE/dx over its vertices.
  Eigen::Vector3d ClampReaction(int clamp, const Eigen::VectorXd& gradient) const;

  // Reference force for scale-aware tolerances (N): the stiffest material's E * t times the mean rest
  // edge length, i.e. the force that stretches a typical element by 100 %.
  double force_scale_N() const { return force_scale_; }
  double mean_edge_length_m() const { return mean_edge_; }
  // Stiffness scale (N/m): the stiffest material's E * t, the order of a vertex's membrane stiffness.
  double stiffness_scale_N_per_m() const { return stiffness_scale_; }

 private:
  GarmentModel model_;
  std::vector<double> rest_area_;
  std::vector<int> free_index_;
  int num_free_ = 0;
  Positions clamp_target_;
  std::vector<NeighborCache> caches_;
  Hinges hinges_;
  // The terms switched on, in evaluation order, with their registry names and breakdown places.
  std::vector<std::unique_ptr<EnergyTerm>> terms_;
  std::vector<const char*> term_names_;
  std::vector<int> registered_term_;  // per registry entry: its index in terms_, or -1 when off
  std::vector<int> record_width_;      // per term of terms_: EnergyTerm::RecordWidth
  bool lagged_ = false;
  // term_times(): per term of terms_, seconds and element evaluations; per thread, the sampled time of
  // each term (ns) in the loop being timed (rows padded apart so threads do not share cache lines).
  std::vector<double> term_seconds_;
  std::vector<long long> term_elements_;
  std::vector<double> term_sample_ns_;
  int term_sample_stride_ = 0;
  double body_field_query_s_ = 0;
  // Where a local Hessian's entries go: for each kept entry (the upper triangle's, free coordinates
  // only), its index in the local matrix's column-major data and in the Hessian's values.
  struct ScatterEntry {
    int local;
    int value;
  };
  // The elements of one stencil kind, the terms summed over them, and all the evaluation needs:
  // colours, the elements around each vertex and each face, the scatter of their local Hessians.
  struct Group {
    Stencil stencil;
    int k = 0;                              // vertices per element
    int count = 0;                          // elements
    std::vector<int> vertices;              // k per element
    std::vector<int> terms;                 // indices into terms_, evaluation order
    std::vector<std::vector<int>> colors;
    std::vector<int> color_of;
    std::vector<int> around_vertex_begin, around_vertex;  // elements around each vertex (CSR)
    std::vector<int> around_face_begin, around_face;      // elements on each face (CSR; a redesign changes them)
    std::vector<ScatterEntry> scatter;
    std::vector<int> scatter_begin;
    std::vector<int> mark;
  };
  std::vector<Group> groups_;  // evaluation order: faces, hinges, vertices (those with terms, faces always)
  Eigen::SparseMatrix<double> pattern_;
  EvaluationRecord scratch_;  // the per-term energies of an evaluation the caller keeps no record of
  double force_scale_ = 1, mean_edge_ = 0, stiffness_scale_ = 1;
  // Changes with the lagged data (Lag): records made before cannot serve.
  int lag_version_ = 0;

  // One element's terms at x and, on request, their summed gradient and Hessian; the same code serves
  // Evaluate and EvaluateFrom so that both sum the same numbers.
  struct ElementSum;
  // With `sample_ns`, adds each term's time (ns) to sample_ns[term index in terms_].
  void EvaluateElement(const Group& group, int e, const Positions& x, bool want_grad, bool want_hess, ElementSum* out,
                       double* sample_ns = nullptr);
  // The sample row of the calling thread for element position i of a loop, or null when i is not sampled.
  double* TermSample(size_t i);
  // Splits a timed loop over `group` (seconds, element evaluations) among its terms by the samples.
  void AddGroupTime(const Group& group, double seconds, long long elements);
  void StoreElement(const Group& group, int e, const ElementSum& sum, EvaluationRecord* r) const;
  void Scatter(const Group& group, int e, const ElementSum& sum, Eigen::VectorXd* gradient, double* values,
               const std::vector<int>* vertex_mark, const std::vector<int>* entry_mark, int changed) const;
  double SumEnergies(const EvaluationRecord& r, EnergyBreakdown* breakdown) const;
  void PrepareRecord(EvaluationRecord* r, bool want_grad) const;
  // EvaluateFrom's marks.
  std::vector<int> vertex_mark_, entry_mark_;
  int mark_ = 0;
};

}  // namespace kgd
