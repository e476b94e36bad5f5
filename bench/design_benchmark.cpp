// BESO benchmarks: the paper's arm flexion (7,062-vertex sleeve) and slouch (16,880-vertex shirt; 28,815
// vertices on a 1 cm body mesh, the paper's size) on the built-in parametric body. Time per BESO
// iteration broken down into simulation, sensitivities, filter, design update and HDF5 writing; the
// whole arm-flexion and paper-sized slouch runs to convergence.
// Run: build/bench/design_benchmark (the whole runs take minutes); figures go to docs/PERFORMANCE.md.
#include <benchmark/benchmark.h>

#include <chrono>
#include <cmath>
#include <filesystem>

#include "core/beso/design_loop.h"
#include "core/scene/paper_scenes.h"
#include "store/design_file.h"
#include "core/scene/builtin_scenes.h"

namespace kgd {
namespace {

// Runs BESO on a built-in scene for at most `iterations` (0: to convergence), writing every iteration
// to an HDF5 design file, and reports the mean cost per iteration after the first (the fully
// reinforced solve from the body surface is a cold start; the others are warm).
// `body`: the parametric body's measurements, null for the default body.
void RunDesign(benchmark::State& state, const std::string& name, int iterations, const BodyMeasurements* body = nullptr) {
  Result<SceneSpec> scene = body ? BuiltinScene(name, *body) : BuiltinScene(name);
  if (!scene.ok()) {
    state.SkipWithError(scene.message().c_str());
    return;
  }
  BesoSettings settings;
  settings.budget = scene->budget;
  if (iterations > 0) settings.max_iterations = iterations;
  DesignFileHeader header;
  header.scene = name;
  header.settings = settings;
  header.garment = scene->garment;
  header.initial = scene->initial;
  header.rest_area_m2 = FaceAreas(scene->garment.vertices, scene->garment.faces);
  header.attachment_faces = scene->attachment_faces;
  const std::string path = (std::filesystem::temp_directory_path() / ("kgd_bench_" + name + ".h5")).string();
  double sim = 0, sens = 0, filter = 0, update = 0, write = 0, total = 0, first = 0, whole = 0;
  int n = 0, newton = 0;
  double ratio = 0, area = 0;
  for (auto _ : state) {
    auto writer = DesignFileWriter::Create(path, header);
    if (!writer.ok()) {
      state.SkipWithError(writer.message().c_str());
      return;
    }
    const auto t0 = std::chrono::steady_clock::now();
    Result<std::vector<BesoIteration>> run = RunBeso(*scene, settings, [&](const BesoIteration& it) {
      const auto w0 = std::chrono::steady_clock::now();
      const Status st = (*writer)->Append(it);
      const double w = std::chrono::duration<double>(std::chrono::steady_clock::now() - w0).count();
      if (it.iteration == 0) {
        first = it.total_s + w;
      } else {
        sim += it.simulation_s;
        sens += it.sensitivity_s;
        filter += it.filter_s;
        update += it.update_s;
        write += w;
        total += it.total_s + w;
        newton += it.solver_iterations;
        ++n;
      }
      ratio = it.density_ratio;
      area = it.area_fraction;
      return st.ok();
    });
    whole = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    if (!run.ok()) {
      state.SkipWithError(run.message().c_str());
      return;
    }
  }
  std::filesystem::remove(path);
  const double k = n > 0 ? 1.0 / n : 0.0;
  state.counters["iterations"] = n + 1;
  state.counters["first_s"] = first;
  state.counters["per_iter_s"] = total * k;
  state.counters["sim_s"] = sim * k;
  state.counters["sens_ms"] = 1e3 * sens * k;
  state.counters["filter_ms"] = 1e3 * filter * k;
  state.counters["update_ms"] = 1e3 * update * k;
  state.counters["hdf5_ms"] = 1e3 * write * k;
  state.counters["newton_per_iter"] = newton * k;
  state.counters["run_s"] = whole;
  state.counters["density_ratio"] = ratio;
  state.counters["area_fraction"] = area;
  state.counters["vertices"] = static_cast<double>(scene->garment.vertices.rows());
}

// Appending one iteration's record to a design file (the server's share of an iteration, with the
// SQLite commit): an arm-flexion-sized garment (7,056 vertices, 13,690 faces), smooth positions and
// energies as a run produces them.
void BM_DesignFileAppend(benchmark::State& state) {
  const int n = 84;
  DesignFileHeader header;
  header.scene = "grid";
  header.garment.vertices.resize(n * n, 3);
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < n; ++j) header.garment.vertices.row(i * n + j) << 0.003 * i, 0.003 * j, 0.0;
  header.garment.faces.resize(2 * (n - 1) * (n - 1), 3);
  int f = 0;
  for (int i = 0; i + 1 < n; ++i)
    for (int j = 0; j + 1 < n; ++j) {
      const int a = i * n + j;
      header.garment.faces.row(f++) << a, a + n, a + 1;
      header.garment.faces.row(f++) << a + 1, a + n, a + n + 1;
    }
  header.initial = header.garment.vertices;
  header.rest_area_m2 = FaceAreas(header.garment.vertices, header.garment.faces);
  const std::string path = (std::filesystem::temp_directory_path() / "kgd_bench_append.h5").string();
  auto writer = DesignFileWriter::Create(path, header);
  if (!writer.ok()) {
    state.SkipWithError(writer.message().c_str());
    return;
  }
  BesoIteration it;
  it.design.assign(f, 1);
  it.positions = header.garment.vertices;
  it.energy_density_Pa.resize(f);
  it.sensitivity.resize(f);
  int k = 0;
  for (auto _ : state) {
    it.iteration = k;
    for (int i = 0; i < it.positions.rows(); ++i) it.positions(i, 2) = 0.01 * std::sin(0.1 * i + 0.01 * k);
    for (int e = 0; e < f; ++e) {
      it.energy_density_Pa[e] = 100.0 + 50.0 * std::cos(0.05 * e + 0.1 * k);
      it.sensitivity[e] = 0.5 * it.energy_density_Pa[e];
    }
    if (k < f) it.design[k] = 0;
    const Status st = (*writer)->Append(it);
    if (!st.ok()) {
      state.SkipWithError(st.message().c_str());
      break;
    }
    ++k;
  }
  writer->reset();
  state.counters["file_MB"] = static_cast<double>(std::filesystem::file_size(path)) / 1e6;
  state.counters["iterations"] = k;
  std::filesystem::remove(path);
}
BENCHMARK(BM_DesignFileAppend)->Unit(benchmark::kMillisecond)->Iterations(150);

void BM_ArmFlexion20(benchmark::State& state) { RunDesign(state, "arm_flexion", 20); }
void BM_ArmFlexionRun(benchmark::State& state) { RunDesign(state, "arm_flexion", 0); }
void BM_Slouch10(benchmark::State& state) { RunDesign(state, "slouch", 10); }
// The paper's slouch shirt has 28.3k vertices; a 1 cm body mesh gives ours 28,815.
void BM_SlouchPaperResolutionRun(benchmark::State& state) {
  BodyMeasurements body;
  body.resolution_m = 0.010;
  RunDesign(state, "slouch", 0, &body);
}
BENCHMARK(BM_ArmFlexion20)->Unit(benchmark::kSecond)->Iterations(1);
BENCHMARK(BM_Slouch10)->Unit(benchmark::kSecond)->Iterations(1);
BENCHMARK(BM_ArmFlexionRun)->Unit(benchmark::kSecond)->Iterations(1);
BENCHMARK(BM_SlouchPaperResolutionRun)->Unit(benchmark::kSecond)->Iterations(1);

}  // namespace
}  // namespace kgd

BENCHMARK_MAIN();
