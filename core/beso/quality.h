// Accuracy presets of a design job and the cost model that predicts a job's time before it starts.
//
// A preset sets the solver's gradient tolerance per BESO iteration (SolverSettings::grad_tol); each is
// a point on the accuracy/time front that `kgd study accuracy` measures (docs/ACCURACY.md):
//   draft     1e-3: about half the time of standard per iteration; designs of the same density ratio
//                   within about 1 %, but another design (the BESO path is sensitive)
//   standard  1e-4: the default (the paper's |g| < 1e-7 MN on its arm sleeve)
//   precise   1e-6: several times the time of standard; the reference designs are made at 1e-8
#pragma once

#include <string>
#include <string_view>
#include <vector>

#include "core/beso/beso.h"
#include "core/util/status.h"

namespace kgd {

enum class Quality { kDraft, kStandard, kPrecise };

struct QualityPreset {
  Quality quality;
  const char* name;  // "draft", "standard", "precise"
  double grad_tol;
};
// In order: draft, standard, precise.
const std::vector<QualityPreset>& QualityPresets();
const QualityPreset& PresetOf(Quality q);
// Errors name the value and the choices.
Result<Quality> QualityFromName(std::string_view name);

// What the time of a design job depends on, known before it starts.
struct JobCostInput {
  int garment_faces = 0;
  int frames = 0;             // motion frames the job poses the body through (0: rest and deformed pose only)
  bool builtin_body = true;   // the parametric body is built and posed (scene files bring their meshes)
  Quality quality = Quality::kStandard;
  int simulations = 1;        // garments simulated per iteration: the motions, or the bodies, a design weighs
};

struct JobCostPrediction {
  double setup_s = 0;          // scene: body, poses, garment
  double iteration0_s = 0;     // the fully reinforced garment, solved cold
  int iterations = 0;          // BESO iterations to the budget and a flat objective
  double per_iteration_s = 0;  // a warm re-solve and a design update
  // The solves of iteration 0 and `later` iterations after it.
  double solves_s(int later) const { return iteration0_s + later * per_iteration_s; }
  // The whole job, its solves taking `machine_factor` times the reference machine's time (MachineFactor).
  double total_s(double machine_factor = 1) const { return setup_s + machine_factor * solves_s(iterations); }
};

// A prediction on this project's reference machine (2 cores; docs/ACCURACY.md states the fit and its
// error on the built-in scenes). Iterations: the target area shrinks by ER per iteration to the budget,
// then the convergence window.
JobCostPrediction PredictJobCost(const JobCostInput& input, const BesoSettings& settings);

// How much longer than the reference machine this machine takes for the solves of a design job
// (iteration 0 and the iterations after it; set-up aside), learned from its finished jobs: a geometric
// mean of measured / predicted, each job weighted by its predicted seconds (a one-second pull test
// hardly moves what ten arm sleeves taught) and older jobs' weights decaying by 0.9 per job. A factor
// of 1 with no jobs is the reference machine's prediction.
struct MachineFactor {
  double factor = 1;
  int jobs = 0;
  double weight_s = 0;  // the decayed sum of the jobs' predicted seconds
};
// `predicted_s`: the reference prediction of the solves for the iterations the job ran (positive);
// `measured_s`: what they took. A ratio beyond 1/20..20 counts as 1/20 or 20 (a suspended laptop).
MachineFactor LearnMachineFactor(MachineFactor previous, double predicted_s, double measured_s);

}  // namespace kgd
