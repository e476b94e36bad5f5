#include "client/simulate_command.h"

#include <cstdio>
#include <filesystem>
#include <iostream>
#include <memory>
#include <nlohmann/json.hpp>

#include "core/mesh/mesh_io.h"
#include "core/scene/scene.h"
#include "core/scene/simulate.h"

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
};

// A scene argument is a scene file if it exists, else the name of a built-in scene.
Result<SceneSpec> ResolveScene(const std::string& arg) {
  if (std::filesystem::exists(arg)) return LoadScene(arg);
  if (arg.find('/') != std::string::npos || (arg.size() > 5 && arg.substr(arg.size() - 5) == ".json"))
    return Status::Error(arg + ": no such scene file");
  return BuiltinScene(arg);
}

nlohmann::json ResultJson(const SceneSpec& scene, const SimulationResult& r) {
  nlohmann::json j;
  j["scene"] = scene.name;
  j["status"] = ToString(r.solve.status);
  if (!r.solve.message.empty()) j["message"] = r.solve.message;
  j["energy_J"] = r.solve.energy_J;
  j["membrane_energy_J"] = r.solve.energies.membrane_J;
  j["contact_energy_J"] = r.solve.energies.contact_J;
  j["attachment_energy_J"] = r.solve.energies.attachment_J;
  j["reinforced_energy_J"] = r.reinforced_energy_J;
  j["reinforced_area_m2"] = r.reinforced_area_m2;
  j["reinforced_density_J_per_m2"] = r.reinforced_density_J_per_m2;
  j["garment_area_m2"] = r.garment_area_m2;
  j["grad_norm_N"] = r.solve.grad_norm_N;
  j["tolerance_N"] = r.solve.tolerance_N;
  j["iterations"] = r.solve.iterations;
  j["seconds"] = r.solve.seconds;
  j["factorizations"] = r.solve.factorizations;
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
  return j;
}

void PrintHuman(const SceneSpec& scene, const SimulationResult& r) {
  const SolveReport& s = r.solve;
  std::printf("scene                 %s (%ld vertices, %ld faces)\n", scene.name.c_str(), (long)r.positions.rows(),
              (long)r.face_density_Pa.size());
  std::printf("status                %s%s%s\n", ToString(s.status), s.message.empty() ? "" : ": ", s.message.c_str());
  std::printf("total energy          %.9g J  (membrane %.6g, contact %.6g, attachments %.6g)\n", s.energy_J,
              s.energies.membrane_J, s.energies.contact_J, s.energies.attachment_J);
  std::printf("reinforced energy     %.6g J over %.6g m^2 (%.1f %% of the garment)\n", r.reinforced_energy_J,
              r.reinforced_area_m2, r.garment_area_m2 > 0 ? 100.0 * r.reinforced_area_m2 / r.garment_area_m2 : 0.0);
  std::printf("reinforced density    %.6g J/m^2\n", r.reinforced_density_J_per_m2);
  std::printf("gradient norm         %.3g N (tolerance %.3g N)\n", s.grad_norm_N, s.tolerance_N);
  std::printf("iterations            %d (%d factorizations, %d PCG solves)\n", s.iterations, s.factorizations, s.pcg_solves);
  std::printf("wall time             %.3f s\n", s.seconds);
  for (const ClampForce& c : r.clamp_forces)
    std::printf("clamp %-15s (%.6g, %.6g, %.6g) N, |F| = %.6g N\n", c.name.c_str(), c.force_N.x(), c.force_N.y(),
                c.force_N.z(), c.force_N.norm());
  if (r.has_contact)
    std::printf("distance to body      min %.3g mm, max %.3g mm (IMLS field, where defined)\n", 1e3 * r.min_phi_m,
                1e3 * r.max_phi_m);
  if (r.inverted_faces > 0) std::printf("inverted faces        %d\n", r.inverted_faces);
}

int RunSimulate(const SimulateOptions& o) {
  Result<SceneSpec> scene = ResolveScene(o.scene);
  if (!scene.ok()) {
    std::cerr << "kgd simulate: " << scene.message() << "\n";
    return 2;
  }
  if (!o.method.empty()) scene->solver.method = o.method == "lbfgs" ? SolverMethod::kLbfgs : SolverMethod::kNewton;
  if (o.grad_tol > 0) scene->solver.grad_tol = o.grad_tol;
  if (o.max_iterations >= 0) scene->solver.max_iterations = o.max_iterations;
  if (o.verbose)
    scene->solver.on_iteration = [](const IterationInfo& i) {
      std::fprintf(stderr, "iter %4d  E %.12g J  |g| %.3e N  alpha %.3g  delta %.3g%s\n", i.iteration, i.energy_J,
                   i.grad_norm_N, i.step_length, i.regularization, i.used_pcg ? "  (pcg)" : "");
    };
  Result<SimulationResult> r = SimulateScene(*scene);
  if (!r.ok()) {
    std::cerr << "kgd simulate: " << r.message() << "\n";
    return 2;
  }
  if (o.json) std::cout << ResultJson(*scene, *r).dump() << std::endl;
  else PrintHuman(*scene, *r);
  if (!o.out.empty()) {
    Eigen::VectorXd design(scene->design.size());
    for (size_t f = 0; f < scene->design.size(); ++f) design[f] = scene->design[f];
    const Status s = WritePly(o.out, r->positions, scene->garment.faces,
                              {{"design", design, true}, {"energy_density_Pa", r->face_density_Pa, false}});
    if (!s.ok()) {
      std::cerr << "kgd simulate: " << s.message() << "\n";
      return 2;
    }
    if (!o.json) std::printf("wrote                 %s\n", o.out.c_str());
  }
  return r->solve.converged() ? 0 : 3;
}

}  // namespace

void AddSimulateCommands(CLI::App& app, int* exit_code) {
  auto opts = std::make_shared<SimulateOptions>();
  CLI::App* sim = app.add_subcommand("simulate", "Simulate a scene to equilibrium in its deformed pose");
  sim->add_option("scene", opts->scene, "Scene file (JSON) or the name of a built-in scene (see `kgd scenes`)")->required();
  sim->add_flag("--json", opts->json, "Print the result as one JSON object (SI units)");
  sim->add_flag("-v,--verbose", opts->verbose, "Print every solver iteration to stderr");
  sim->add_option("--out", opts->out, "Write the equilibrium as PLY with per-face design and energy density");
  sim->add_option("--method", opts->method, "Override the solver: newton or lbfgs")->check(CLI::IsMember({"newton", "lbfgs"}));
  sim->add_option("--grad-tol", opts->grad_tol, "Override the dimensionless gradient tolerance (default 1e-7)")
      ->check(CLI::PositiveNumber);
  sim->add_option("--max-iterations", opts->max_iterations, "Override the iteration limit")->check(CLI::NonNegativeNumber);
  sim->callback([opts, exit_code] { *exit_code = RunSimulate(*opts); });

  CLI::App* scenes = app.add_subcommand("scenes", "List the built-in scenes");
  scenes->callback([exit_code] {
    for (const std::string& n : BuiltinSceneNames()) std::cout << n << "\n";
    *exit_code = 0;
  });

  auto name = std::make_shared<std::string>();
  auto dir = std::make_shared<std::string>();
  CLI::App* scene = app.add_subcommand("scene", "Work with scenes");
  scene->require_subcommand(1);
  CLI::App* exp = scene->add_subcommand("export", "Write a built-in scene as plain files (scene.json, meshes, index lists)");
  exp->add_option("name", *name, "Built-in scene name")->required();
  exp->add_option("dir", *dir, "Output directory")->required();
  exp->callback([name, dir, exit_code] {
    Result<SceneSpec> s = BuiltinScene(*name);
    Status st = s.ok() ? ExportScene(*s, *dir) : s.status();
    if (!st.ok()) {
      std::cerr << "kgd scene export: " << st.message() << "\n";
      *exit_code = 2;
      return;
    }
    std::cout << "wrote " << (std::filesystem::path(*dir) / "scene.json").string() << "\n";
    *exit_code = 0;
  });
}

}  // namespace kgd::cli
