// What the accuracy of a design iteration's re-solve changes in BESO's decisions: along a design run
// of each scene (the scene's own solver settings), at every STRIDE-th iteration the iteration's solve
// is repeated from the same start (the previous iteration's equilibrium, the iteration's design, a
// fresh factorization) with other stopping rules, and each solve's next design (the update the loop
// makes from that equilibrium: sensitivities, filter, temporal averaging, ranking) is compared with
// the one a tight solve (grad_tol 1e-8) gives. Per rule: the garment area share whose next design
// differs from the tight solve's (mean and largest over the samples), Newton iterations, global
// factorizations and wall seconds per solve (the machine's own kernels).
//   build/bench/decision_benchmark [--stride N] [SCENE ...]   (default: arm_flexion knee_flexion slouch)
// One JSON line per scene and rule on stdout. Single-motion scenes without design constraints.
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <memory>
#include <string>
#include <vector>

#include "core/beso/design_loop.h"
#include "core/scene/builtin_scenes.h"
#include "core/scene/scene.h"
#include "core/scene/simulate.h"

namespace kgd {
namespace {

struct Rule {
  std::string name;
  double tol_factor = 1;  // times the scene's grad_tol
  int max_newton = 0;     // 0: to the tolerance
};

struct Tally {
  double changed_sum = 0, changed_max = 0, newton = 0, factorizations = 0, seconds = 0;
  int samples = 0;
};

int Main(int argc, char** argv) {
  int stride = 10;
  std::vector<std::string> scenes;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--stride" && i + 1 < argc) stride = std::max(1, std::atoi(argv[++i]));
    else scenes.push_back(a);
  }
  if (scenes.empty()) scenes = {"arm_flexion", "knee_flexion", "slouch"};
  const std::vector<Rule> rules = {{"tight 1e-8", 0, 0},  {"grad_tol", 1, 0},  {"3 grad_tol", 3, 0}, {"10 grad_tol", 10, 0},
                                   {"20 grad_tol", 20, 0}, {"30 grad_tol", 30, 0}, {"2 newton", 1, 2}};
  for (const std::string& name : scenes) {
    Result<SceneSpec> loaded = BuiltinScene(name);
    if (!loaded.ok()) {
      std::fprintf(stderr, "%s: %s\n", name.c_str(), loaded.message().c_str());
      return 1;
    }
    const SceneSpec& scene = *loaded;
    Result<GarmentModel> model = BuildGarmentModel(scene);
    if (!model.ok()) {
      std::fprintf(stderr, "%s: %s\n", name.c_str(), model.message().c_str());
      return 1;
    }
    GarmentSystem sys(std::move(model).value(), scene.initial);
    const int nf = static_cast<int>(scene.garment.faces.rows());
    const int nv = static_cast<int>(scene.garment.vertices.rows());
    Eigen::VectorXd area(nf);
    for (int f = 0; f < nf; ++f) area[f] = sys.rest_areas_m2()[f];
    const double total_area = area.sum();
    BesoSettings settings;
    settings.budget = scene.budget;
    const double final_area = settings.budget * total_area;
    const Positions& reference = scene.on_body.rows() ? scene.on_body : scene.initial;
    auto next_design = [&](const Eigen::VectorXd& density, const BesoIteration& b) {
      const Eigen::VectorXd s = Sensitivities(density, b.design, scene.reinforced.youngs_modulus_Pa, scene.cloth.youngs_modulus_Pa,
                                              settings.d_min, settings.penalty);
      const Eigen::VectorXd filtered = AverageSensitivities(FilterSensitivities(s, scene.garment.faces, nv, area), b.sensitivity);
      return UpdateDesign(filtered, area, b.design, NextTargetArea(b.target_area_m2, final_area, settings.evolutionary_ratio),
                          settings.admission_ratio * total_area);
    };
    std::vector<Tally> tally(rules.size());
    // One simulator per rule (its symbolic analysis kept), each solve from a fresh factorization as the loop's.
    std::vector<std::unique_ptr<Simulator>> sims;
    for (size_t r = 0; r < rules.size(); ++r) sims.push_back(std::make_unique<Simulator>(&sys));
    Positions start;
    Result<std::vector<BesoIteration>> run = RunBeso(scene, settings, [&](const BesoIteration& b) {
      if (b.iteration > 0 && b.iteration % stride == 0) {
        std::vector<uint8_t> tight;
        for (size_t r = 0; r < rules.size(); ++r) {
          SolverSettings solver = scene.solver;
          if (rules[r].tol_factor == 0) {
            solver.grad_tol = 1e-8;
            solver.max_iterations = 2000;
          } else {
            solver.grad_tol *= rules[r].tol_factor;
          }
          if (rules[r].max_newton > 0) {
            solver.max_iterations = rules[r].max_newton;
            solver.accept_iteration_limit = true;
          }
          sys.SetDesign(b.design);
          Simulator& sim = *sims[r];
          sim.ResetFactorization();
          Positions x = start;
          const auto t0 = std::chrono::steady_clock::now();
          const SolveReport report = SolveLagged(sim, sys, &x, solver);
          const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
          if (!report.at_equilibrium()) {
            std::fprintf(stderr, "%s iteration %d, %s: %s\n", name.c_str(), b.iteration, rules[r].name.c_str(), ToString(report.status));
            continue;
          }
          const std::vector<uint8_t> d = next_design(Summarize(sys, x, reference, report).face_density_Pa, b);
          if (r == 0) tight = d;
          double changed = 0;
          for (int f = 0; f < nf; ++f) changed += d[f] != tight[f] ? area[f] : 0.0;
          changed /= total_area;
          Tally& t = tally[r];
          t.changed_sum += changed;
          t.changed_max = std::max(t.changed_max, changed);
          t.newton += report.iterations;
          t.factorizations += report.factorizations;
          t.seconds += seconds;
          ++t.samples;
        }
      }
      start = b.positions;
      return true;
    });
    if (!run.ok()) {
      std::fprintf(stderr, "%s: %s\n", name.c_str(), run.message().c_str());
      return 1;
    }
    for (size_t r = 0; r < rules.size(); ++r) {
      const Tally& t = tally[r];
      const double n = std::max(1, t.samples);
      std::printf("{\"scene\":\"%s\",\"rule\":\"%s\",\"samples\":%d,\"changed_area_share_mean\":%.5f,\"changed_area_share_max\":%.5f,"
                  "\"newton_per_solve\":%.2f,\"factorizations_per_solve\":%.2f,\"seconds_per_solve\":%.4f}\n",
                  name.c_str(), rules[r].name.c_str(), t.samples, t.changed_sum / n, t.changed_max, t.newton / n, t.factorizations / n,
                  t.seconds / n);
      std::fflush(stdout);
    }
  }
  return 0;
}

}  // namespace
}  // namespace kgd

int main(int argc, char** argv) { return kgd::Main(argc, argv); }
