#include "worker/machine_speed.h"

#include <cstdio>

#include "core/scene/builtin_scenes.h"
#include "job/cost_calibration.h"
#include "job/design_job.h"

namespace kgd::worker {

Result<v1::MachineSpeed> MachineSpeedOfThisMachine() {
  v1::MachineSpeed speed;
  const std::string kept = LocalCostCalibrationFile();
  if (const MachineFactor f = ReadMachineFactor(kept); f.jobs > 0 && f.weight_s > 0) {
    speed.set_predicted_s(f.weight_s);
    speed.set_measured_s(f.factor * f.weight_s);
    speed.set_what("this machine's factor from " + std::to_string(f.jobs) + " design jobs (" + kept + ")");
    return speed;
  }
  // The cost model's kind of work: a design job's iteration 0 (the cold solve) and a warm iteration after it.
  constexpr const char* kScene = "knee_flexion";
  Result<SceneSpec> scene = ResolveScene(kScene, {});
  if (!scene.ok()) return scene.status().WithContext("measuring this machine's speed: ");
  v1::OptimizerSettings optimizer;
  optimizer.set_max_iterations(1);
  optimizer.set_quality("standard");
  const int faces = static_cast<int>(scene->garment.faces.rows());
  Result<DesignJob> job = NewDesignJob(std::move(scene).value(), optimizer, kScene, "");
  if (!job.ok()) return job.status().WithContext("measuring this machine's speed: ");
  double measured_s = 0;
  int iterations = 0;
  Result<std::vector<BesoIteration>> run = RunDesignJob(*job, [&](const BesoIteration& it) {
    measured_s += it.total_s;
    ++iterations;
    return true;
  });
  if (!run.ok()) return run.status().WithContext("measuring this machine's speed: ");
  const double predicted_s = PredictedSolvesSeconds(faces, Quality::kStandard, iterations - 1);
  RecordDesignTime(kept, predicted_s, measured_s);
  speed.set_predicted_s(predicted_s);
  speed.set_measured_s(measured_s);
  speed.set_what(std::string(kScene) + ", iterations 0-" + std::to_string(iterations - 1));
  return speed;
}

}  // namespace kgd::worker
