// The design file: one design job's whole history in HDF5 -- the garment, the job that made it, and
// every BESO iteration's metrics, design, equilibrium positions, energy densities and sensitivities.
// `kgd design` writes it; `kgd designs`, `kgd evaluate` and `kgd baselines` read it; the service
// stores one per job. Layout (format_version 1; SI units; N iterations, V vertices, F faces):
//
//   /                            attrs format = "kgd design history", format_version = 1
//   /job                         attrs scene (built-in name or scene-file path), body (measurement
//                                overrides "name=value ..."), settings (BESO settings, JSON), kgd_version,
//                                motions (JSON [{"name", "role", "weight"}, ...]: the scene's K motions;
//                                files before it lack it and read as one motion, the scene's),
//                                kernels (the numeric kernels' level, core/util/pinned_kernels.h; files
//                                before it lack it and read "x86-64"), solver (JSON {"grad_tol",
//                                "max_newton_iterations"}: the solves' settings in force, 0 the default;
//                                files before it lack it and resume at the scene's)
//   /garment/rest_vertices       (V,3) float64, m
//   /garment/faces               (F,3) int32, 0-based vertex indices
//   /garment/rest_area           (F)   float64, m^2
//   /garment/initial_positions   (V,3) float64, m: the garment on the body in the deformed pose
//   /garment/attachment_faces    (A)   int32
//   /garment/thickness           (2)   float64, m: cloth, reinforced (optional: files before it lack it)
//   /body/vertices, /body/faces  (B,3) float64 m, (G,3) int32: the body in the simulated pose
//                                (optional: scenes without a body, and files before it, have none)
//   /iterations/<metric>         (N)   one dataset per metric (DesignFileMetricNames): float64, or
//                                int32 for iteration, status, solver_iterations, cold_restart;
//                                status: 0 converged, 1 line_search_failed, 2 not_positive_definite,
//                                3 iteration_limit, 4 invalid_state, 5 stalled (SolveStatus)
//   /iterations/design           (N,F)   uint8, 1 = reinforced
//   /iterations/positions        (N,V,3) float64, m
//   /iterations/energy_density_Pa (N,F) float64, strain energy density W
//   /iterations/sensitivity      (N,F)   float64, filtered averaged sensitivities (row 0: zeros)
//   /iterations/motion_metrics   (N,K,6) float64 per motion: energy_J, reinforced_energy_J,
//                                reinforced_density_J_per_m2, density_ratio, simulation_s,
//                                solver_iterations (with /job motions)
//   /iterations/motion_positions (N,K-1,V,3) float64, m: motions 2..K's equilibria, where a resumed
//                                job warm-starts them (with K > 1; NaN rows: not stored; files before
//                                it lack it and resume by solving them again)
//
// Per-iteration arrays are chunked one iteration per chunk, metrics 64 iterations per chunk, /garment
// datasets in one chunk each; every chunk carries a Fletcher-32 checksum (files written before it
// have none and read as before); designs
// are deflate-compressed, the float arrays are not (they shrink by only ~25 % at most of an append's
// cost: design_file.cpp; `h5repack -f GZIP=4` packs a finished file). Datasets grow by one row per
// Append. /iterations/iteration is written last: its length is the number of complete
// iterations, and a reader (or a resumed writer) ignores rows beyond it. The writer flushes the file
// after every iteration (an interrupted `kgd design` resumes from the last one). HDF5 is not
// crash-safe: a writer killed mid-append can damage rows it had committed (about one kill in 150).
// Reopen then rebuilds the file from the iterations that read back whole, and readers give up on a
// damaged block within a second instead of retrying it for hours. Reopen also reads every kept
// iteration back first: a file damaged otherwise (one byte of a chunk index is enough) is rebuilt the
// same way, with the original kept as FILE.damaged, since a writer in SWMR mode would retry the
// damaged block for ever.
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "core/beso/design_loop.h"
#include "core/mesh/trimesh.h"
#include "core/util/pinned_kernels.h"
#include "core/util/status.h"

namespace kgd {

// The job and garment, written once when the file is created.
struct DesignFileHeader {
  std::string scene;          // built-in scene name or scene-file path
  std::string body;           // parametric body overrides, "name=value ..." (empty: defaults)
  BesoSettings settings;
  TriMesh garment;            // rest shape
  Positions initial;          // on the body in the deformed pose
  Eigen::VectorXd rest_area_m2;
  std::vector<int> attachment_faces;
  // Material thicknesses (m), to turn energy densities (J/m^3) into energy per area (J/m^2); 0: unknown.
  double cloth_thickness_m = 0, reinforced_thickness_m = 0;
  TriMesh body_mesh;          // the body in the simulated pose; empty when the scene has none
  // The scene's motions: name, role, weight (the figures unused). Empty: one motion, the scene's.
  std::vector<MotionMetrics> motions;
  // The numeric kernels the designs were computed with (core/util/pinned_kernels.h): "x86-64-v3",
  // "x86-64", "native" or "unpinned" (RunningKernels() of the process that ran iteration 0); a file
  // without it reads "x86-64". A resume runs at this level.
  std::string kernels;
  // The equilibrium solves' settings in force (the scene's, or the job's quality, --grad-tol,
  // --max-newton): grad_tol 0 means not recorded (a file from before it was: the scene's own),
  // max_newton_iterations 0 the solver's default (200). A resume solves with them.
  double grad_tol = 0;
  int max_newton_iterations = 0;
};

struct DesignFile {
  DesignFileHeader header;
  std::vector<BesoIteration> iterations;  // metrics always; arrays only when read with arrays
};

// Names of the per-iteration metric datasets, in table order.
const std::vector<std::string>& DesignFileMetricNames();

struct DesignFileReader;

class DesignFileWriter {
 public:
  // Creates (or overwrites) `path` with the header and no iterations.
  static Result<std::unique_ptr<DesignFileWriter>> Create(const std::string& path, const DesignFileHeader& header);
  // Opens an existing file to append after its first `keep` iterations (later ones are dropped;
  // keep < 0: all). A file whose writer was killed, or with an iteration that does not read back whole,
  // is first rebuilt from the iterations that do, which may be fewer than `keep`: num_iterations() says
  // how many were kept, repair_note() what happened (a damaged original is kept as path + ".damaged").
  static Result<std::unique_ptr<DesignFileWriter>> Reopen(const std::string& path, int keep = -1);
  // Like Reopen, but always copies the first `keep` iterations that read back whole into a fresh file
  // that replaces `path`: after a failed write, whose file HDF5 may go on to extend from a wrong end
  // ("addr overflow") if it were appended to in place.
  static Result<std::unique_ptr<DesignFileWriter>> Rebuild(const std::string& path, int keep);
  ~DesignFileWriter();

  // Appends one iteration (its index must be the number stored so far) and flushes it to disk.
  Status Append(const BesoIteration& iteration);
  // Replaces the stored BESO settings (a resume given another iteration limit), so that the file reads as
  // the job now runs; the new settings are written beside the old before they replace them, and a file
  // killed in between reads them.
  Status SetSettings(const BesoSettings& settings);
  int num_iterations() const { return count_; }
  // Empty, or what Reopen did to a killed writer's or a damaged file ("rebuilt ...: kept K of N iterations").
  const std::string& repair_note() const { return repair_note_; }
  int faces() const;
  int vertices() const;

 private:
  DesignFileWriter() = default;
  static Result<std::unique_ptr<DesignFileWriter>> Salvage(const DesignFileReader& reader, int keep);
  struct Impl;
  std::unique_ptr<Impl> impl_;
  int count_ = 0;
  std::string repair_note_;
};

struct DesignFileReadOptions {
  bool arrays = true;         // designs, positions, densities, sensitivities (false: metrics only)
  int only_iteration = -1;    // >= 0: arrays of this iteration only (metrics of all)
};

// Reads a design file. Errors name the file and what is wrong with it (not HDF5, wrong format or
// version, inconsistent sizes).
Result<DesignFile> ReadDesignFile(const std::string& path, const DesignFileReadOptions& options = {});

// What every stored iteration of a design file reads back as: each metric, design and array, with the
// checksum of every chunk verified (a flipped bit fails it).
struct DesignFileCheck {
  int iterations = 0;         // complete iterations the file records
  int intact = 0;             // the leading iterations that read back whole: what a resume keeps
  std::vector<int> damaged;   // the iterations that do not (ascending)
  std::string first_damage;   // what is wrong with the first of them (names the file, iteration, dataset)
  bool ok() const { return damaged.empty(); }
};

// Reads every iteration of `path` whole. An error when not even the file's header reads (not a design
// file, or damaged there); otherwise what is intact and what is damaged.
Result<DesignFileCheck> CheckDesignFile(const std::string& path);

// BESO settings as the JSON stored in /job (also used by the CLI for --json output).
std::string BesoSettingsToJson(const BesoSettings& settings);
// Unknown keys and invalid values are refused; a missing key takes the default, except
// resolve_tolerance_factor, which takes 1 (the files written before it ran every re-solve at the
// tolerance, so a resumed job continues as it ran).
Result<BesoSettings> BesoSettingsFromJson(const std::string& json);

}  // namespace kgd
