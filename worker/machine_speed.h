// A worker's speed against the job cost model's reference machine (core/beso/quality.h,
// job/cost_calibration.h), known before its first job, so that a server's first predictions are its
// workers' and not the reference machine's: the factor this machine keeps (cost_calibration.json in the
// scene cache's folder, learned from `kgd design` jobs and earlier measurements) or, when it keeps none,
// a measurement: iterations 0 and 1 of a knee_flexion design job (the kind of work the model predicts;
// a few seconds), which is then kept there too. The worker sends it with its first lease requests
// (kgd.v1.LeaseJobRequest.speed).
#pragma once

#include "core/util/status.h"
#include "kgd/v1/kgd.pb.h"

namespace kgd::worker {

// The kept factor as a speed (its jobs' weight in seconds: predicted and measured), or a measurement.
// Errors: the measurement's scene or job failed (the worker then sends no speed).
Result<v1::MachineSpeed> MachineSpeedOfThisMachine();

}  // namespace kgd::worker
