#include "core/beso/quality.h"

#include <algorithm>
#include <cmath>

namespace kgd {
namespace {

// The fit (docs/ACCURACY.md, "Predicted job time"); seconds per garment face, per frame, and fixed. Per
// iteration and iteration 0: the arm-flexion study (13,936 faces) at grad_tol 1e-3, 1e-4 and 1e-6, the
// iterations with every re-solve at the tolerance (resolve_tolerance_factor 1) and at the default factor
// 20. Set-up: a built-in scene read from the scene cache (core/scene/scene_cache.h); a first build costs
// seconds more.
constexpr double kDraftIterationRate = 2.9e-6, kDraftIteration0Rate = 3.4e-5;
constexpr double kStandardIterationRate = 5.0e-6, kStandardIteration0Rate = 7.2e-5;
constexpr double kPreciseIterationRate = 4.7e-5, kPreciseIteration0Rate = 1.65e-4;
// At factor 20, the shrinking iterations alone: the F = 1 rates scaled by the accuracy study's per-iteration
// solve time at 20 over its time at 1 (its iterations at the budget taken out), then all by 1.5 for what an
// iteration costs beyond its solves (the design file's append, the update), so that the seven scenes of
// `make study STUDY=paper` at the default factor come out at 1.04 times their wall time on average
// (docs/PERFORMANCE.md, "Predicted job time").
constexpr double kDraftLooseIterationRate = 6.2e-7, kStandardLooseIterationRate = 3.45e-6, kPreciseLooseIterationRate = 1.29e-5;
constexpr double kLooseFactor = 20;
constexpr double kSetupBase_s = 0.05, kSetupPerFrame_s = 0.02, kSetupPerFace_s = 2.0e-5;

}  // namespace

const std::vector<QualityPreset>& QualityPresets() {
  static const std::vector<QualityPreset> presets = {
      {Quality::kDraft, "draft", 1e-3},
      {Quality::kStandard, "standard", 1e-4},
      {Quality::kPrecise, "precise", 1e-6},
  };
  return presets;
}

const QualityPreset& PresetOf(Quality q) {
  for (const QualityPreset& p : QualityPresets())
    if (p.quality == q) return p;
  return QualityPresets()[1];
}

Result<Quality> QualityFromName(std::string_view name) {
  std::string list;
  for (const QualityPreset& p : QualityPresets()) {
    if (name == p.name) return p.quality;
    list += (list.empty() ? "" : ", ") + std::string(p.name);
  }
  return Status::Error("quality: '" + std::string(name) + "' is not a preset (one of: " + list + ")");
}

MachineFactor LearnMachineFactor(MachineFactor f, double predicted_s, double measured_s) {
  if (!(predicted_s > 0) || !(measured_s > 0) || !std::isfinite(predicted_s) || !std::isfinite(measured_s)) return f;
  const double ratio = std::clamp(measured_s / predicted_s, 1.0 / 20, 20.0);
  const double kept = f.jobs > 0 && f.factor > 0 && f.weight_s > 0 ? 0.9 * f.weight_s : 0;
  f.factor = std::exp((kept * std::log(kept > 0 ? f.factor : 1) + predicted_s * std::log(ratio)) / (kept + predicted_s));
  f.weight_s = kept + predicted_s;
  f.jobs += 1;
  return f;
}

JobCostPrediction PredictJobCost(const JobCostInput& in, const BesoSettings& settings) {
  // Fitted on the built-in scenes with the pinned kernels on 2 cores (docs/ACCURACY.md, "Predicted job
  // time"): time per garment face of a warm re-solve and of the cold first solve, per preset, and the
  // set-up of the parametric body's poses per frame.
  struct Rates {
    double per_iteration_s_per_face, iteration0_s_per_face, loose_iteration_s_per_face;
  };
  const Rates rates = in.quality == Quality::kDraft     ? Rates{kDraftIterationRate, kDraftIteration0Rate, kDraftLooseIterationRate}
                      : in.quality == Quality::kPrecise ? Rates{kPreciseIterationRate, kPreciseIteration0Rate, kPreciseLooseIterationRate}
                                                        : Rates{kStandardIterationRate, kStandardIteration0Rate, kStandardLooseIterationRate};
  JobCostPrediction p;
  // Every garment a design weighs (a motion, or a body) is cut and solved alike: K of them cost K
  // times one (docs/PERFORMANCE.md, "Jobs with several motions").
  const double v = std::max(in.garment_faces, 1), k = std::max(in.simulations, 1);
  p.setup_s = in.builtin_body ? kSetupBase_s + kSetupPerFrame_s * in.frames + kSetupPerFace_s * v * k : kSetupPerFace_s * v * k;
  p.iteration0_s = rates.iteration0_s_per_face * v * k;
  const double shrink = std::log(std::max(settings.budget, 1e-6)) / std::log1p(-settings.evolutionary_ratio);
  const int shrinking = static_cast<int>(std::ceil(shrink));
  p.iterations = std::min(settings.max_iterations, shrinking + settings.converge_window + 2);
  // While the target shrinks the re-solves stop at resolve_tolerance_factor x the tolerance: between the
  // two fitted factors the rate goes geometrically with log F, beyond them it stays at the nearer.
  const double w = std::clamp(std::log(std::max(settings.resolve_tolerance_factor, 1.0)) / std::log(kLooseFactor), 0.0, 1.0);
  const double loose = std::pow(rates.per_iteration_s_per_face, 1 - w) * std::pow(rates.loose_iteration_s_per_face, w);
  const int at_shrinking = std::min(shrinking, p.iterations), at_budget = p.iterations - at_shrinking;
  p.per_iteration_s = v * k * (p.iterations > 0 ? (at_shrinking * loose + at_budget * rates.per_iteration_s_per_face) / p.iterations
                                                 : rates.per_iteration_s_per_face);
  return p;
}

}  // namespace kgd
