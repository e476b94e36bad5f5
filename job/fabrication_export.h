// Fabrication export: a stored design (any iteration of a design file) to the files a maker cuts from
// (core/fabrication/): the pattern pieces and the reinforcement patches as SVG and DXF in millimetres,
// and a JSON report. The design is cleaned for manufacture first and the cleaned design simulated
// again, so the report gives its density ratio beside the stored one.
#pragma once

#include <functional>
#include <string>
#include <vector>

#include "core/fabrication/cut_sheet.h"
#include "core/fabrication/patches.h"
#include "core/fabrication/pattern.h"
#include "core/scene/scene.h"
#include "core/util/status.h"
#include "store/design_file.h"

namespace kgd {

// The largest lengths an export takes: a minimum feature, seam allowance or gap (mm), and a vinyl
// roll's width (mm). Larger, or not finite, is refused naming the value.
constexpr double kMaxExportFeatureMm = 100, kMaxSheetWidthMm = 10000;

struct ExportOptions {
  int iteration = -1;                 // -1: the last iteration within the budget (else the last)
  CleaningOptions cleaning;
  SheetOptions sheet;
  std::vector<std::string> formats = {"svg", "dxf", "png"};
  // Called as each stage of the export starts ("cleaning the design", "cutting the pattern", ...), with
  // the fraction of the export's usual time done before it: a long export's progress.
  std::function<void(const std::string& stage, double fraction)> progress;
};

struct ExportReport {
  std::string design_file;
  int iteration = 0;
  Pattern pattern;
  std::vector<Patch> patches;
  CleanedDesign cleaned;
  double area_fraction = 0, cleaned_area_fraction = 0;
  double density_ratio = 0, cleaned_density_ratio = 0;  // vs the file's iteration 0
  std::string cleaned_solve_status;
  double sheet_usage = 0;
  std::vector<SeamSides> seam_lengths;
  std::vector<std::string> files;     // written, in order
  double seconds = 0;
  // Where the time went, stage by stage. An export that simulates cuts the pattern alongside cleaning
  // and simulating: its stage is then the wait for it, and pattern_seconds its own time.
  std::vector<std::pair<std::string, double>> stage_seconds;
  double pattern_seconds = 0;
  // For the user beside the report: why the design exported is not the one they may expect (empty: none).
  std::string note;
};

// Exports iteration `options.iteration` of `design_file` into `out_dir` (created if missing), cut
// along the scene's seams if it gives them (SceneSpec::seams):
// pattern.svg / .dxf / .png (pieces), patches.svg / .dxf / .png (the vinyl sheet; PNG: previews) per `formats`, and
// report.json. Every file is written under a temporary name and renamed only when all are written: a
// failed export leaves no file behind. Errors name the file, the iteration, the format or the option
// out of range (kMaxExportFeatureMm, kMaxSheetWidthMm) with its value.
Result<ExportReport> ExportDesign(const std::string& design_file, const std::string& out_dir, const ExportOptions& options);

// The same for a scene's own design (a scene file's, or a built-in scene's such as pull_test_line):
// its density ratio against the same garment fully reinforced. `iteration` in the report is -1.
Result<ExportReport> ExportDesignOfScene(const SceneSpec& scene, const std::string& out_dir, const ExportOptions& options);

// A design cleaned for manufacture and simulated again, as every export does: `scene.design` cleaned
// (CleanDesign with `cleaning`; attachments and clamp strips kept as they are) and solved from
// `scene.initial` (an export starts it from the stored equilibrium), its density ratio against
// `full_density` (the fully reinforced design's reinforced density). `progress` (optional) hears the
// stages as ExportOptions::progress does. The design worker makes this for a job's last design, so that
// the service's cut files report it (kgd.v1.CleanedDesign).
// Where the cleaned design of a stored iteration starts its solve: the stored equilibrium (it differs
// little from the stored design) for a garment cut from the body; a garment of its own starts where the
// design job started it, since its attachment anchors are its start positions (moving them would move
// its attachments).
void StartFromStoredEquilibrium(SceneSpec* scene, const Positions& equilibrium);

struct CleanedSimulation {
  CleanedDesign cleaned;
  double area_fraction = 0, density_ratio = 0;
  std::string solve_status;
};
Result<CleanedSimulation> SimulateCleanedDesign(const SceneSpec& scene, double full_density, const CleaningOptions& cleaning,
                                                const std::function<void(const std::string& stage, double fraction)>& progress = nullptr);

// The files of an export from a design file's header and one iteration (with its arrays), in memory,
// by geometry alone: no scene is built and nothing is simulated (the report's cleaned density ratio is
// 0 and its solve status "not simulated"; no clamp strips are known, and kgd chooses the seams, since
// the scene file's are not stored). What the design service offers for download, since it never
// simulates (it fills in its worker's SimulateCleanedDesign of a job's last design).
struct ExportFiles {
  std::vector<std::pair<std::string, std::string>> files;  // name (pattern.svg, ..., report.json), contents
  ExportReport report;
};
Result<ExportFiles> ExportGeometry(const DesignFileHeader& header, const BesoIteration& iteration, const ExportOptions& options);

// Writes `files` (name, contents) into `out_dir` (created if missing), each under a temporary name, then
// renames them all: all the files or none.
Status WriteExportFiles(const std::string& out_dir, const std::vector<std::pair<std::string, std::string>>& files);

// The report as JSON (SI units, and mm where the key says so).
std::string ExportReportJson(const ExportReport& report);

}  // namespace kgd
