#include "client/body_command.h"

#include <cstdio>
#include <filesystem>
#include <iostream>
#include <memory>
#include <numbers>
#include <stdexcept>

#include "core/mesh/mesh_io.h"

namespace kgd::cli {
namespace {

Result<double> ParseNumber(const std::string& option, const std::string& item, const std::string& text) {
  try {
    size_t used = 0;
    const double v = std::stod(text, &used);
    if (used == text.size()) return v;
  } catch (const std::exception&) {
  }
  return Status::Error(option + " " + item + ": '" + text + "' is not a number");
}

// `name=degrees` items into joint angles (rad).
Result<JointAngles> ParseAngles(const std::string& option, const std::vector<std::string>& items) {
  JointAngles out;
  for (const std::string& item : items) {
    const size_t eq = item.find('=');
    if (eq == std::string::npos) return Status::Error(option + " " + item + ": expected name=degrees, e.g. r_elbow_flex=100");
    Result<double> v = ParseNumber(option, item, item.substr(eq + 1));
    if (!v.ok()) return v.status();
    out[item.substr(0, eq)] = *v * std::numbers::pi / 180.0;
  }
  if (Status st = ValidateJointAngles(out); !st.ok()) return st.WithContext(option + ": ");
  return out;
}

struct BodyOptions {
  std::string dir;
  std::vector<std::string> body, rest, pose;
  int frames = 0;
};

int RunBody(const BodyOptions& o) {
  auto fail = [](const std::string& m) {
    std::cerr << "kgd body: " << m << "\n";
    return 2;
  };
  Result<std::optional<BodyMeasurements>> m = ParseBodyMeasurements(o.body);
  if (!m.ok()) return fail(m.message());
  Result<JointAngles> rest = ParseAngles("--rest", o.rest), pose = ParseAngles("--pose", o.pose);
  if (!rest.ok()) return fail(rest.message());
  if (!pose.ok()) return fail(pose.message());
  Result<ParametricBody> body = BuildParametricBody(m->value_or(BodyMeasurements{}));
  if (!body.ok()) return fail(body.message());
  Result<std::vector<Positions>> poses = PoseSequence(*body, MotionKeyframes(*rest, *pose, o.frames));
  if (!poses.ok()) return fail(poses.message());
  const std::filesystem::path dir(o.dir);
  std::error_code ec;
  std::filesystem::create_directories(dir / (o.frames > 0 ? "frames" : ""), ec);
  if (ec) return fail(o.dir + ": cannot create directory: " + ec.message());
  const Faces& faces = body->rest.faces;
  std::vector<std::pair<std::string, const Positions*>> files = {{"rest.obj", &poses->front()}, {"pose.obj", &poses->back()}};
  for (int k = 1; k <= o.frames; ++k) {
    char name[32];
    std::snprintf(name, sizeof name, "frames/frame_%02d.obj", k);
    files.emplace_back(name, &(*poses)[k]);
  }
  for (const auto& [name, x] : files)
    if (Status st = WriteObj((dir / name).string(), *x, faces); !st.ok()) return fail(st.message());
  std::printf("wrote %s (%ld vertices, %ld faces): rest.obj, pose.obj", o.dir.c_str(), (long)body->rest.vertices.rows(),
              (long)faces.rows());
  if (o.frames > 0) std::printf(", %s ... %s", files[2].first.c_str(), files.back().first.c_str());
  std::printf("\n");
  return 0;
}

}  // namespace

void AddBodyCommand(CLI::App& app, int* exit_code) {
  auto o = std::make_shared<BodyOptions>();
  CLI::App* cmd = app.add_subcommand("body", "Write the parametric body, made to measure, in a rest and a deformed pose (and frames) as OBJ files");
  cmd->add_option("dir", o->dir, "Output directory")->required();
  cmd->add_option("--body", o->body, "A measurement, name=value in SI (repeatable), e.g. height_m=1.80");
  cmd->add_option("--rest", o->rest, "A joint angle of the rest pose, name=degrees (repeatable); default the A-pose");
  cmd->add_option("--pose", o->pose, "A joint angle of the deformed pose, name=degrees (repeatable), e.g. r_elbow_flex=100");
  cmd->add_option("--frames", o->frames, "Also write this many frames from rest to pose (frame N = pose)")->check(CLI::Range(0, 100));
  cmd->callback([o, exit_code] { *exit_code = RunBody(*o); });
}

}  // namespace kgd::cli
