// What a looser tolerance for the design iterations' re-solves (BesoSettings::resolve_tolerance_factor)
// costs in design quality and buys in time: each built-in scene designed with the factor 1 (every
// re-solve at the scene's grad_tol) and with the others given (default 20), in one process
// (the machine's own kernels, as the other benchmarks). Per run: iterations, the median and mean wall
// time of the iterations after 0, Newton iterations per iteration, the final density ratio as the run
// found it and tight (the final design re-solved at 1e-8 over the fully reinforced garment's, both
// tight: study::TightDensity, as docs/ACCURACY.md), and the area share of faces whose final design
// differs from factor 1's.
// --repeat adds a run at factor 1 from the scene's start moved by at most 1 nm: the same accuracy on
// another round-off path, what any two runs differ by anyway.
//   build/bench/tolerance_benchmark [--factors 1,20] [--repeat] [SCENE ...]   (default: every built-in scene)
// One JSON line per run on stdout.
#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <sstream>
#include <string>
#include <vector>

#include "core/beso/design_loop.h"
#include "core/scene/builtin_scenes.h"
#include "core/scene/paper_scenes.h"
#include "core/scene/scene.h"
#include "study/accuracy_study.h"

namespace kgd {
namespace {

double Median(std::vector<double> v) {
  if (v.empty()) return 0.0;
  std::sort(v.begin(), v.end());
  const size_t n = v.size();
  return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

int Main(int argc, char** argv) {
  std::vector<double> factors = {1.0, 20.0};
  std::vector<std::string> scenes;
  bool repeat = false;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--repeat") {
      repeat = true;
    } else if (a == "--factors" && i + 1 < argc) {
      factors.clear();
      std::stringstream ss(argv[++i]);
      for (std::string f; std::getline(ss, f, ',');) factors.push_back(std::atof(f.c_str()));
    } else {
      scenes.push_back(a);
    }
  }
  if (scenes.empty()) scenes = BuiltinSceneNames();
  for (const std::string& name : scenes) {
    Result<SceneSpec> scene = BuiltinScene(name);
    if (!scene.ok()) {
      std::fprintf(stderr, "%s: %s\n", name.c_str(), scene.message().c_str());
      return 1;
    }
    const int nf = static_cast<int>(scene->garment.faces.rows());
    const Eigen::VectorXd area = FaceAreas(scene->garment.vertices, scene->garment.faces);
    const double full_tight = study::TightDensity(*scene, std::vector<uint8_t>(nf, kReinforced));
    std::vector<uint8_t> reference;
    std::vector<double> runs = factors;
    if (repeat) runs.push_back(-1);  // factor 1, the start moved
    for (double factor : runs) {
      BesoSettings settings;
      settings.budget = scene->budget;
      settings.resolve_tolerance_factor = factor < 0 ? 1.0 : factor;
      SceneSpec start = *scene;
      if (factor < 0) study::MoveStartByANanometre(&start);
      std::vector<double> later;
      int newton = 0;
      Result<std::vector<BesoIteration>> run = RunBeso(start, settings, [&](const BesoIteration& it) {
        if (it.iteration > 0) {
          later.push_back(it.total_s);
          newton += it.solver_iterations;
        }
        return true;
      });
      if (!run.ok() || run->empty()) {
        std::printf("{\"scene\":\"%s\",\"factor\":%g,\"start_moved\":%s,\"error\":\"%s\"}\n", name.c_str(), settings.resolve_tolerance_factor,
                    factor < 0 ? "true" : "false", run.ok() ? "no iterations" : run.message().c_str());
        std::fflush(stdout);
        continue;
      }
      const BesoIteration& last = run->back();
      if (reference.empty()) reference = last.design;
      double changed = 0;
      for (int f = 0; f < nf; ++f) changed += reference[f] != last.design[f] ? area[f] : 0.0;
      const double tight = study::TightDensity(*scene, last.design) / full_tight;
      double mean = 0;
      for (double s : later) mean += s;
      mean /= std::max<size_t>(1, later.size());
      std::printf("{\"scene\":\"%s\",\"factor\":%g,\"start_moved\":%s,\"iterations\":%d,\"median_s\":%.5f,\"mean_s\":%.5f,\"newton_per_iteration\":%.3f,"
                  "\"ratio_run\":%.6f,\"ratio_tight\":%.6f,\"changed_area_share\":%.5f}\n",
                  name.c_str(), settings.resolve_tolerance_factor, factor < 0 ? "true" : "false", last.iteration, Median(later), mean, later.empty() ? 0.0 : double(newton) / later.size(),
                  last.density_ratio, tight, changed / area.sum());
      std::fflush(stdout);
    }
  }
  return 0;
}

}  // namespace
}  // namespace kgd

int main(int argc, char** argv) { return kgd::Main(argc, argv); }
