#include "client/design_command.h"

#include "core/beso/quality.h"

#include "client/service_commands.h"
#include "job/cost_calibration.h"
#include "job/fabrication_export.h"

#include <unistd.h>

#include <atomic>
#include <csignal>
#include <cmath>
#include <cstdio>
#include <optional>
#include <filesystem>
#include <iostream>
#include <limits>
#include <memory>
#include <nlohmann/json.hpp>
#include <sstream>

#include "client/metrics_json.h"
#include "client/out_of_memory.h"
#include "client/optimizer_flags.h"
#include "client/simulate_command.h"
#include "proto/job_spec.h"
#include "proto/records.h"
#include "core/beso/baselines.h"
#include "job/design_job.h"
#include "core/beso/design_loop.h"
#include "core/mesh/mesh_io.h"
#include "core/scene/body_garment.h"
#include "core/scene/simulate.h"
#include "core/util/pinned_kernels.h"
#include "store/design_file.h"
#include "core/scene/builtin_scenes.h"

namespace kgd::cli {
namespace {

std::atomic<bool> g_interrupted{false};
extern "C" void OnInterrupt(int) { g_interrupted = true; }

struct DesignOptions {
  std::string scene;
  std::vector<std::string> body;
  std::string out;
  std::string resume;
  OptimizerFlags optimizer;
  bool json = false, verbose = false, evaluate = false, overwrite = false;
};

// Exit codes beyond 0 (done), 2 (bad input or usage), 3 (the run failed) and 130 (interrupted):
// the design could not be stored (a full disk, an I/O error, another writer), or a file read is damaged.
constexpr int kExitStorage = 4;
constexpr int kExitDamaged = 5;

std::string Duration(double s) {
  char buf[32];
  if (s < 60) std::snprintf(buf, sizeof buf, "%.0fs", s);
  else if (s < 3600) std::snprintf(buf, sizeof buf, "%dm%02ds", static_cast<int>(s) / 60, static_cast<int>(s) % 60);
  else std::snprintf(buf, sizeof buf, "%dh%02dm", static_cast<int>(s) / 3600, static_cast<int>(s) % 3600 / 60);
  return buf;
}

int Fail(const char* command, const std::string& message, int code = 2) {
  std::cerr << "kgd " << command << ": " << message << "\n";
  return code;
}

// A design file that could not be read: exit 5 when it is damaged (an iteration, its header or the
// HDF5 structure), 2 otherwise (no such file, not a design file, an iteration it does not hold).
int FailReading(const char* command, const std::string& message) {
  for (const char* damage : {" is damaged", " are damaged", "(damaged", "inconsistent shapes", "cannot open the HDF5 file"})
    if (message.find(damage) != std::string::npos) return Fail(command, message, kExitDamaged);
  return Fail(command, message);
}

// One line per motion of a scene with several: role, weight, reinforced energy and density ratio.
void PrintMotions(const BesoIteration& it) {
  for (const MotionMetrics& m : it.motions)
    std::printf("  motion %-16s %-6s weight %-5.3g reinforced energy %.4g J, density ratio %.3f\n", m.name.c_str(), ToString(m.role), m.weight,
                m.reinforced_energy_J, m.density_ratio);
}

// A design file's designs repeat, and its scene rebuilds as stored, only at the kernels they were computed
// with (core/util/pinned_kernels.h). When this process runs another level, the program runs again at the
// file's (`writer`, when given, closed first) and this returns only with an error, which names the level
// where the machine cannot run it; a file of native or unpinned kernels goes on with a warning. `doing`
// says what the command does with the file ("resuming it", "simulating its designs", ...).
Status RunAtKernelsOf(const std::string& path, const std::string& kernels, const std::string& doing,
                      std::unique_ptr<DesignFileWriter>* writer = nullptr) {
  const std::string running = RunningKernels();
  if (kernels == running || running == kKernelsNative) return Status::Ok();
  if (kernels != kKernelsX8664 && kernels != kKernelsX8664V3) {
    std::fprintf(stderr, "kgd: warning: %s was computed with %s kernels: %s it here may differ from the machine it ran on\n", path.c_str(),
                 kernels.c_str(), doing.c_str());
    return Status::Ok();
  }
  const bool can = kernels == MachineKernelLevel() || kernels == kKernelsX8664;
  if (can) {
    std::fprintf(stderr, "kgd: %s was computed with the %s kernels; %s with them\n", path.c_str(), kernels.c_str(), doing.c_str());
    if (writer) writer->reset();
  }
  const Status s = PinNumericKernelsTo(kernels);
  if (can || s.ok()) return s.WithContext(path + ": ");
  return Status::Error(path + ": computed with the " + kernels + " kernels, and " + s.message() + ": " + doing +
                       " here would not repeat them; do it on an " + kernels + " machine" +
                       (std::getenv("KGD_KERNELS") ? ", or without KGD_KERNELS" : ""));
}

int RunDesign(const DesignOptions& o) {
  const bool resume = !o.resume.empty();
  const v1::OptimizerSettings optimizer = ToProto(o.optimizer);
  if (resume && (AnyDesignFlagGiven(o.optimizer) || !o.body.empty() || !o.out.empty() || o.overwrite))
    return Fail("design", "--resume continues the stored job with its own settings (its solves' quality too); only --iterations may be given with it");
  if (!resume && o.scene.empty()) return Fail("design", "give a scene (a built-in name or a scene file), or --resume FILE");
  if (resume && !o.scene.empty()) return Fail("design", "give either a scene or --resume FILE, not both");

  Result<DesignJob> job = Status::Error("");
  std::unique_ptr<DesignFileWriter> writer;
  std::string path;
  if (resume) {
    path = o.resume;
    // Reopened first: a file left by a killed run is rebuilt from its intact iterations before any is read.
    Result<std::unique_ptr<DesignFileWriter>> w = DesignFileWriter::Reopen(path);
    if (!w.ok()) {
      const std::string& e = w.message();
      const auto has = [&e](const char* what) { return e.find(what) != std::string::npos; };
      if (has(": no such file") || has("not an HDF5 file") || has("not a kgd design file") || has("format_version")) return Fail("design", e);
      if (has("/garment") || has("/job "))
        return Fail("design", e + ": the file's header (its job and garment) is damaged, so none of its iterations can be kept; run the job again",
                    kExitDamaged);
      return Fail("design", e, kExitStorage);
    }
    writer = std::move(w).value();
    if (!writer->repair_note().empty()) std::fprintf(stderr, "kgd design: %s: %s\n", path.c_str(), writer->repair_note().c_str());
    const int n = writer->num_iterations();
    Result<DesignFile> file = ReadDesignFile(path, {.arrays = true, .only_iteration = n - 1});
    if (!file.ok()) return Fail("design", file.message());
    if (Status s = RunAtKernelsOf(path, file->header.kernels, "resuming it", &writer); !s.ok()) return Fail("design", s.message());
    Result<SceneSpec> scene = RebuildSceneOfDesignFile(path, file->header);
    if (!scene.ok()) return Fail("design", scene.message());
    job = ResumeDesignJob(std::move(scene).value(), std::move(file->header), std::move(file->iterations), path,
                          optimizer.has_max_iterations() ? optimizer.max_iterations() : 0);
    if (!job.ok()) return Fail("design", job.message());
    // The file reads as the job now runs: its new iteration limit.
    if (optimizer.has_max_iterations())
      if (Status s = writer->SetSettings(job->header.settings); !s.ok()) return Fail("design", s.message());
  } else {
    Result<SceneSpec> scene = ResolveScene(o.scene, o.body);
    if (!scene.ok()) return Fail("design", scene.message());
    const std::string name = scene->name;
    job = NewDesignJob(std::move(scene).value(), optimizer,
                       std::filesystem::exists(o.scene) ? std::filesystem::absolute(o.scene).string() : o.scene, JoinWords(o.body));
    if (!job.ok()) return Fail("design", job.message());
    path = o.out.empty() ? name + ".h5" : o.out;
    if (std::error_code ec; std::filesystem::exists(path, ec) && !o.overwrite)
      return Fail("design", path + " exists: --overwrite replaces it, --resume " + path + " continues the job it holds");
    Result<std::unique_ptr<DesignFileWriter>> w = DesignFileWriter::Create(path, job->header);
    if (!w.ok()) return Fail("design", w.message(), kExitStorage);
    writer = std::move(w).value();
  }
  SceneSpec& scene = job->scene;
  if (o.verbose) scene.solver.diagnose_steps = true;
  if (o.verbose)
    scene.solver.on_iteration = [](const IterationInfo& i) {
      std::fprintf(stderr, "  newton %4d  %s\n", i.iteration, DescribeIteration(i).c_str());
    };
  const BesoSettings& settings = job->settings();
  const bool bar = !o.json && isatty(STDOUT_FILENO);
  g_interrupted = false;
  InstallOutOfMemoryReserve();
  ReportUnexpectedExit("kgd design", "the iterations stored before are in " + path + "; continue with: kgd design --resume " + path);
  std::signal(SIGINT, OnInterrupt);
  std::signal(SIGTERM, OnInterrupt);

  // What the job should take (core/beso/quality.h) on this machine, before it starts.
  const Quality quality = QualityOfJob(optimizer.quality());
  const int garment_faces = static_cast<int>(scene.garment.faces.rows());
  const int simulations = static_cast<int>(MotionsOf(scene).size());
  const JobCostPrediction cost = PredictJobCost({.garment_faces = garment_faces,
                                                 .frames = 0,  // the scene is built: its set-up is spent
                                                 .builtin_body = false,
                                                 .quality = quality,
                                                 .simulations = simulations},
                                                settings);
  const MachineFactor machine = ReadMachineFactor(LocalCostCalibrationFile());
  const double predicted_s = machine.factor * cost.solves_s(cost.iterations);
  if (!o.json && !resume) {
    // The frames of every motion (or body) the job weighs, as `kgd scenes` counts them.
    int frames = 0;
    for (const SceneMotion& m : MotionsOf(scene)) frames += static_cast<int>(m.pose.frames.size());
    char calibrated[96];
    if (machine.jobs > 0) std::snprintf(calibrated, sizeof calibrated, "; this machine: %.2fx the reference, from %d jobs", machine.factor, machine.jobs);
    else std::snprintf(calibrated, sizeof calibrated, "; the reference machine's until a job finishes here");
    std::printf("design %s -> %s (budget %.3g, %s, %d frames): predicted about %.0f s (%d iteration%s of %.3f s%s)\n", scene.name.c_str(),
                path.c_str(), settings.budget, PresetOf(quality).name, frames, predicted_s, cost.iterations, cost.iterations == 1 ? "" : "s",
                machine.factor * cost.per_iteration_s, calibrated);
  } else if (!bar && !o.json) {
    std::printf("design %s -> %s (budget %.3g)\n", scene.name.c_str(), path.c_str(), settings.budget);
  }
  // A collapsed (or swollen) posed body understates (or overstates) what the design resists: say so first.
  if (!o.json && !resume && scene.motion)
    if (const std::optional<BodyVolumeChange> v = MotionVolumeChange(*scene.motion))
      if (const std::string note = BodyVolumeNote(*v); !note.empty())
        std::printf("note: %s; body volume %s\n", note.c_str(), DescribeBodyVolume(*v).c_str());
  Status write_status = Status::Ok();
  std::vector<double> recent;  // seconds of the last iterations, for the ETA
  double elapsed = 0;
  // Metrics of every iteration stored (arrays are not needed for the summary and the stop reason).
  std::vector<BesoIteration> metrics;
  for (const BesoIteration& it : job->history) metrics.push_back(MetricsOnly(it));
  // Iteration 0 and the last with their arrays, for --evaluate.
  std::optional<BesoIteration> first, last;
  auto on_iteration = [&](const BesoIteration& it) {
    if (o.evaluate) {
      if (it.iteration == 0) first = it;
      last = it;
    }
    write_status = writer->Append(it);
    elapsed += it.total_s;
    recent.push_back(it.total_s);
    if (recent.size() > 8) recent.erase(recent.begin());
    double mean = 0;
    for (double t : recent) mean += t;
    mean /= recent.size();
    const int left = IterationsLeft(*job, it);
    if (bar) {
      const double done = 1.0 - static_cast<double>(left) / (it.iteration + left);
      const int width = 24, filled = static_cast<int>(done * width);
      std::printf("\r[%s%s] it %3d  area %5.1f%%  ratio %.3f  %.2f s/it  ETA %-7s", std::string(filled, '#').c_str(),
                  std::string(width - filled, '.').c_str(), it.iteration, 100 * it.area_fraction, it.density_ratio, mean,
                  Duration(left * mean).c_str());
    } else {
      nlohmann::ordered_json j = MetricsJson(MetricsToProto(it));
      j["eta_s"] = left * mean;
      std::printf("%s\n", j.dump().c_str());
    }
    std::fflush(stdout);
    metrics.push_back(MetricsOnly(it));
    return write_status.ok() && !g_interrupted && !OutOfMemory();
  };
  const Result<std::vector<BesoIteration>> run = RunDesignJob(*job, on_iteration);
  std::signal(SIGINT, SIG_DFL);
  std::signal(SIGTERM, SIG_DFL);
  if (bar) std::printf("\n");
  if (!write_status.ok())
    return Fail("design", write_status.message() + "; once there is room, continue with: kgd design --resume " + path, kExitStorage);
  if (OutOfMemory())
    return Fail("design", "out of memory: stopped after iteration " + std::to_string(metrics.empty() ? -1 : metrics.back().iteration) +
                              ", which is stored in " + path + "; continue with: kgd design --resume " + path,
                kExitStorage);
  // Refused before its first iteration (the scene or the settings: a garment that is not symmetric, a
  // pressure limit the cloth garment already breaks): bad input; the new file holds no iteration and goes.
  if (!run.ok() && metrics.empty()) {
    writer.reset();
    if (!resume) {
      std::error_code ec;
      std::filesystem::remove(path, ec);
    }
    return Fail("design", run.message(), 2);
  }
  if (!run.ok()) return Fail("design", run.message() + " (iterations so far are in " + path + ")", 3);
  const BesoIteration end = metrics.empty() ? BesoIteration{} : metrics.back();
  if (g_interrupted) {
    std::fprintf(stderr, "kgd design: stopped after iteration %d; continue with: kgd design --resume %s\n", end.iteration, path.c_str());
    return 130;
  }
  std::string evaluation_path;
  if (o.evaluate) {
    // A resumed run that stored no new iteration reads its first and last back from the file.
    if (!first || !last) {
      Result<DesignFile> f0 = ReadDesignFile(path, {.arrays = true, .only_iteration = 0});
      Result<DesignFile> fl = ReadDesignFile(path, {.arrays = true, .only_iteration = end.iteration});
      if (!f0.ok()) return Fail("design", f0.message());
      if (!fl.ok()) return Fail("design", fl.message());
      if (!first) first = f0->iterations.front();
      if (!last) last = fl->iterations.back();
    }
    Result<DesignEvaluation> e = EvaluateDesign(*job, *first, *last);
    if (!e.ok()) return Fail("design", e.message() + " (the design is in " + path + ")", 3);
    evaluation_path = EvaluationPath(path);
    if (Status st = WriteDesignEvaluation(evaluation_path, *e); !st.ok()) return Fail("design", st.message());
  }
  const BesoEnd how = BesoEndOf(metrics, settings, job->header.rest_area_m2.sum());
  const std::string why = DescribeBesoEnd(how, metrics, settings);
  // A whole job teaches the cost model this machine's speed (a resumed one ran only part of it).
  if (!resume && end.iteration >= 1) RecordDesignTime(LocalCostCalibrationFile(), PredictedSolvesSeconds(garment_faces, quality, end.iteration, simulations), elapsed);
  if (o.json || !bar) {
    nlohmann::ordered_json j{{"event", "done"}, {"file", path}, {"iterations", end.iteration + 1}, {"area_fraction", end.area_fraction},
                             {"density_ratio", end.density_ratio}, {"seconds", elapsed}, {"end", why}};
    j["motions"] = MotionsJson(end.motions);
    if (settings.max_pressure_Pa > 0) j["peak_pressure_Pa"] = end.peak_pressure_Pa, j["max_pressure_Pa"] = settings.max_pressure_Pa;
    if (!resume) j["predicted_s"] = predicted_s, j["machine_factor"] = machine.factor, j["machine_factor_jobs"] = machine.jobs;
    if (!evaluation_path.empty()) j["evaluation"] = evaluation_path;
    std::printf("%s\n", j.dump().c_str());
  } else if (how == BesoEnd::kNothingToResist) {
    std::printf("done: stopped at iteration 0, %s; wrote %s\n", why.c_str(), path.c_str());
  } else {
    std::printf("done: %d iterations (%s), area %.1f%%, reinforced energy density %.4g J/m^2 = %.3f x fully reinforced, %s; wrote %s\n",
                end.iteration + 1, why.c_str(), 100 * end.area_fraction, end.reinforced_density_J_per_m2, end.density_ratio,
                Duration(elapsed).c_str(), path.c_str());
    if (end.motions.size() > 1) PrintMotions(end);
    if (settings.max_pressure_Pa > 0)
      std::printf("  skin pressure peak %.3g kPa over the resisted motions' deformed poses (limit %.4g kPa); the limit keeps %.1f %% of the garment cloth\n",
                  1e-3 * end.peak_pressure_Pa, 1e-3 * settings.max_pressure_Pa, 100 * end.pressure_kept_out_fraction);
  }
  if (!evaluation_path.empty() && bar) std::printf("evaluation (the design over the motion, Line and X beside it): %s\n", evaluation_path.c_str());
  return 0;
}

// What a damaged design file still holds, for the message that refuses to serve it.
std::string DescribeDamage(const std::string& path, const DesignFileCheck& c) {
  std::string kept = c.intact == 0 ? "no iteration before it is intact"
                                   : "iterations 0.." + std::to_string(c.intact - 1) + " are intact (`kgd design --resume " + path +
                                         "` rebuilds the file from them and continues; the damaged file is kept beside it)";
  return c.first_damage + "; " + std::to_string(c.damaged.size()) + " of " + std::to_string(c.iterations) + " iterations damaged; " + kept;
}

// `kgd check FILE...`: every iteration of each design file read back whole, checksums verified.
int RunCheck(const std::vector<std::string>& paths, bool json) {
  int code = 0;
  nlohmann::ordered_json all = nlohmann::ordered_json::array();
  for (const std::string& path : paths) {
    Result<DesignFileCheck> c = CheckDesignFile(path);
    nlohmann::ordered_json j{{"file", path}};
    if (!c.ok()) {
      j["ok"] = false, j["error"] = c.message();
      if (!json) std::printf("%s: unreadable: %s\n", path.c_str(), c.message().c_str());
      code = kExitDamaged;
    } else {
      j["ok"] = c->ok(), j["iterations"] = c->iterations, j["intact"] = c->intact, j["damaged"] = c->damaged;
      if (!c->ok()) j["error"] = c->first_damage;
      if (!json && c->ok()) std::printf("%s: intact, %d iterations (every chunk's checksum verified)\n", path.c_str(), c->iterations);
      if (!json && !c->ok()) std::printf("%s: damaged: %s\n", path.c_str(), DescribeDamage(path, *c).c_str());
      if (!c->ok()) code = kExitDamaged;
    }
    all.push_back(j);
  }
  if (json) std::printf("%s\n", (paths.size() == 1 ? all[0] : all).dump().c_str());
  return code;
}

int RunDesigns(const std::string& path, bool json) {
  // Verified first: a history is printed only when every iteration it lists reads back whole.
  Result<DesignFileCheck> check = CheckDesignFile(path);
  if (!check.ok()) return FailReading("designs", check.message());
  if (!check->ok()) return Fail("designs", DescribeDamage(path, *check), kExitDamaged);
  Result<DesignFile> f = ReadDesignFile(path, {.arrays = false});
  if (!f.ok()) return Fail("designs", f.message());
  const DesignFileHeader& h = f->header;
  if (json) {
    nlohmann::ordered_json j;
    j["scene"] = h.scene;
    j["body"] = h.body;
    j["kernels"] = h.kernels;
    j["grad_tol"] = h.grad_tol;
    j["max_newton_iterations"] = h.max_newton_iterations;
    j["settings"] = nlohmann::json::parse(BesoSettingsToJson(h.settings));
    j["garment_vertices"] = h.garment.vertices.rows();
    j["garment_faces"] = h.garment.faces.rows();
    j["garment_area_m2"] = h.rest_area_m2.sum();
    j["iterations"] = nlohmann::json::array();
    for (const BesoIteration& it : f->iterations) j["iterations"].push_back(MetricsJson(MetricsToProto(it)));
    j["end"] = DescribeBesoEnd(BesoEndOf(f->iterations, h.settings, h.rest_area_m2.sum()), f->iterations, h.settings);
    std::printf("%s\n", j.dump().c_str());
    return 0;
  }
  char tol[64] = "";
  if (h.grad_tol > 0) std::snprintf(tol, sizeof tol, "; solves to grad_tol %g", h.grad_tol);
  std::printf("scene %s%s%s: %ld vertices, %ld faces, %.4g m^2; budget %.3g, ER %.3g, AR_max %.3g, p %.3g, re-solves while shrinking at %gx "
              "the tolerance%s; %s kernels%s\n", h.scene.c_str(), h.body.empty() ? "" : " ", h.body.c_str(), static_cast<long>(h.garment.vertices.rows()),
              static_cast<long>(h.garment.faces.rows()), h.rest_area_m2.sum(), h.settings.budget, h.settings.evolutionary_ratio,
              h.settings.admission_ratio, h.settings.penalty, h.settings.resolve_tolerance_factor,
              h.settings.keep_attachments ? ", attachments kept" : "", h.kernels.c_str(),
              tol);
  std::printf("%5s %8s %8s %12s %12s %12s %7s %6s %8s %8s\n", "iter", "area_%", "target_%", "energy_J", "reinf_J", "density_J/m2",
              "ratio", "newton", "sim_s", "total_s");
  double total = 0;
  for (const BesoIteration& it : f->iterations) {
    std::printf("%5d %8.2f %8.2f %12.6g %12.6g %12.6g %7.3f %6d %8.3f %8.3f\n", it.iteration, 100 * it.area_fraction,
                100 * it.target_area_m2 / h.rest_area_m2.sum(), it.energy_J, it.reinforced_energy_J, it.reinforced_density_J_per_m2,
                it.density_ratio, it.solver_iterations, it.simulation_s, it.total_s);
    total += it.total_s;
  }
  if (!f->iterations.empty() && f->iterations.back().motions.size() > 1) {
    std::printf("motions at iteration %d:\n", f->iterations.back().iteration);
    PrintMotions(f->iterations.back());
  }
  const BesoEnd end = BesoEndOf(f->iterations, h.settings, h.rest_area_m2.sum());
  std::printf("%zu iterations, %s; %s\n", f->iterations.size(), Duration(total).c_str(),
              end == BesoEnd::kRunning ? "not finished (kgd design --resume FILE continues it)"
                                       : ("finished: " + DescribeBesoEnd(end, f->iterations, h.settings)).c_str());
  return 0;
}

// The design of iteration `k` (-1: the last) with the file's scene.
struct StoredDesign {
  DesignFile file;
  SceneSpec scene;
  int iteration = 0;
};
Result<StoredDesign> LoadStoredDesign(const std::string& path, int k) {
  Result<DesignFile> metrics = ReadDesignFile(path, {.arrays = false});
  if (!metrics.ok()) return metrics.status();
  const int n = static_cast<int>(metrics->iterations.size());
  if (n == 0) return Status::Error(path + ": no iterations stored yet");
  if (k < 0) k = n - 1;
  if (k >= n) return Status::Error(path + ": iteration " + std::to_string(k) + " is not stored (0.." + std::to_string(n - 1) + ")");
  KGD_RETURN_IF_ERROR(RunAtKernelsOf(path, metrics->header.kernels, "simulating its designs"));
  Result<DesignFile> f = ReadDesignFile(path, {.arrays = true, .only_iteration = k});
  if (!f.ok()) return f.status();
  Result<SceneSpec> scene = SceneOfDesignFile(path, f->header);
  if (!scene.ok()) return scene.status();
  return StoredDesign{std::move(f).value(), std::move(scene).value(), k};
}

// The stored design on every body of `on` (a scene argument; empty: the design file's own scene):
// density ratio against each body's fully reinforced garment (docs/MODEL.md, "Range of bodies").
int RunEvaluateOnBodies(const StoredDesign& sd, const std::string& path, const std::string& on, bool json) {
  Result<SceneSpec> scene = on.empty() ? Result<SceneSpec>(sd.scene) : ResolveScene(on);
  if (!scene.ok()) return Fail("evaluate", scene.message());
  const Faces& own = sd.scene.garment.faces;
  const Faces& theirs = scene->garment.faces;
  if (own.rows() != theirs.rows() || own.cols() != theirs.cols() || own != theirs)
    return Fail("evaluate", path + " on " + scene->name + ": the design's garment (scene '" + sd.scene.name + "', " + std::to_string(own.rows()) +
                                " faces) is not the garment of scene '" + scene->name + "' (" + std::to_string(theirs.rows()) +
                                " faces, other faces or another order): --on takes a scene of the design's garment");
  const std::vector<uint8_t>& design = sd.file.iterations[sd.iteration].design;
  Result<std::vector<BodyEvaluation>> bodies = EvaluateOnBodies(*scene, design);
  if (!bodies.ok()) return Fail("evaluate", path + " on " + scene->name + ": " + bodies.message());
  nlohmann::ordered_json j;
  j["file"] = path;
  j["iteration"] = sd.iteration;
  j["scene"] = scene->name;
  j["bodies"] = nlohmann::json::array();
  if (!json)
    std::printf("design of iteration %d (%.1f%% reinforced) on the bodies of %s, deformed pose\n%-8s %12s %14s %14s %7s %9s %9s\n", sd.iteration,
                100 * sd.file.iterations[sd.iteration].area_fraction, scene->name.c_str(), "body", "reinf_J", "density_J/m2", "full_J/m2",
                "ratio", "peak_kPa", "p95_kPa");
  double worst = std::numeric_limits<double>::infinity();
  for (const BodyEvaluation& e : *bodies) {
    worst = std::min(worst, e.density_ratio);
    if (json)
      j["bodies"].push_back({{"body", e.name},
                             {"reinforced_energy_J", e.designed.reinforced_energy_J},
                             {"reinforced_density_J_per_m2", e.designed.reinforced_density_J_per_m2},
                             {"full_reinforced_density_J_per_m2", e.full.reinforced_density_J_per_m2},
                             {"density_ratio", e.density_ratio},
                             {"peak_pressure_Pa", e.designed.skin.peak_Pa},
                             {"p95_pressure_Pa", e.designed.skin.p95_Pa}});
    else
      std::printf("%-8s %12.6g %14.6g %14.6g %7.3f %9.3g %9.3g\n", e.name.c_str(), e.designed.reinforced_energy_J,
                  e.designed.reinforced_density_J_per_m2, e.full.reinforced_density_J_per_m2, e.density_ratio, 1e-3 * e.designed.skin.peak_Pa,
                  1e-3 * e.designed.skin.p95_Pa);
  }
  if (json) {
    j["worst_density_ratio"] = worst;
    std::printf("%s\n", j.dump().c_str());
  } else {
    std::printf("worst body: density ratio %.3f\n", worst);
  }
  return 0;
}

int RunEvaluate(const std::string& path, int k, bool json, const std::string& on) {
  Result<StoredDesign> sd = LoadStoredDesign(path, k);
  if (!sd.ok()) return FailReading("evaluate", sd.message());
  if (!on.empty() || !sd->scene.bodies.empty()) return RunEvaluateOnBodies(*sd, path, on, json);
  SceneSpec designed = sd->scene, full = sd->scene;
  designed.design = sd->file.iterations[sd->iteration].design;
  full.design.assign(full.design.size(), kReinforced);
  const bool frames = designed.motion && !designed.motion->frames.empty();
  std::vector<SimulationResult> a, b;
  for (auto [spec, out] : {std::pair{&designed, &a}, std::pair{&full, &b}}) {
    if (frames) {
      Result<std::vector<SimulationResult>> r = SimulateFrames(*spec);
      if (!r.ok()) return Fail("evaluate", r.message());
      *out = std::move(r).value();
    } else {
      Result<SimulationResult> r = SimulateScene(*spec);
      if (!r.ok()) return Fail("evaluate", r.message());
      out->push_back(std::move(r).value());
    }
  }
  bool converged = true;
  nlohmann::ordered_json j;
  j["file"] = path;
  j["iteration"] = sd->iteration;
  j["frames"] = nlohmann::json::array();
  if (!json)
    std::printf("design of iteration %d (%.1f%% reinforced) over %zu frame%s\n%6s %12s %12s %14s %14s %7s %9s %9s\n", sd->iteration,
                100 * sd->file.iterations[sd->iteration].area_fraction, a.size(), a.size() == 1 ? "" : "s", "frame", "energy_J",
                "reinf_J", "density_J/m2", "full_J/m2", "ratio", "peak_kPa", "p95_kPa");
  for (size_t f = 0; f < a.size(); ++f) {
    converged &= a[f].solve.at_equilibrium() && b[f].solve.at_equilibrium();
    const double ratio = b[f].reinforced_density_J_per_m2 > 0 ? a[f].reinforced_density_J_per_m2 / b[f].reinforced_density_J_per_m2 : 0;
    if (json) {
      j["frames"].push_back({{"frame", f + 1},
                             {"status", ToString(a[f].solve.status)},
                             {"energy_J", a[f].solve.energy_J},
                             {"reinforced_energy_J", a[f].reinforced_energy_J},
                             {"reinforced_density_J_per_m2", a[f].reinforced_density_J_per_m2},
                             {"full_reinforced_density_J_per_m2", b[f].reinforced_density_J_per_m2},
                             {"density_ratio", ratio}});
      if (a[f].skin.pressure_Pa.size()) {
        j["frames"].back()["peak_pressure_Pa"] = a[f].skin.peak_Pa;
        j["frames"].back()["p95_pressure_Pa"] = a[f].skin.p95_Pa;
        j["frames"].back()["full_peak_pressure_Pa"] = b[f].skin.peak_Pa;
        j["frames"].back()["full_p95_pressure_Pa"] = b[f].skin.p95_Pa;
      }
    } else {
      std::printf("%6zu %12.6g %12.6g %14.6g %14.6g %7.3f %9.3g %9.3g%s\n", f + 1, a[f].solve.energy_J, a[f].reinforced_energy_J,
                  a[f].reinforced_density_J_per_m2, b[f].reinforced_density_J_per_m2, ratio, 1e-3 * a[f].skin.peak_Pa,
                  1e-3 * a[f].skin.p95_Pa, a[f].solve.at_equilibrium() ? "" : "  (not converged)");
    }
  }
  if (json) std::printf("%s\n", j.dump().c_str());
  return converged ? 0 : 3;
}

int RunBaselines(const std::string& path, int k, double angle_deg, bool angle_given, const std::string& out, bool json) {
  Result<StoredDesign> sd = LoadStoredDesign(path, k);
  if (!sd.ok()) return FailReading("baselines", sd.message());
  const DesignFileHeader& h = sd->file.header;
  Result<DesignFile> first = ReadDesignFile(path, {.arrays = true, .only_iteration = 0});
  if (!first.ok()) return Fail("baselines", first.message());
  const Result<BaselineComparison> cmp =
      CompareWithBaselines(sd->scene, sd->file.iterations[sd->iteration].design,
                           first->iterations[0].energy_density_Pa.cwiseProduct(h.rest_area_m2),
                           angle_given ? std::optional<double>(angle_deg * M_PI / 180) : std::nullopt);
  if (!cmp.ok()) return Fail("baselines", path + ": " + cmp.message());
  struct Row {
    const char* name;
    const std::vector<uint8_t>* design;
    const SimulationResult* result;
  };
  const std::vector<Row> rows = {{"optimized", &sd->file.iterations[sd->iteration].design, &cmp->optimized_result},
                                 {"line", &cmp->line, &cmp->line_result},
                                 {"x", &cmp->x, &cmp->x_result}};
  const double garment_area = h.rest_area_m2.sum();
  nlohmann::ordered_json j;
  j["file"] = path;
  j["iteration"] = sd->iteration;
  j["theta0_deg"] = cmp->theta0_rad * 180 / M_PI;
  if (!json)
    std::printf("iteration %d: reinforced area %.4g m^2 (%.1f%%); bands centred at %.1f deg\n%-10s %8s %14s %14s %13s\n", sd->iteration,
                cmp->area_m2, 100 * cmp->area_m2 / garment_area, cmp->theta0_rad * 180 / M_PI, "design", "area_%", "reinforced_J",
                "density_J/m2", "vs_optimized");
  bool converged = true;
  const double best = cmp->optimized_result.reinforced_energy_J;
  for (const Row& r : rows) {
    const SimulationResult& s = *r.result;
    converged &= s.solve.at_equilibrium();
    if (json) {
      j[r.name] = {{"area_fraction", s.reinforced_area_m2 / garment_area},
                   {"status", ToString(s.solve.status)},
                   {"energy_J", s.solve.energy_J},
                   {"reinforced_energy_J", s.reinforced_energy_J},
                   {"reinforced_density_J_per_m2", s.reinforced_density_J_per_m2}};
    } else {
      std::printf("%-10s %8.2f %14.6g %14.6g %13.3f%s\n", r.name, 100 * s.reinforced_area_m2 / garment_area, s.reinforced_energy_J,
                  s.reinforced_density_J_per_m2, best > 0 ? s.reinforced_energy_J / best : 0.0, s.solve.at_equilibrium() ? "" : "  (not converged)");
    }
    if (!out.empty()) {
      const std::filesystem::path p(out);
      const std::string file = (p.parent_path() / (p.stem().string() + "_" + r.name + ".ply")).string();
      if (Status st = WriteGarmentPly(file, s.positions, h.garment.faces, *r.design, s.face_density_Pa); !st.ok())
        return Fail("baselines", st.message());
    }
  }
  if (json) std::printf("%s\n", j.dump().c_str());
  return converged ? 0 : 3;
}

}  // namespace

void AddDesignCommands(CLI::App& app, int* exit_code) {
  auto o = std::make_shared<DesignOptions>();
  CLI::App* d = app.add_subcommand("design", "Optimize where to reinforce a garment (BESO), locally; writes the history to HDF5");
  d->add_option("scene", o->scene, "Scene file (JSON) or the name of a built-in scene (see `kgd scenes`)");
  d->add_option("--body", o->body, "A measurement of the parametric body, name=value in SI (repeatable)");
  d->add_option("--out", o->out, "Design file to write (default: SCENE.h5 in the current folder)");
  d->add_option("--resume", o->resume, "Continue the job stored in this design file after its last iteration");
  d->add_flag("--overwrite", o->overwrite, "Replace the --out file when it exists (refused without it)");
  AddOptimizerFlags(d, &o->optimizer);
  d->add_flag("-v,--verbose", o->verbose, "Print every solver iteration to stderr");
  d->add_flag("--evaluate", o->evaluate,
              "Then simulate the final design over every frame of the motion and beside the Line and X baselines of its area "
              "(FILE.evaluation.h5; the design service always does)");
  d->add_flag("--json", o->json, "Print one JSON line per iteration (the default when stdout is not a terminal)");
  d->callback([o, exit_code] { *exit_code = RunDesign(*o); });

  auto file = std::make_shared<std::string>();
  auto json = std::make_shared<bool>(false);
  auto iteration = std::make_shared<int>(-1);
  auto angle = std::make_shared<double>(0.0);
  auto out = std::make_shared<std::string>();
  CLI::App* ds = app.add_subcommand("designs", "Print the history stored in a design file");
  ds->add_option("file", *file, "Design file (HDF5) written by kgd design")->required();
  ds->add_flag("--json", *json, "Print as one JSON object");
  ds->callback([file, json, exit_code] { *exit_code = RunDesigns(*file, *json); });

  auto files = std::make_shared<std::vector<std::string>>();
  CLI::App* ck = app.add_subcommand("check", "Read every iteration of design files back whole (each chunk's checksum verified); "
                                             "exit 5 names what is damaged and what can be kept");
  ck->add_option("files", *files, "Design files (HDF5)")->required();
  ck->add_flag("--json", *json, "Print as JSON");
  ck->callback([files, json, exit_code] { *exit_code = RunCheck(*files, *json); });

  CLI::App* ev = app.add_subcommand("evaluate", "Simulate a stored design over every frame of the scene's motion, beside the fully reinforced garment");
  ev->add_option("file", *file, "Design file (HDF5)")->required();
  ev->add_option("--iteration", *iteration, "Which iteration's design (default: the last)");
  ev->add_flag("--json", *json, "Print as one JSON object");
  auto on = std::make_shared<std::string>();
  ev->add_option("--on", *on,
                 "Instead: the design on every body of this scene (a built-in name or scene file with the design's garment faces, "
                 "e.g. knee_flexion_sizes), in the deformed pose against each body's fully reinforced garment; a design file of "
                 "several bodies always is");
  ev->callback([file, iteration, json, on, exit_code] { *exit_code = RunEvaluate(*file, *iteration, *json, *on); });

  CLI::App* bl = app.add_subcommand("baselines", "Simulate a Line and an X of the same reinforced area as a stored design, and compare");
  bl->add_option("file", *file, "Design file (HDF5)")->required();
  bl->add_option("--iteration", *iteration, "Which iteration's design (default: the last)");
  CLI::Option* angle_opt =
      bl->add_option("--angle", *angle, "Centre the bands at this angle (degrees) around the garment (default: where the fully reinforced garment stores its energy)");
  bl->add_option("--out", *out, "Write the three equilibria as PLY: OUT_optimized.ply, OUT_line.ply, OUT_x.ply");
  bl->add_flag("--json", *json, "Print as one JSON object");
  bl->callback([file, iteration, angle, angle_opt, out, json, exit_code] {
    *exit_code = RunBaselines(*file, *iteration, *angle, angle_opt->count() > 0, *out, *json);
  });

  struct ExportFlags {
    std::string file, out, formats = "svg,dxf,png";
    std::vector<std::string> body;
    std::string server = DefaultServer();
    int iteration = -1;
    double min_feature_mm = 3, seam_allowance_mm = 10, sheet_width_mm = 305;
    bool no_mirror = false, json = false;
  };
  auto ex = std::make_shared<ExportFlags>();
  CLI::App* xp = app.add_subcommand("export", "Cut files for fabrication: pattern pieces and reinforcement patches (SVG, DXF in mm) from a stored design");
  xp->add_option("file", ex->file, "Design file (HDF5); a job id on the design server (--server); or a scene file or built-in scene name to export its own design")->required();
  AddServerOptions(xp, &ex->server, "With a job id: the design server, host:port");
  xp->add_option("--body", ex->body, "With a built-in scene: a measurement of the parametric body, name=value in SI (repeatable)");
  xp->add_option("--out", ex->out, "Output folder (created if missing)")->required();
  xp->add_option("--iteration", ex->iteration, "Which iteration's design (default: the last within the budget)");
  // Their ranges are checked with the export itself (exit 2, the value named), as the service checks them.
  xp->add_option("--min-feature-mm", ex->min_feature_mm, "Remove reinforcement thinner than this (and islands and holes under its square x 4); [0, 100]")
      ->capture_default_str();
  xp->add_option("--seam-allowance-mm", ex->seam_allowance_mm, "Seam allowance around every pattern piece; [0, 100]")->capture_default_str();
  xp->add_option("--sheet-width-mm", ex->sheet_width_mm, "Width of the vinyl roll the patches are nested on; (0, 10000]")->capture_default_str();
  xp->add_flag("--no-mirror", ex->no_mirror, "Do not mirror the patches (mirrored is right for heat-transfer vinyl cut from the back)");
  xp->add_option("--formats", ex->formats, "Comma-separated: svg, dxf, png (a preview)")->capture_default_str();
  xp->add_flag("--json", ex->json, "Print the report as JSON");
  xp->callback([ex, exit_code] {
    ExportOptions o;
    o.iteration = ex->iteration;
    o.cleaning.min_feature_m = ex->min_feature_mm / 1000;
    o.sheet.seam_allowance_mm = ex->seam_allowance_mm;
    o.sheet.sheet_width_mm = ex->sheet_width_mm;
    o.sheet.mirror = !ex->no_mirror;
    if (!ex->json) o.progress = PrintExportProgress;
    o.formats.clear();
    std::stringstream list(ex->formats);
    for (std::string f; std::getline(list, f, ',');)
      if (!f.empty()) o.formats.push_back(f);
    // A job on the design server (a number that is no file).
    if (!ex->file.empty() && ex->file.find_first_not_of("0123456789") == std::string::npos && !std::filesystem::exists(ex->file)) {
      *exit_code = RunExportJob({.server = ex->server, .out = ex->out, .job = std::stoll(ex->file), .iteration = ex->iteration,
                                 .min_feature_mm = ex->min_feature_mm, .seam_allowance_mm = ex->seam_allowance_mm,
                                 .sheet_width_mm = ex->sheet_width_mm, .no_mirror = ex->no_mirror, .json = ex->json});
      return;
    }
    // A design file, or a scene (file or built-in name) with its own design.
    Result<ExportReport> r = Status::Error("");
    if (std::filesystem::path(ex->file).extension() == ".h5") {
      // The export simulates the cleaned design on the file's scene.
      Result<DesignFile> header = ReadDesignFile(ex->file, {.arrays = false});
      const Status at = header.ok() ? RunAtKernelsOf(ex->file, header->header.kernels, "exporting it") : Status::Ok();
      r = at.ok() ? ExportDesign(ex->file, ex->out, o) : Result<ExportReport>(at);
    } else {
      Result<SceneSpec> scene = ResolveScene(ex->file, ex->body);
      r = scene.ok() ? ExportDesignOfScene(*scene, ex->out, o) : Result<ExportReport>(scene.status());
    }
    if (!r.ok()) {
      *exit_code = FailReading("export", r.message());
      return;
    }
    if (!r->note.empty() && !ex->json) std::fprintf(stderr, "kgd export: note: %s\n", r->note.c_str());
    if (ex->json) {
      std::printf("%s", ExportReportJson(*r).c_str());
    } else {
      const std::string what = r->iteration >= 0 ? "iteration " + std::to_string(r->iteration) : "design of " + r->design_file;
      std::printf("%s: reinforced area %.1f%%, density ratio %.3f; cleaned (features >= %g mm): area %.1f%%, density ratio %.3f\n", what.c_str(),
                  100 * r->area_fraction, r->density_ratio, ex->min_feature_mm, 100 * r->cleaned_area_fraction, r->cleaned_density_ratio);
      for (size_t i = 0; i < r->pattern.pieces.size(); ++i) {
        const PatternPiece& piece = r->pattern.pieces[i];
        const Distortion& d = piece.distortion;
        std::printf("piece %zu: area distortion mean %.2f%% max %.2f%%, angle mean %.2f max %.2f deg; sew line turns at most %.1f deg away from corners, "
                    "within %.2f mm of the outline\n",
                    i + 1, 100 * d.area_mean, 100 * d.area_max, d.angle_mean_deg, d.angle_max_deg, piece.sew_turning_max_deg, piece.sew_deviation_max_mm);
      }
      std::printf("%zu patches on a %g mm sheet (%.0f%% used)%s; %.2f s\n", r->patches.size(), ex->sheet_width_mm, 100 * r->sheet_usage,
                  ex->no_mirror ? "" : ", mirrored", r->seconds);
      for (const std::string& f : r->files) std::printf("wrote %s\n", f.c_str());
    }
    *exit_code = 0;
  });
}

}  // namespace kgd::cli
