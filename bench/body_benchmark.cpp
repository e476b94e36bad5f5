// Parametric body and built-in scenes: what a design job pays before its first simulation.
#include <benchmark/benchmark.h>

#include "core/body/parametric_body.h"
#include "core/scene/paper_scenes.h"
#include "core/scene/simulate.h"

namespace kgd {
namespace {

void BM_BuildParametricBody(benchmark::State& state) {
  BodyMeasurements m;
  m.resolution_m = state.range(0) / 1000.0;
  for (auto _ : state) {
    Result<ParametricBody> b = BuildParametricBody(m);
    if (!b.ok()) state.SkipWithError(b.message().c_str());
    state.counters["vertices"] = b.ok() ? b->rest.vertices.rows() : 0;
  }
}
BENCHMARK(BM_BuildParametricBody)->Arg(13)->Arg(8)->Unit(benchmark::kMillisecond);

// Posing from rest to a built-in motion's deformed pose: arm flexion (elbow 100 degrees) and the crouch.
void BM_PoseBody(benchmark::State& state) {
  static const Result<const ParametricBody*> body = DefaultParametricBody();
  const PaperMotion motion = PaperMotions()[state.range(0)];
  for (auto _ : state) benchmark::DoNotOptimize(PoseBody(**body, motion.pose));
  state.SetLabel(motion.name);
}
BENCHMARK(BM_PoseBody)->Arg(0)->Arg(5)->Unit(benchmark::kMillisecond);

// A built-in scene from nothing (body cached): posing through all frames, cutting the garment.
void BM_PaperScene(benchmark::State& state) {
  static const Result<const ParametricBody*> body = DefaultParametricBody();
  const PaperMotion motion = PaperMotions()[state.range(0)];
  for (auto _ : state) benchmark::DoNotOptimize(PaperScene(**body, motion));
  state.SetLabel(motion.name);
}
BENCHMARK(BM_PaperScene)->DenseRange(0, 6)->Unit(benchmark::kMillisecond)->Iterations(1);

// The fully reinforced garment through all frames of arm flexion and knee flexion.
void BM_SimulateFrames(benchmark::State& state) {
  static const Result<const ParametricBody*> body = DefaultParametricBody();
  Result<SceneSpec> scene = PaperScene(**body, PaperMotions()[state.range(0)]);
  scene->design.assign(scene->design.size(), kReinforced);
  int iterations = 0;
  for (auto _ : state) {
    Result<std::vector<SimulationResult>> r = SimulateFrames(*scene);
    iterations = 0;
    for (const SimulationResult& f : *r) iterations += f.solve.iterations;
  }
  state.counters["vertices"] = scene->garment.vertices.rows();
  state.counters["newton_its"] = iterations;
  state.SetLabel(scene->name);
}
BENCHMARK(BM_SimulateFrames)->Arg(0)->Arg(2)->Unit(benchmark::kMillisecond)->Iterations(1);

}  // namespace
}  // namespace kgd

BENCHMARK_MAIN();
