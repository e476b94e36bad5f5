// The accuracy study (`kgd study accuracy`, `make study-accuracy`): what accuracy costs in time. Sweeps
// the knobs that trade one for the other (solver tolerance per BESO iteration, method, relaxation, fold
// barrier, mesh resolution, the frames a design is evaluated over) on a built-in scene;
// WriteAccuracyReport writes what it found as CSV, SVG plots and a generated ACCURACY.md.
#pragma once

#include <cstdint>
#include <limits>
#include <string>
#include <utility>
#include <vector>

#include "core/util/status.h"

namespace kgd {
struct SceneSpec;
}

namespace kgd::study {

// Tight re-solves and reference solutions: a tolerance two decades below the tightest knob setting a
// design is made with that Newton still reaches on the built-in scenes.
inline constexpr double kTightGradTol = 1e-8;
// The reinforced density (J/m^2) of `design` put on in `scene`'s deformed pose and solved by Newton at
// kTightGradTol: the "tight" figure every design of the study is judged by; NaN when that solve does
// not reach equilibrium.
double TightDensity(SceneSpec scene, const std::vector<uint8_t>& design);
// Moves every coordinate of the scene's start (`initial`) by a uniform draw in [-1, 1] nm (seeded: the
// same move every call): a run as accurate as the scene's on another round-off path.
void MoveStartByANanometre(SceneSpec* scene);
// The knob of `precise` run again from a start moved by at most 1 nm.
inline constexpr const char* kRepeatKnob = "precise, repeated";

struct AccuracyStudyOptions {
  std::string scene = "arm_flexion";  // a built-in scene
  std::string work_dir;               // the study's own scene cache lives (and is removed) under it
  int method_iterations = 30;         // BESO iterations the methods are compared over
  int lbfgs_trace_iterations = 10000;
  bool quick = false;  // three tolerances, no resolutions and no repeat of `precise`
};

constexpr double kStudyNaN = std::numeric_limits<double>::quiet_NaN();

// One design job of the study and what it gave.
struct StudyRun {
  std::string knob, value;
  int vertices = 0, faces = 0;
  int iterations = 0;  // BESO iterations after iteration 0
  std::string end;     // how it ended, or the error
  bool designed = false;  // it ended with a final design
  double loop_s = kStudyNaN, iteration0_s = kStudyNaN, per_iteration_s = kStudyNaN;
  double ratio_run = kStudyNaN;    // final density ratio, as the run's own solves found it
  double ratio_tight = kStudyNaN;  // the final design put on in the pose and re-solved at kTightGradTol
  double jaccard = kStudyNaN;      // against the reference run's final design (or the same iteration's)
  double jaccard_precise = kStudyNaN;  // against the `precise` preset's final design
};

// A solve's energy against time, iteration by iteration.
struct EnergyTrace {
  std::string name;
  double start_energy_J = kStudyNaN;
  std::vector<std::pair<double, double>> time_energy;  // (s since the start, J)
  std::string status;
};

// The pull test's jaw force at one tolerance against its value at 1e-11.
struct PullRow {
  double tol = kStudyNaN, force_N = kStudyNaN, error = kStudyNaN, seconds = kStudyNaN;
  int iterations = 0;
};

// The reference design over the motion simulated at every stride-th frame.
struct FramesRow {
  int stride = 0, frames = 0;
  double seconds = kStudyNaN, last_energy_J = kStudyNaN, last_error = kStudyNaN, curve_error = kStudyNaN;
  std::string status;
};

struct AccuracyStudy {
  AccuracyStudyOptions options;
  long garment_vertices = 0;
  double budget = kStudyNaN;
  double setup_cold_s = 0, setup_warm_s = 0;
  // False when no run of the tolerance sweep finished a design: nothing below the runs was measured.
  bool finished = false;
  std::string reference_value;  // the tolerance of the reference run (the tightest that finished)
  std::vector<StudyRun> runs;     // the sweep, the variants and the resolutions
  std::vector<StudyRun> methods;  // the methods over the first `method_iterations` iterations
  int method_iterations = 0;
  int warm_k = -1;  // the warm traces start from the reference run's equilibrium of this iteration
  std::vector<EnergyTrace> traces;  // Newton, L-BFGS cold; Newton, L-BFGS warm
  double e_cold = kStudyNaN, e_warm = kStudyNaN, scale_cold = kStudyNaN, scale_warm = kStudyNaN;
  std::vector<PullRow> pull;
  int evaluation_frames = 0;
  std::vector<FramesRow> frame_rows;
  std::string frames_skipped;  // why there are no frame rows
};

// Runs the study (minutes with `quick`, about fifty minutes on arm flexion on two cores; progress on
// stderr). Errors: the work folder or the scene cannot be made.
Result<AccuracyStudy> RunAccuracyStudy(const AccuracyStudyOptions& options);

// Writes ACCURACY.md, runs.csv, traces.csv, pull_test.csv, frames.csv, accuracy_time.svg and
// newton_lbfgs.svg into `dir`; ACCURACY.md links its plots as `image_prefix` + file name. Its header
// says the command, the date and the machine (MachineLine). Errors: a file cannot be written.
Status WriteAccuracyReport(const AccuracyStudy& study, const std::string& dir, const std::string& image_prefix);

}  // namespace kgd::study
