#include "client/simulate_command.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <map>
#include <memory>
#include <optional>
#include <nlohmann/json.hpp>

#include "client/body_command.h"
#include "job/cost_calibration.h"
#include "core/mesh/mesh_io.h"
#include "core/scene/body_garment.h"
#include "core/scene/paper_scenes.h"
#include "core/scene/scene.h"
#include "core/scene/simulate.h"
#include "core/scene/scene_file.h"
#include "core/scene/scene_keys.h"
#include "core/scene/builtin_scenes.h"
#include "core/beso/quality.h"

namespace kgd::cli {
namespace {

struct SimulateOptions {
  std::string scene;
  bool json = false;
  std::string out;
  std::string method;
  double grad_tol = 0;
  int max_iterations = -1;
  bool verbose = false;
  bool frames = false;
  bool profile = false;
  std::string design;
  std::vector<std::string> body;
};

nlohmann::json ResultJson(const SceneSpec& scene, const SimulationResult& r) {
  nlohmann::json j;
  j["scene"] = scene.name;
  j["status"] = ToString(r.solve.status);
  if (!r.solve.message.empty()) j["message"] = r.solve.message;
  j["energy_J"] = r.solve.energy_J;
  for (const EnergyBreakdown::Term& t : r.solve.energies.terms) j[std::string(t.name) + "_energy_J"] = t.energy_J;
  j["reinforced_energy_J"] = r.reinforced_energy_J;
  j["reinforced_area_m2"] = r.reinforced_area_m2;
  j["reinforced_density_J_per_m2"] = r.reinforced_density_J_per_m2;
  j["garment_area_m2"] = r.garment_area_m2;
  j["grad_norm_N"] = r.solve.grad_norm_N;
  j["tolerance_N"] = r.solve.tolerance_N;
  j["iterations"] = r.solve.iterations;
  j["seconds"] = r.solve.seconds;
  j["factorizations"] = r.solve.factorizations;
  j["local_steps"] = r.solve.local_steps;
  j["vertices"] = r.positions.rows();
  j["faces"] = r.face_density_Pa.size();
  j["inverted_faces"] = r.inverted_faces;
  nlohmann::json forces = nlohmann::json::object();
  for (const ClampForce& c : r.clamp_forces) forces[c.name] = {c.force_N.x(), c.force_N.y(), c.force_N.z()};
  j["clamp_force_N"] = forces;
  if (r.has_contact) {
    j["min_phi_m"] = r.min_phi_m;
    j["max_phi_m"] = r.max_phi_m;
  }
  if (r.skin.pressure_Pa.size()) {
    j["peak_pressure_Pa"] = r.skin.peak_Pa;
    j["p95_pressure_Pa"] = r.skin.p95_Pa;
    j["peak_pressure_body_vertex"] = r.skin.peak_vertex;
    j["pressed_body_vertices"] = r.skin.loaded_vertices;
    j["contact_normal_force_N"] = r.skin.normal_force_N;
  }
  return j;
}

// The body's volume over the motion (scenes cut from a body), and a note when the motion changes it by
// more than kBodyVolumeNoticeFraction: flesh keeps its volume, so the posed meshes are then collapsed or
// swollen and the garment energies with them.
void AddBodyVolumeJson(const SceneSpec& scene, nlohmann::json* j) {
  if (!scene.motion) return;
  const std::optional<BodyVolumeChange> c = MotionVolumeChange(*scene.motion);
  if (!c) return;
  (*j)["body_volume_rest_m3"] = c->rest_m3;
  (*j)["body_volume_pose_m3"] = c->pose_m3;
  (*j)["body_volume_frame"] = c->frame;
  (*j)["body_volume_change"] = c->Relative();
}

void PrintBodyVolume(const SceneSpec& scene) {
  if (!scene.motion) return;
  const std::optional<BodyVolumeChange> c = MotionVolumeChange(*scene.motion);
  if (!c) {
    std::printf("body volume           - (the body surface is not closed)\n");
    return;
  }
  std::printf("body volume           %s\n", DescribeBodyVolume(*c).c_str());
  if (const std::string note = BodyVolumeNote(*c); !note.empty()) std::printf("note                  %s\n", note.c_str());
}

// Where the time went: set-up (scene, model) and the solve's parts, each built term's evaluations.
struct SetupTimes {
  double scene_s = 0;  // the scene: bodies, poses, garment (ResolveScene)
  double model_s = 0;  // the simulator's model and system: body field, terms, pattern, analysis
};

nlohmann::json ProfileJson(const SetupTimes& setup, const SolveReport& s) {
  nlohmann::json terms = nlohmann::json::array();
  for (const GarmentSystem::TermTime& t : s.term_times) terms.push_back({{"name", t.name}, {"seconds", t.seconds}, {"elements", t.elements}});
  return {{"scene_s", setup.scene_s},
          {"model_s", setup.model_s},
          {"solve_s", s.seconds},
          {"assembly_s", s.assembly_s},
          {"factorization_s", s.factorization_s},
          {"linear_solve_s", s.solve_s},
          {"line_search_s", s.line_search_s},
          {"body_field_query_s", s.body_field_query_s},
          {"terms", terms}};
}

void PrintProfile(const SetupTimes& setup, const SolveReport& s) {
  std::string built;
  for (const GarmentSystem::TermTime& t : s.term_times) built += (built.empty() ? "" : ", ") + std::string(t.name);
  std::printf("profile (s)           scene %.3f, model %.3f, solve %.3f\n", setup.scene_s, setup.model_s, s.seconds);
  std::printf("  solve               assembly %.3f, factorization %.3f, linear solves %.3f, line search %.3f\n", s.assembly_s,
              s.factorization_s, s.solve_s, s.line_search_s);
  std::printf("  terms built         %s\n", built.c_str());
  for (const GarmentSystem::TermTime& t : s.term_times) {
    std::string name = t.name;
    std::replace(name.begin(), name.end(), '_', ' ');
    std::printf("  %-19s %.4f  (%lld element evaluations%s)\n", name.c_str(), t.seconds, t.elements,
                name == "contact" ? ", with its body-field queries" : "");
  }
  if (s.body_field_query_s > 0) std::printf("  body-field queries  %.4f  (the line search's contact projection)\n", s.body_field_query_s);
}

void PrintHuman(const SceneSpec& scene, const SimulationResult& r) {
  const SolveReport& s = r.solve;
  std::printf("scene                 %s (%ld vertices, %ld faces)\n", scene.name.c_str(), (long)r.positions.rows(),
              (long)r.face_density_Pa.size());
  std::printf("status                %s%s%s\n", ToString(s.status), s.message.empty() ? "" : ": ", s.message.c_str());
  // The terms with energy, by name ("fold_barrier" printed "fold barrier").
  std::string parts;
  for (const EnergyBreakdown::Term& t : s.energies.terms) {
    if (t.energy_J == 0 && std::string_view(t.name) != "membrane") continue;
    std::string name = t.name;
    std::replace(name.begin(), name.end(), '_', ' ');
    char part[96];
    std::snprintf(part, sizeof part, "%s%s %.6g", parts.empty() ? "" : ", ", name.c_str(), t.energy_J);
    parts += part;
  }
  std::printf("total energy          %.9g J  (%s)\n", s.energy_J, parts.c_str());
  std::printf("reinforced energy     %.6g J over %.6g m^2 (%.1f %% of the garment)\n", r.reinforced_energy_J,
              r.reinforced_area_m2, r.garment_area_m2 > 0 ? 100.0 * r.reinforced_area_m2 / r.garment_area_m2 : 0.0);
  std::printf("reinforced density    %.6g J/m^2\n", r.reinforced_density_J_per_m2);
  std::printf("gradient norm         %.3g N (tolerance %.3g N)\n", s.grad_norm_N, s.tolerance_N);
  std::printf("iterations            %d (%d factorizations, %d PCG solves, %d local steps)\n", s.iterations, s.factorizations,
              s.pcg_solves, s.local_steps);
  std::printf("wall time             %.3f s\n", s.seconds);
  for (const ClampForce& c : r.clamp_forces)
    std::printf("clamp %-15s (%.6g, %.6g, %.6g) N, |F| = %.6g N\n", c.name.c_str(), c.force_N.x(), c.force_N.y(),
                c.force_N.z(), c.force_N.norm());
  if (r.has_contact)
    std::printf("distance to body      min %.3g mm, max %.3g mm (IMLS field, where defined)\n", 1e3 * r.min_phi_m,
                1e3 * r.max_phi_m);
  if (r.skin.pressure_Pa.size())
    std::printf("skin pressure         peak %.3g kPa (%.3g mmHg) at body vertex %d, p95 %.3g kPa (%.3g mmHg) over the %d body vertices pressed; normal force %.4g N\n",
                1e-3 * r.skin.peak_Pa, kMmHgPerPa * r.skin.peak_Pa, r.skin.peak_vertex, 1e-3 * r.skin.p95_Pa, kMmHgPerPa * r.skin.p95_Pa,
                r.skin.loaded_vertices, r.skin.normal_force_N);
  if (r.inverted_faces > 0) std::printf("inverted faces        %d\n", r.inverted_faces);
}

// The scene's other motions (or bodies), each simulated in its deformed pose with the same design
// (SceneInMotion / SceneOnBody): what a design job weighs beside the scene's own motion.
struct OtherMotion {
  SceneMotion motion;
  SimulationResult result;
};
Result<std::vector<OtherMotion>> SimulateOtherMotions(const SceneSpec& scene) {
  std::vector<OtherMotion> out;
  const std::vector<SceneMotion> motions = MotionsOf(scene);
  for (size_t k = 1; k < motions.size(); ++k) {
    const std::string what = (scene.bodies.empty() ? "motion '" : "body '") + motions[k].name + "': ";
    Result<SceneSpec> posed = scene.bodies.empty() ? SceneInMotion(scene, static_cast<int>(k)) : SceneOnBody(scene, static_cast<int>(k));
    if (!posed.ok()) return posed.status().WithContext(what);
    posed->design = scene.design;
    posed->solver = scene.solver;
    Result<SimulationResult> r = SimulateScene(*posed);
    if (!r.ok()) return r.status().WithContext(what);
    out.push_back({motions[k], std::move(r).value()});
  }
  return out;
}

void PrintOtherMotions(const SceneSpec& scene, const std::vector<OtherMotion>& others) {
  if (others.empty()) return;
  const std::vector<SceneMotion> motions = MotionsOf(scene);
  std::printf("%s (the same design in each deformed pose; the lines above are %s '%s'):\n", scene.bodies.empty() ? "other motions" : "other bodies",
              scene.bodies.empty() ? "motion" : "body", motions[0].name.c_str());
  for (const OtherMotion& o : others) {
    const SimulationResult& r = o.result;
    std::printf("  %-18s %s, weight %g: %s, reinforced energy %.6g J, total %.6g J", o.motion.name.c_str(), ToString(o.motion.role), o.motion.weight,
                ToString(r.solve.status), r.reinforced_energy_J, r.solve.energy_J);
    if (r.skin.pressure_Pa.size())
      std::printf(", skin pressure peak %.3g kPa (%.3g mmHg), p95 %.3g kPa (%.3g mmHg)", 1e-3 * r.skin.peak_Pa, kMmHgPerPa * r.skin.peak_Pa,
                  1e-3 * r.skin.p95_Pa, kMmHgPerPa * r.skin.p95_Pa);
    std::printf("\n");
  }
}

Status WriteResultPly(const std::string& path, const SceneSpec& scene, const SimulationResult& r) {
  return WriteGarmentPly(path, r.positions, scene.garment.faces, scene.design, r.face_density_Pa);
}

// `--out result.ply` with frames: result_frame_01.ply, result_frame_02.ply, ...
std::string FramePath(const std::string& out, int frame) {
  const std::filesystem::path p(out);
  char suffix[32];
  std::snprintf(suffix, sizeof suffix, "_frame_%02d", frame + 1);
  return (p.parent_path() / (p.stem().string() + suffix + p.extension().string())).string();
}

int RunFrames(const SimulateOptions& o, const SceneSpec& scene) {
  nlohmann::json frames = nlohmann::json::array();
  bool all_converged = true;
  Status write_status = Status::Ok();
  if (!scene.motion || scene.motion->frames.empty()) {
    std::cerr << "kgd simulate: scene '" << scene.name << "' has no motion frames (give body.frames with garment.region)\n";
    return 2;
  }
  if (!o.json)
    std::printf("%-6s %-14s %-16s %-14s %-10s %-9s %-9s %-9s %-10s %s\n", "frame", "status", "energy_J", "reinforced_J", "min_phi_mm",
                "inverted", "peak_kPa", "p95_kPa", "seconds", "iterations");
  Result<std::vector<SimulationResult>> r = SimulateFrames(scene, [&](int k, const SimulationResult& fr) {
    all_converged &= fr.solve.at_equilibrium();
    if (o.json) {
      nlohmann::json j = ResultJson(scene, fr);
      j["frame"] = k + 1;
      frames.push_back(j);
    } else {
      std::printf("%-6d %-14s %-16.9g %-14.6g %-10.3g %-9d %-9.3g %-9.3g %-10.3f %d\n", k + 1, ToString(fr.solve.status), fr.solve.energy_J,
                  fr.reinforced_energy_J, 1e3 * fr.min_phi_m, fr.inverted_faces, 1e-3 * fr.skin.peak_Pa, 1e-3 * fr.skin.p95_Pa,
                  fr.solve.seconds, fr.solve.iterations);
      std::fflush(stdout);
    }
    if (!o.out.empty() && write_status.ok()) write_status = WriteResultPly(FramePath(o.out, k), scene, fr);
  });
  if (!r.ok()) {
    std::cerr << "kgd simulate: " << r.message() << "\n";
    return 2;
  }
  if (o.json) {
    nlohmann::json j{{"scene", scene.name}, {"frames", frames}};
    AddBodyVolumeJson(scene, &j);
    std::cout << j.dump() << std::endl;
  } else {
    PrintBodyVolume(scene);
  }
  if (!write_status.ok()) {
    std::cerr << "kgd simulate: " << write_status.message() << "\n";
    return 2;
  }
  if (!o.out.empty() && !o.json) std::printf("wrote                 %s ... %s\n", FramePath(o.out, 0).c_str(), FramePath(o.out, static_cast<int>(r->size()) - 1).c_str());
  return all_converged ? 0 : 3;
}

int RunSimulate(const SimulateOptions& o) {
  const auto t_scene = std::chrono::steady_clock::now();
  Result<SceneSpec> scene = ResolveScene(o.scene, o.body);
  SetupTimes setup;
  setup.scene_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t_scene).count();
  if (!scene.ok()) {
    std::cerr << "kgd simulate: " << scene.message() << "\n";
    return 2;
  }
  if (!o.method.empty()) scene->solver.method = o.method == "lbfgs" ? SolverMethod::kLbfgs : SolverMethod::kNewton;
  if (o.grad_tol > 0) scene->solver.grad_tol = o.grad_tol;
  if (o.max_iterations >= 0) scene->solver.max_iterations = o.max_iterations;
  if (o.verbose) scene->solver.diagnose_steps = true;
  if (o.verbose)
    scene->solver.on_iteration = [](const IterationInfo& i) {
      std::fprintf(stderr, "iter %4d  %s\n", i.iteration, DescribeIteration(i).c_str());
    };
  if (o.design == "all_cloth") scene->design.assign(scene->design.size(), kCloth);
  if (o.design == "all_reinforced") scene->design.assign(scene->design.size(), kReinforced);
  if (o.frames) return RunFrames(o, *scene);
  const auto t_simulate = std::chrono::steady_clock::now();
  Result<SimulationResult> r = SimulateScene(*scene);
  if (!r.ok()) {
    std::cerr << "kgd simulate: " << r.message() << "\n";
    return 2;
  }
  setup.model_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t_simulate).count() - r->solve.seconds;
  Result<std::vector<OtherMotion>> others = SimulateOtherMotions(*scene);
  if (!others.ok()) {
    std::cerr << "kgd simulate: " << others.message() << "\n";
    return 2;
  }
  if (o.json) {
    nlohmann::json j = ResultJson(*scene, *r);
    AddBodyVolumeJson(*scene, &j);
    if (o.profile) j["profile"] = ProfileJson(setup, r->solve);
    // A scene of several motions (bodies): each, the scene's own first.
    if (!others->empty()) {
      const std::vector<SceneMotion> motions = MotionsOf(*scene);
      nlohmann::json list = nlohmann::json::array();
      auto add = [&](const SceneMotion& m, const nlohmann::json& result) {
        nlohmann::json e{{"name", m.name}, {"role", ToString(m.role)}, {"weight", m.weight}};
        e.update(result);
        e.erase("scene");
        list.push_back(e);
      };
      add(motions[0], j);
      for (const OtherMotion& other : *others) add(other.motion, ResultJson(*scene, other.result));
      j[scene->bodies.empty() ? "motions" : "bodies"] = list;
    }
    std::cout << j.dump() << std::endl;
  } else {
    PrintHuman(*scene, *r);
    PrintOtherMotions(*scene, *others);
    PrintBodyVolume(*scene);
    if (o.profile) PrintProfile(setup, r->solve);
  }
  if (!o.out.empty()) {
    const Status s = WriteResultPly(o.out, *scene, *r);
    if (!s.ok()) {
      std::cerr << "kgd simulate: " << s.message() << "\n";
      return 2;
    }
    if (!o.json) std::printf("wrote                 %s\n", o.out.c_str());
  }
  bool all = r->solve.at_equilibrium();
  for (const OtherMotion& other : *others) all &= other.result.solve.at_equilibrium();
  return all ? 0 : 3;
}

}  // namespace

void AddSimulateCommands(CLI::App& app, int* exit_code) {
  auto opts = std::make_shared<SimulateOptions>();
  CLI::App* sim = app.add_subcommand("simulate", "Simulate a scene to equilibrium in its deformed pose");
  sim->add_option("scene", opts->scene, "Scene file (JSON) or the name of a built-in scene (see `kgd scenes`)")->required();
  sim->add_flag("--json", opts->json, "Print the result as one JSON object (SI units)");
  sim->add_flag("-v,--verbose", opts->verbose, "Print every solver iteration to stderr");
  sim->add_flag("--profile", opts->profile,
                "Say which energy terms the scene built and where the time went: set-up, assembly, factorization, "
                "solves, line search, each term's evaluations, body-field queries");
  sim->add_flag("--frames", opts->frames,
                "Simulate every frame of the scene's motion in order (each warm-started from the previous); "
                "with --out, one PLY per frame (NAME_frame_01.ply, ...)");
  sim->add_option("--body", opts->body,
                  "A measurement of the parametric body for the paper's scenes, name=value in SI (repeatable), e.g. "
                  "--body upper_arm_circumference_m=0.32 --body height_m=1.80");
  sim->add_option("--design", opts->design, "Override the design: all_cloth or all_reinforced")
      ->check(CLI::IsMember({"all_cloth", "all_reinforced"}));
  sim->add_option("--out", opts->out, "Write the equilibrium as PLY with per-face design and energy density");
  sim->add_option("--method", opts->method, "Override the solver: newton or lbfgs")->check(CLI::IsMember({"newton", "lbfgs"}));
  sim->add_option("--grad-tol", opts->grad_tol, "Override the dimensionless gradient tolerance (default 1e-7)")
      ->check(CLI::PositiveNumber);
  sim->add_option("--max-iterations", opts->max_iterations, "Override the iteration limit")->check(CLI::NonNegativeNumber);
  sim->callback([opts, exit_code] { *exit_code = RunSimulate(*opts); });

  CLI::App* scenes = app.add_subcommand("scenes", "List the built-in scenes");
  scenes->callback([exit_code] {
    // The solves' share of each prediction is this machine's (job/cost_calibration.h).
    const MachineFactor machine = ReadMachineFactor(LocalCostCalibrationFile());
    std::printf("%-26s %-12s %-7s %-7s %-7s %-18s %-9s %-42s %s\n", "name", "garment", "faces", "budget", "frames", "predicted (s)",
                "symmetric", "motions (role weight)", "description");
    for (const BuiltinSceneInfo& s : BuiltinSceneInfos()) {
      // The whole design job per preset (draft / standard / precise), core/beso/quality.h.
      const std::map<std::string, double> seconds = PredictedSceneSeconds(s, machine.factor);
      std::string predicted;
      for (const QualityPreset& q : QualityPresets())
        predicted += (predicted.empty() ? "" : "/") + std::to_string(static_cast<int>(std::lround(seconds.at(q.name))));
      std::string motions;
      for (const BuiltinSceneInfo::Motion& m : s.motions) {
        char weight[32];
        std::snprintf(weight, sizeof weight, "%g", m.weight);
        motions += (motions.empty() ? "" : ", ") + m.name + (s.body_objective.empty() ? " (" + std::string(ToString(m.role)) + " " + weight + ")" : std::string());
      }
      // A scene of several bodies weighs its bodies as motions: their names and what it weighs of them.
      if (!s.body_objective.empty()) motions = "bodies " + motions + " (" + s.body_objective + ")";
      std::printf("%-26s %-12s %-7d %-7.2f %-7s %-18s %-9s %-42s %s\n", s.name.c_str(), s.garment.empty() ? "-" : s.garment.c_str(),
                  s.garment_faces, s.budget, s.frames ? std::to_string(s.frames).c_str() : "-", predicted.c_str(), s.symmetric ? "yes" : "no",
                  motions.c_str(), s.description.c_str());
    }
    if (machine.jobs > 0) std::printf("predicted: draft/standard/precise, the solves at %.2fx the reference machine (learned from the design jobs run here: %d)\n", machine.factor, machine.jobs);
    else std::printf("predicted: draft/standard/precise on the reference machine (a design job finished here tunes them to this one)\n");
    std::printf("design constraints: kgd design/submit --symmetric (mirror symmetry about the body's sagittal plane, x = 0); in a scene "
                "file, garment.keep_out, garment.keep_in and garment.symmetry (kgd scene keys)\n");
    *exit_code = 0;
  });

  auto name = std::make_shared<std::string>();
  auto dir = std::make_shared<std::string>();
  auto body = std::make_shared<std::vector<std::string>>();
  CLI::App* scene = app.add_subcommand("scene", "Work with scenes");
  scene->require_subcommand(1);
  CLI::App* exp = scene->add_subcommand("export", "Write a built-in scene as plain files (scene.json, meshes, index lists)");
  exp->add_option("name", *name, "Built-in scene name")->required();
  exp->add_option("dir", *dir, "Output directory")->required();
  exp->add_option("--body", *body, "A measurement of the parametric body, name=value in SI (repeatable)");
  exp->callback([name, dir, body, exit_code] {
    Result<SceneSpec> s = ResolveBuiltinScene(*name, *body);
    Status st = s.ok() ? ExportScene(*s, *dir) : s.status();
    if (!st.ok()) {
      std::cerr << "kgd scene export: " << st.message() << "\n";
      *exit_code = 2;
      return;
    }
    std::cout << "wrote " << (std::filesystem::path(*dir) / "scene.json").string() << "\n";
    *exit_code = 0;
  });

  CLI::App* keys = scene->add_subcommand("keys", "List every key of a scene file: section, key, what it holds (SI units)");
  keys->callback([exit_code] {
    std::string section;
    for (const SceneKey& k : SceneKeys()) {
      if (section != k.section) std::printf("%s%s\n", section.empty() ? "" : "\n", k.section);
      section = k.section;
      std::printf("  %-26s %s\n", k.key, k.what);
    }
    *exit_code = 0;
  });
}

}  // namespace kgd::cli
