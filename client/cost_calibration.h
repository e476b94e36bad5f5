// This machine's factor on the job cost model (core/beso/quality.h: LearnMachineFactor), kept as
// cost_calibration.json in the scene cache's folder (core/scene/scene_cache.h), so that the time
// `kgd design` and `kgd scenes` predict is this machine's after its first finished design job. Nothing is
// kept when the cache is off (KGD_CACHE_DIR=off); a missing or damaged file reads as no jobs.
#pragma once

#include "core/beso/quality.h"

namespace kgd::cli {

MachineFactor ReadMachineFactor();

// After a design job from iteration 0: `predicted_s` the reference prediction of its solves for the
// iterations it ran, `measured_s` what they took. Errors are ignored (a prediction is a courtesy).
void RecordDesignTime(double predicted_s, double measured_s);

}  // namespace kgd::cli
