// A design job, the one way: what `kgd design` (local) and kgd-worker (for the service) both do to
// prepare, resume and run a BESO job on a scene. Only where the iterations go differs: the local
// command appends them to its design file, the worker reports them to the server, which appends them
// to the job's design file. Either way the file's header is the job's header() below, so a job gives
// the same file, bit for bit in its arrays, wherever it runs.
#pragma once

#include <functional>
#include <string>
#include <vector>

#include "core/beso/design_loop.h"
#include "core/scene/scene.h"
#include "kgd/v1/kgd.pb.h"
#include "store/design_evaluation.h"
#include "store/design_file.h"

namespace kgd {

struct DesignJob {
  SceneSpec scene;           // with the job's solver overrides applied
  DesignFileHeader header;   // scene name, body words, BESO settings, garment: what the design file stores
  // Iterations already run (empty for a new job): metrics of 0..k, with arrays on iteration k.
  std::vector<BesoIteration> history;

  const BesoSettings& settings() const { return header.settings; }
};

// A new job on `scene` (built by the caller) named `scene_name` with `body` overrides (as words,
// "name=value ..."): BESO settings from `optimizer` over the scene's budget, the solver overrides and
// the motion weights (ApplyMotionWeights) applied. Errors name the setting or the motion, as
// SettingsOfJob and ApplyMotionWeights do.
Result<DesignJob> NewDesignJob(SceneSpec scene, const v1::OptimizerSettings& optimizer, std::string scene_name, std::string body);

// A stored job continued: `header` and `history` from its design file or the server's checkpoint,
// `scene` rebuilt by the caller. The scene must give the stored garment exactly (the message names
// the first difference, prefixed by `source`); `max_iterations` > 0 replaces the stored limit. The
// scene's motions take the stored weights (header.motions).
Result<DesignJob> ResumeDesignJob(SceneSpec scene, DesignFileHeader header, std::vector<BesoIteration> history, const std::string& source,
                                  int max_iterations = 0);

// Ok when `scene` gives exactly the garment `header` stores; else names the first difference (counts,
// a face, a rest or an on-body vertex), prefixed by `source`.
Status CheckStoredGarment(const SceneSpec& scene, const DesignFileHeader& header, const std::string& source);

// The scene a design file was made from, rebuilt (ResumeDesignJob checks it against the stored
// garment); errors are prefixed by `path`.
Result<SceneSpec> RebuildSceneOfDesignFile(const std::string& path, const DesignFileHeader& header);
// ... and checked against the garment the file stores.
Result<SceneSpec> SceneOfDesignFile(const std::string& path, const DesignFileHeader& header);

// Runs the job from its last iteration (or from the start): every new iteration goes to
// `on_iteration`, which returns false to stop after it. Returns the new iterations.
Result<std::vector<BesoIteration>> RunDesignJob(const DesignJob& job, const std::function<bool(const BesoIteration&)>& on_iteration);

// The job's finished design (`last`, with arrays) beyond the deformed pose: simulated through every
// frame of the scene's motion (none without one), and the Line and X baselines of its reinforced area
// beside it (none unless the garment has two attachment bands; `note` says why). `first` is iteration 0
// (its metrics; with its energies the bands centre where the fully reinforced garment works hardest,
// else where `last` does); density ratios are against it.
Result<DesignEvaluation> EvaluateDesign(const DesignJob& job, const BesoIteration& first, const BesoIteration& last);

// Iterations a job probably still runs after `it`: to shrink the target to the budget at ER per
// iteration, then the stop window; capped by max_iterations; 0 after an iteration 0 with nothing to
// resist. For progress bars and ETAs.
int IterationsLeft(const DesignJob& job, const BesoIteration& it);

// "word word ..." <-> words, as body overrides are stored.
std::string JoinWords(const std::vector<std::string>& words);
std::vector<std::string> SplitWords(const std::string& text);

}  // namespace kgd
