#include "job/fabrication_export.h"

#include "core/fabrication/sheet_png.h"

#include <omp.h>
#include <unistd.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <future>
#include <nlohmann/json.hpp>
#include <set>

#include "core/scene/simulate.h"
#include "job/design_job.h"
#include "store/design_file.h"

namespace kgd {
namespace fs = std::filesystem;

namespace {

// Times the export's stages and announces each as it starts (ExportOptions::progress).
class Stages {
 public:
  explicit Stages(const ExportOptions& o) : progress_(o.progress) {}
  void Begin(const std::string& name, double fraction) {
    End();
    if (progress_) progress_(name, fraction);
    name_ = name;
    start_ = std::chrono::steady_clock::now();
  }
  std::vector<std::pair<std::string, double>> Finish() {
    End();
    return std::move(seconds_);
  }

 private:
  void End() {
    if (!name_.empty()) seconds_.push_back({name_, std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count()});
    name_.clear();
  }
  std::function<void(const std::string&, double)> progress_;
  std::string name_;
  std::chrono::steady_clock::time_point start_;
  std::vector<std::pair<std::string, double>> seconds_;
};

Status CheckOptions(const ExportOptions& o) {
  const std::set<std::string> known = {"svg", "dxf", "png"};
  if (o.formats.empty()) return Status::Error("export: no format asked for (svg, dxf, png)");
  for (const std::string& f : o.formats)
    if (!known.count(f)) return Status::Error("export: unknown format '" + f + "' (svg, dxf, png)");
  // Each length finite and within what a garment and a vinyl roll can be; the message names the value.
  struct Length {
    const char* what;
    double mm, max_mm;
    bool zero_allowed;
  };
  for (const Length& l : {Length{"minimum feature (--min-feature-mm, minFeatureMm)", 1000 * o.cleaning.min_feature_m, kMaxExportFeatureMm, true},
                          Length{"seam allowance (--seam-allowance-mm, seamAllowanceMm)", o.sheet.seam_allowance_mm, kMaxExportFeatureMm, true},
                          Length{"sheet width (--sheet-width-mm, sheetWidthMm)", o.sheet.sheet_width_mm, kMaxSheetWidthMm, false},
                          Length{"gap between patches", o.sheet.gap_mm, kMaxExportFeatureMm, true}})
    if (!std::isfinite(l.mm) || l.mm < 0 || (l.mm == 0 && !l.zero_allowed) || l.mm > l.max_mm) {
      char text[320];
      std::snprintf(text, sizeof text, "export: the %s %g mm is not a finite number in %s0, %g] mm", l.what, l.mm, l.zero_allowed ? "[" : "(", l.max_mm);
      return Status::Error(text);
    }
  return Status::Ok();
}

Result<ExportReport> ExportSceneDesign(SceneSpec scene, const Eigen::VectorXd& strain, double full_density, const std::string& label,
                                       const std::string& out_dir, const ExportOptions& o, ExportReport r,
                                       std::chrono::steady_clock::time_point start, Stages& stages);

}  // namespace

Result<ExportReport> ExportDesignOfScene(const SceneSpec& scene, const std::string& out_dir, const ExportOptions& o) {
  const auto start = std::chrono::steady_clock::now();
  KGD_RETURN_IF_ERROR(CheckOptions(o));
  if (scene.design.size() != static_cast<size_t>(scene.garment.faces.rows())) return Status::Error("export: scene '" + scene.name + "' has no design");
  Stages stages(o);
  stages.Begin("simulating the scene's design and the fully reinforced garment", 0);
  // Its density ratio is against the same garment fully reinforced.
  SceneSpec full = scene;
  full.design.assign(scene.garment.faces.rows(), 1);
  Result<SimulationResult> f = SimulateScene(full);
  if (!f.ok()) return f.status().WithContext("export: the fully reinforced garment: ");
  Result<SimulationResult> d = SimulateScene(scene);
  if (!d.ok()) return d.status().WithContext("export: the scene's design: ");
  ExportReport r;
  r.design_file = scene.name;
  r.iteration = -1;
  r.area_fraction = d->reinforced_area_m2 / d->garment_area_m2;
  r.density_ratio = f->reinforced_density_J_per_m2 > 0 ? d->reinforced_density_J_per_m2 / f->reinforced_density_J_per_m2 : 0;
  return ExportSceneDesign(scene, d->face_density_Pa, f->reinforced_density_J_per_m2, scene.name, out_dir, o, std::move(r), start, stages);
}

Result<ExportReport> ExportDesign(const std::string& path, const std::string& out_dir, const ExportOptions& o) {
  const auto start = std::chrono::steady_clock::now();
  KGD_RETURN_IF_ERROR(CheckOptions(o));
  Stages stages(o);
  stages.Begin("reading the design file", 0);

  Result<DesignFile> metrics = ReadDesignFile(path, {.arrays = false});
  if (!metrics.ok()) return metrics.status();
  const DesignFileHeader& h = metrics->header;
  const int n = static_cast<int>(metrics->iterations.size());
  if (n == 0) return Status::Error(path + ": no iterations stored yet");
  int k = o.iteration;
  if (k < 0) {
    // The last design within the budget (every stored iteration is a valid design).
    k = n - 1;
    for (int i = n - 1; i >= 0; --i)
      if (metrics->iterations[i].area_fraction <= h.settings.budget + 1e-9) {
        k = i;
        break;
      }
  }
  std::string note;
  if (o.iteration < 0 && metrics->iterations[k].area_fraction > h.settings.budget + 1e-9) {
    char buf[200];
    std::snprintf(buf, sizeof buf, "no stored iteration is within the budget (%.1f %%): the last, iteration %d, reinforces %.1f %% of the garment",
                  100 * h.settings.budget, k, 100 * metrics->iterations[k].area_fraction);
    note = buf;
  }
  if (k >= n) return Status::Error(path + ": iteration " + std::to_string(k) + " is not stored (0.." + std::to_string(n - 1) + ")");
  Result<DesignFile> file = ReadDesignFile(path, {.arrays = true, .only_iteration = k});
  if (!file.ok()) return file.status();
  const BesoIteration& it = file->iterations[k];
  bool any = false;
  for (uint8_t d : it.design) any |= d != 0;
  if (!any) return Status::Error(path + ": iteration " + std::to_string(k) + " has no reinforced face: nothing to cut");
  stages.Begin("building the scene", 0.05);
  Result<SceneSpec> scene = SceneOfDesignFile(path, h);
  if (!scene.ok()) return scene.status();
  scene->design = it.design;
  ExportReport r;
  r.design_file = path;
  r.note = note;
  r.iteration = k;
  r.area_fraction = it.area_fraction;
  r.density_ratio = it.density_ratio;
  StartFromStoredEquilibrium(&*scene, it.positions);
  return ExportSceneDesign(std::move(scene).value(), it.energy_density_Pa, metrics->iterations[0].reinforced_density_J_per_m2,
                           h.scene + ", iteration " + std::to_string(k), out_dir, o, std::move(r), start, stages);
}

namespace {

using Files = std::vector<std::pair<std::string, std::string>>;  // name, contents

PatternOptions PatternOptionsOf(const std::vector<std::vector<int>>& seams, const Eigen::VectorXd& strain) {
  PatternOptions po;
  po.strain = strain;
  for (const std::vector<int>& s : seams) po.seams.push_back({s});
  return po;
}

// The patches of r->cleaned.design on `pattern` and the sheets' files (report.json aside).
Status CutFiles(Result<Pattern> pattern, const std::vector<uint8_t>& include, const std::string& label, const ExportOptions& o, ExportReport* r,
                Files* files, Stages& stages) {
  if (!pattern.ok()) return pattern.status().WithContext("export: " + label + ": ");
  r->pattern = std::move(pattern).value();
  stages.Begin("outlining the patches", 0.75);
  const double min_area = o.cleaning.min_area_m2 > 0 ? o.cleaning.min_area_m2 : 4 * o.cleaning.min_feature_m * o.cleaning.min_feature_m;
  r->patches = ReinforcementPatches(r->pattern, r->cleaned.design, include, min_area);
  r->seam_lengths = SeamLengths(r->pattern);
  stages.Begin("nesting and drawing the sheets", 0.85);
  SheetOptions so = o.sheet;
  if (so.label.empty()) so.label = label;
  const Sheet pieces = PatternSheet(r->pattern, r->patches, so);
  Result<Sheet> patches = PatchSheet(r->patches, so, &r->sheet_usage);
  if (!patches.ok()) return patches.status().WithContext("export: ");
  for (const std::string& f : o.formats)
    for (const auto& [name, sheet] : {std::pair<std::string, const Sheet*>{"pattern", &pieces}, {"patches", &*patches}}) {
      if (f != "png") {
        files->push_back({name + "." + f, f == "svg" ? SvgText(*sheet) : DxfText(*sheet)});
        continue;
      }
      Result<std::string> png = SheetPng(*sheet);
      if (!png.ok()) return png.status().WithContext("export: " + name + ": ");
      files->push_back({name + ".png", std::move(png).value()});
    }
  return Status::Ok();
}

// Attachments stay as they are (keep); faces left out of the patches (include = 0) stay too.
Status CheckReinforced(const std::vector<uint8_t>& design, const std::vector<uint8_t>& include, const std::string& label) {
  for (size_t f = 0; f < design.size(); ++f)
    if (design[f] && include[f]) return Status::Ok();
  return Status::Error("export: " + label + " has no reinforced face: nothing to cut");
}

}  // namespace

Status WriteExportFiles(const std::string& out_dir, const std::vector<std::pair<std::string, std::string>>& files) {
  std::error_code ec;
  fs::create_directories(out_dir, ec);
  if (ec) return Status::Error("export: cannot create " + out_dir + ": " + ec.message());
  const std::string suffix = ".tmp" + std::to_string(getpid());
  std::vector<std::string> written;
  auto clean_up = [&] {
    for (const std::string& t : written) fs::remove(t, ec);
  };
  for (const auto& [name, contents] : files) {
    const std::string tmp = (fs::path(out_dir) / (name + suffix)).string();
    std::ofstream out(tmp, std::ios::binary);
    written.push_back(tmp);
    out << contents;
    out.close();
    if (!out) {
      clean_up();
      return Status::Error("export: cannot write " + tmp + " (disk full, or the folder is not writable?)");
    }
  }
  for (size_t i = 0; i < files.size(); ++i) {
    fs::rename(written[i], (fs::path(out_dir) / files[i].first), ec);
    if (ec) {
      clean_up();
      return Status::Error("export: cannot rename " + written[i] + ": " + ec.message());
    }
  }
  return Status::Ok();
}

namespace {

// The faces a cleaning keeps as they are (attachments; clamp strips, a test sample's fixtures) and the
// faces that are garment (not clamp strips).
void KeepAndInclude(const SceneSpec& scene, std::vector<uint8_t>* keep, std::vector<uint8_t>* include) {
  const int nf = static_cast<int>(scene.garment.faces.rows());
  keep->assign(nf, 0);
  include->assign(nf, 1);
  for (int a : scene.attachment_faces) (*keep)[a] = 1;
  if (scene.effects.clamps && !scene.clamps.empty()) {
    std::vector<char> clamped(scene.garment.vertices.rows(), 0);
    for (const Clamp& c : scene.clamps)
      for (int v : c.vertices) clamped[v] = 1;
    for (int f = 0; f < nf; ++f)
      if (clamped[scene.garment.faces(f, 0)] && clamped[scene.garment.faces(f, 1)] && clamped[scene.garment.faces(f, 2)]) (*include)[f] = 0, (*keep)[f] = 1;
  }
}

Result<ExportReport> ExportSceneDesign(SceneSpec scene, const Eigen::VectorXd& strain, double full_density, const std::string& label,
                                       const std::string& out_dir, const ExportOptions& o, ExportReport r,
                                       std::chrono::steady_clock::time_point start, Stages& stages) {
  const TriMesh& garment = scene.garment;
  std::vector<uint8_t> keep, include;
  KeepAndInclude(scene, &keep, &include);
  KGD_RETURN_IF_ERROR(CheckReinforced(scene.design, include, label));

  // The pattern depends on the garment and its seams alone: it is cut on a thread of its own while the
  // design is cleaned and simulated, each side on one core (two OpenMP teams on two cores would spin
  // against each other).
  const PatternOptions pattern_options = PatternOptionsOf(scene.seams, strain);
  std::future<Result<Pattern>> pattern = std::async(std::launch::async, [&garment, &pattern_options, &r] {
    omp_set_num_threads(1);
    const auto begin = std::chrono::steady_clock::now();
    Result<Pattern> p = CutPattern(garment, pattern_options);
    r.pattern_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - begin).count();
    return p;
  });
  const int threads = omp_get_max_threads();
  omp_set_num_threads(1);
  Result<CleanedSimulation> sim = SimulateCleanedDesign(scene, full_density, o.cleaning, [&](const std::string& stage, double fraction) {
    stages.Begin(stage == "simulating the cleaned design" ? stage + " (the pattern is cut alongside)" : stage, fraction);
  });
  omp_set_num_threads(threads);
  if (!sim.ok()) return sim.status();
  r.cleaned = std::move(sim->cleaned);
  r.cleaned_density_ratio = sim->density_ratio;
  r.cleaned_area_fraction = sim->area_fraction;
  r.cleaned_solve_status = sim->solve_status;

  Files files;
  stages.Begin("finishing the pattern", 0.5);
  KGD_RETURN_IF_ERROR(CutFiles(pattern.get(), include, label, o, &r, &files, stages));
  stages.Begin("writing the files", 0.95);
  for (const auto& [name, contents] : files) r.files.push_back((fs::path(out_dir) / name).string());
  r.files.push_back((fs::path(out_dir) / "report.json").string());
  // The report's own timing ends where its writing starts.
  r.stage_seconds = stages.Finish();
  r.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  files.push_back({"report.json", ExportReportJson(r)});
  KGD_RETURN_IF_ERROR(WriteExportFiles(out_dir, files));
  return r;
}

}  // namespace

void StartFromStoredEquilibrium(SceneSpec* scene, const Positions& equilibrium) {
  // A garment cut from the body has its attachment anchors on the body (on_body); a garment of its own
  // has them at its start positions, which must stay where the design job had them.
  if (scene->on_body.rows() > 0 && equilibrium.rows() == scene->initial.rows()) scene->initial = equilibrium;
}

Result<CleanedSimulation> SimulateCleanedDesign(const SceneSpec& scene, double full_density, const CleaningOptions& cleaning,
                                                const std::function<void(const std::string& stage, double fraction)>& progress) {
  if (scene.design.size() != static_cast<size_t>(scene.garment.faces.rows())) return Status::Error("export: scene '" + scene.name + "' has no design");
  std::vector<uint8_t> keep, include;
  KeepAndInclude(scene, &keep, &include);
  if (progress) progress("cleaning the design for manufacture", 0.1);
  CleanedSimulation out;
  out.cleaned = CleanDesign(scene.garment, scene.design, cleaning, keep);
  // The cleaned design, simulated as the design loop does.
  if (progress) progress("simulating the cleaned design", 0.2);
  SceneSpec cleaned = scene;
  cleaned.design = out.cleaned.design;
  Result<SimulationResult> sim = SimulateScene(cleaned);
  if (!sim.ok()) return sim.status().WithContext("export: the cleaned design: ");
  out.density_ratio = full_density > 0 ? sim->reinforced_density_J_per_m2 / full_density : 0;
  out.area_fraction = sim->reinforced_area_m2 / FaceAreas(scene.garment.vertices, scene.garment.faces).sum();
  out.solve_status = ToString(sim->solve.status);
  return out;
}

Result<ExportFiles> ExportGeometry(const DesignFileHeader& h, const BesoIteration& it, const ExportOptions& o) {
  const auto start = std::chrono::steady_clock::now();
  KGD_RETURN_IF_ERROR(CheckOptions(o));
  const int nf = static_cast<int>(h.garment.faces.rows());
  if (static_cast<int>(it.design.size()) != nf) return Status::Error("export: iteration " + std::to_string(it.iteration) + " carries no design");
  const std::string label = h.scene + ", iteration " + std::to_string(it.iteration);
  std::vector<uint8_t> keep(nf, 0), include(nf, 1);
  for (int a : h.attachment_faces) keep[a] = 1;
  KGD_RETURN_IF_ERROR(CheckReinforced(it.design, include, label));
  ExportFiles out;
  ExportReport& r = out.report;
  Stages stages(o);
  r.design_file = h.scene;
  r.iteration = it.iteration;
  r.area_fraction = it.area_fraction;
  r.density_ratio = it.density_ratio;
  stages.Begin("cleaning the design for manufacture", 0);
  r.cleaned = CleanDesign(h.garment, it.design, o.cleaning, keep);
  double area = 0;
  for (int f = 0; f < nf; ++f) area += r.cleaned.design[f] ? h.rest_area_m2[f] : 0;
  r.cleaned_area_fraction = area / h.rest_area_m2.sum();
  r.cleaned_solve_status = "not simulated";
  stages.Begin("cutting and flattening the pattern", 0.5);
  const auto begin = std::chrono::steady_clock::now();
  Result<Pattern> pattern = CutPattern(h.garment, PatternOptionsOf({}, it.energy_density_Pa));
  r.pattern_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - begin).count();
  KGD_RETURN_IF_ERROR(CutFiles(std::move(pattern), include, label, o, &r, &out.files, stages));
  r.stage_seconds = stages.Finish();
  r.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  for (const auto& [name, contents] : out.files) r.files.push_back(name);
  r.files.push_back("report.json");
  out.files.push_back({"report.json", ExportReportJson(r)});
  return out;
}

std::string ExportReportJson(const ExportReport& r) {
  nlohmann::ordered_json j;
  j["design_file"] = r.design_file;
  j["iteration"] = r.iteration;
  if (!r.note.empty()) j["note"] = r.note;
  j["area_fraction"] = r.area_fraction;
  j["density_ratio"] = r.density_ratio;
  j["cleaned"] = {{"area_fraction", r.cleaned_area_fraction},
                  {"density_ratio", r.cleaned_density_ratio},
                  {"solve_status", r.cleaned_solve_status},
                  {"removed_m2", r.cleaned.removed_m2},
                  {"added_m2", r.cleaned.added_m2},
                  {"islands_removed", r.cleaned.islands_removed},
                  {"holes_filled", r.cleaned.holes_filled}};
  j["pieces"] = nlohmann::json::array();
  for (size_t i = 0; i < r.pattern.pieces.size(); ++i) {
    const PatternPiece& p = r.pattern.pieces[i];
    Positions flat3(p.flat.rows(), 3);
    flat3 << p.flat, Eigen::VectorXd::Zero(p.flat.rows());
    j["pieces"].push_back({{"piece", i + 1},
                           {"faces", p.faces.rows()},
                           {"rest_area_m2", FaceAreas(p.rest, p.faces).sum()},
                           {"flat_area_m2", FaceAreas(flat3, p.faces).sum()},
                           {"area_distortion_mean", p.distortion.area_mean},
                           {"area_distortion_max", p.distortion.area_max},
                           {"angle_distortion_mean_deg", p.distortion.angle_mean_deg},
                           {"angle_distortion_max_deg", p.distortion.angle_max_deg},
                           {"sew_line_points", p.sew_line.rows()},
                           {"sew_line_turning_max_deg", p.sew_turning_max_deg},
                           {"sew_line_deviation_max_mm", p.sew_deviation_max_mm}});
  }
  j["seams"] = nlohmann::json::array();
  for (size_t i = 0; i < r.seam_lengths.size(); ++i)
    j["seams"].push_back({{"seam", i + 1}, {"vertices", r.pattern.seams[i].vertices.size()}, {"side_a_mm", r.seam_lengths[i].a_mm},
                          {"side_b_mm", r.seam_lengths[i].b_mm}});
  j["patches"] = nlohmann::json::array();
  for (size_t i = 0; i < r.patches.size(); ++i)
    j["patches"].push_back({{"patch", i + 1},
                            {"piece", r.patches[i].piece + 1},
                            {"area_m2", r.patches[i].area_m2},
                            {"outline_area_m2", r.patches[i].outline_area_m2},
                            {"holes", r.patches[i].holes.size()}});
  j["sheet_usage"] = r.sheet_usage;
  j["files"] = r.files;
  j["seconds"] = r.seconds;
  j["pattern_seconds"] = r.pattern_seconds;
  j["stage_seconds"] = nlohmann::ordered_json::object();
  for (const auto& [stage, seconds] : r.stage_seconds) j["stage_seconds"][stage] = seconds;
  return j.dump(2) + "\n";
}

}  // namespace kgd
