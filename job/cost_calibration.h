// A machine's factor on the job cost model (core/beso/quality.h: LearnMachineFactor), kept in a small
// JSON file: by `kgd design` as cost_calibration.json in the scene cache's folder
// (core/scene/scene_cache.h), and by the design server in its data folder from the jobs its workers
// finish. The time predicted before a job starts is then this machine's (or these workers') after the
// first finished job. A missing or damaged file reads as no jobs.
#pragma once

#include <map>
#include <string>

#include "core/beso/quality.h"
#include "core/scene/builtin_scenes.h"

namespace kgd {

// The local file: cost_calibration.json in the scene cache's folder; empty when the cache is off
// (KGD_CACHE_DIR=off), and then nothing is kept.
std::string LocalCostCalibrationFile();

// The factor kept in `path` (no jobs when `path` is empty, missing or damaged).
MachineFactor ReadMachineFactor(const std::string& path);

// The quality a job spec names (JobSpec.optimizer.quality): empty or unknown is standard, the default.
Quality QualityOfJob(const std::string& name);

// The reference machine's prediction of a design job's solves on a garment of `garment_faces`: iteration
// 0 and `later` iterations after it (JobCostPrediction::solves_s) of `simulations` garments each (the
// motions, or bodies, it weighs), what a finished job's time is learned against.
double PredictedSolvesSeconds(int garment_faces, Quality quality, int later, int simulations = 1);

// A built-in scene's whole design job per preset name (draft, standard, precise) at its budget, its
// solves at `machine_factor` times the reference machine's: what `kgd scenes` and the web form show.
std::map<std::string, double> PredictedSceneSeconds(const BuiltinSceneInfo& scene, double machine_factor);

// After a design job from iteration 0: `predicted_s` the reference prediction of its solves for the
// iterations it ran, `measured_s` what they took; updates `path` (atomically: a temporary file, then a
// rename). Errors are ignored (a prediction is a courtesy).
void RecordDesignTime(const std::string& path, double predicted_s, double measured_s);

}  // namespace kgd
