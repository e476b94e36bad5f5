// kgd_fuzz: a mutation harness over the inputs kgd takes from outside (`make fuzz`).
//
//   scene    scene files and their meshes (LoadScene): the pull-test examples, mutated
//   proto    job specs with uploaded scene files as protobuf bytes and as JSON (the HTTP layer's
//            parser), iteration records and garments (RecordFromProto, GarmentFromProto), mutated
//   design   design files (ReadDesignFile, and DesignFileWriter::Reopen's repair), mutated bytes
//   http     a real kgd-server --http: mutated JSON bodies, multipart uploads, paths and queries
//
// Every case of the first three runs in a child process with a time limit, so that a crash or a hang is
// caught and named (target, case, seed) rather than ending the run; the HTTP cases go to one server
// process, which must answer each (never 500) and stay up. Mutations: bit flips, random bytes, deleted,
// duplicated or truncated ranges, and tokens that break parsers (numbers at the edges, NaN, empty
// strings, deep nesting). Exit 0: no crash, hang or internal error; 1: some (listed).
//
//   kgd_fuzz --source DIR --kgd KGD --server KGD_SERVER [--cases N] [--seed S] [--targets scene,proto,design,http]
#include <google/protobuf/util/json_util.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <CLI/CLI.hpp>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <functional>
#include <random>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "core/scene/scene_file.h"
#include "kgd/v1/kgd.pb.h"
#include "proto/job_spec.h"
#include "proto/records.h"
#include "store/design_file.h"
#include "tests/child_process.h"
#include <httplib.h>

namespace kgd {
namespace {
namespace fs = std::filesystem;

std::string ReadBytes(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}
void WriteBytes(const std::string& path, const std::string& bytes) { std::ofstream(path, std::ios::binary) << bytes; }

// One to four mutations of `in`.
std::string Mutate(std::string s, std::mt19937_64& rng) {
  static const std::vector<std::string> tokens = {"-1", "0", "1e308", "-1e308", "1e-320", "nan", "NaN", "inf", "\"\"", "[]", "{}", "null",
                                                  "999999999999", "-2147483649", "true", "\"\\u0000\"", "[[[[[[[[[[[[[[[[",
                                                  "{\"a\":{\"a\":{\"a\":{", ",", ":", "\"", "\n", "f 1 2 99999999\n", "v nan 0 0\n"};
  const int n = 1 + static_cast<int>(rng() % 4);
  for (int k = 0; k < n; ++k) {
    const size_t size = s.size();
    const size_t at = size ? rng() % size : 0;
    const size_t len = size ? 1 + rng() % std::min<size_t>(size - at, 64) : 0;
    switch (rng() % 7) {
      case 0:
        if (size) s[at] ^= static_cast<char>(1 << (rng() % 8));
        break;
      case 1:
        if (size) s[at] = static_cast<char>(rng() % 256);
        break;
      case 2:
        s.erase(at, len);
        break;
      case 3:
        s.insert(at, s.substr(at, len));
        break;
      case 4:
        s.insert(at, tokens[rng() % tokens.size()]);
        break;
      case 5:
        if (size) s.replace(at, len, tokens[rng() % tokens.size()]);
        break;
      case 6:
        s.resize(at);
        break;
    }
  }
  return s;
}

struct Finding {
  std::string target;
  int index;
  std::string what;
};

// Inputs the code under test accepted, and refused with an error (a crash or hang is neither).
int accepted = 0, refused = 0;

// Runs `body` in a child process with a time limit: "" when it returned, else what happened. `body`
// returns whether the input was accepted.
std::string InChild(const std::function<bool()>& body, int timeout_s) {
  std::fflush(stdout);
  const pid_t pid = fork();
  if (pid == 0) {
    alarm(timeout_s);
    _exit(body() ? 10 : 0);
  }
  int status = 0;
  waitpid(pid, &status, 0);
  if (WIFEXITED(status) && (WEXITSTATUS(status) == 0 || WEXITSTATUS(status) == 10)) {
    ++(WEXITSTATUS(status) == 10 ? accepted : refused);
    return "";
  }
  if (WIFSIGNALED(status)) return WTERMSIG(status) == SIGALRM ? "hang (over " + std::to_string(timeout_s) + " s)" : std::string("crash: ") + strsignal(WTERMSIG(status));
  return "exit " + std::to_string(WEXITSTATUS(status));
}

struct Options {
  std::string source, kgd, server;
  int cases = 500;
  uint64_t seed = 1;
  std::string targets = "scene,proto,design,http";
};

void FuzzScene(const Options& o, const std::string& dir, std::vector<Finding>* findings) {
  const fs::path examples = fs::path(o.source) / "examples" / "pull_test";
  std::vector<std::string> scenes;
  for (const auto& e : fs::directory_iterator(examples))
    if (e.path().extension() == ".json") scenes.push_back(e.path().filename().string());
  std::sort(scenes.begin(), scenes.end());
  for (int i = 0; i < o.cases; ++i) {
    std::mt19937_64 rng(o.seed * 1000003 + i);
    const fs::path work = fs::path(dir) / "scene";
    fs::remove_all(work);
    fs::copy(examples, work);
    const std::string scene = scenes[rng() % scenes.size()];
    // Mostly the scene file; sometimes a mesh or a face list it names.
    std::vector<std::string> files = {scene, scene, scene, "sample.obj", "line_reinforced_faces.txt"};
    const std::string victim = (work / files[rng() % files.size()]).string();
    WriteBytes(victim, Mutate(ReadBytes(victim), rng));
    const std::string path = (work / scene).string();
    const std::string what = InChild([&] { return LoadScene(path).ok(); }, 20);
    if (!what.empty()) findings->push_back({"scene", i, what + " (" + fs::path(victim).filename().string() + ")"});
  }
}

void FuzzProto(const Options& o, const std::string& seed_file, std::vector<Finding>* findings) {
  const fs::path examples = fs::path(o.source) / "examples" / "pull_test";
  v1::JobSpec spec;
  Result<v1::Scene> scene = ParseSceneJson(ReadBytes((examples / "all_cloth.json").string()), "all_cloth.json");
  if (!scene.ok()) {
    findings->push_back({"proto", -1, "seed scene: " + scene.message()});
    return;
  }
  *spec.mutable_scene_files()->mutable_scene() = *scene;
  (*spec.mutable_scene_files()->mutable_files())["sample.obj"] = ReadBytes((examples / "sample.obj").string());
  std::string spec_json;
  (void)google::protobuf::util::MessageToJsonString(spec, &spec_json);
  Result<DesignFile> file = ReadDesignFile(seed_file);
  if (!file.ok() || file->iterations.empty()) {
    findings->push_back({"proto", -1, "seed design file: " + file.message()});
    return;
  }
  const std::string record = RecordToProto(file->iterations.back()).SerializeAsString();
  const std::string garment = GarmentToProto(file->header).SerializeAsString();
  const std::string spec_bytes = spec.SerializeAsString();
  const int faces = static_cast<int>(file->header.garment.faces.rows()), vertices = static_cast<int>(file->header.garment.vertices.rows());
  for (int i = 0; i < o.cases; ++i) {
    std::mt19937_64 rng(o.seed * 2000003 + i);
    const int kind = static_cast<int>(rng() % 4);
    const std::string what = InChild(
        [&] {
          switch (kind) {
            case 0: {  // a job spec as the HTTP door parses it, then validated and turned into a scene
              v1::JobSpec s;
              return google::protobuf::util::JsonStringToMessage(Mutate(spec_json, rng), &s).ok() && ValidateJobSpec(s).ok() && SceneOfJob(s).ok();
            }
            case 1: {  // the same as gRPC bytes
              v1::JobSpec s;
              return s.ParseFromString(Mutate(spec_bytes, rng)) && ValidateJobSpec(s).ok() && SceneOfJob(s).ok();
            }
            case 2: {
              v1::IterationRecord r;
              return r.ParseFromString(Mutate(record, rng)) && RecordFromProto(r, faces, vertices).ok();
            }
            default: {
              v1::Garment g;
              DesignFileHeader h;
              return g.ParseFromString(Mutate(garment, rng)) && GarmentFromProto(g, &h).ok();
            }
          }
        },
        20);
    static const char* kinds[] = {"JobSpec JSON", "JobSpec bytes", "IterationRecord", "Garment"};
    if (!what.empty()) findings->push_back({"proto", i, what + " (" + kinds[kind] + ")"});
  }
}

void FuzzDesignFile(const Options& o, const std::string& dir, const std::string& seed_file, std::vector<Finding>* findings) {
  const std::string original = ReadBytes(seed_file);
  for (int i = 0; i < o.cases; ++i) {
    std::mt19937_64 rng(o.seed * 3000017 + i);
    const std::string path = dir + "/design.h5";
    // HDF5 files are binary: flips and random bytes mostly, sometimes a cut.
    std::string bytes = original;
    const int n = 1 + static_cast<int>(rng() % 8);
    for (int k = 0; k < n; ++k) bytes[rng() % bytes.size()] = static_cast<char>(rng() % 256);
    if (rng() % 8 == 0) bytes.resize(rng() % bytes.size());
    WriteBytes(path, bytes);
    const bool reopen = rng() % 4 == 0;
    const std::string what = InChild(
        [&] {
          return reopen ? DesignFileWriter::Reopen(path).ok() : ReadDesignFile(path).ok();
        },
        30);
    if (!what.empty()) findings->push_back({"design", i, what + (reopen ? " (Reopen)" : " (Read)")});
  }
}

void FuzzHttp(const Options& o, const std::string& dir, std::vector<Finding>* findings) {
  const int http_port = test_support::FreePort(), grpc_port = test_support::FreePort();
  test_support::Process server = test_support::Process::Spawn(
      {o.server, "--data", dir + "/http-data", "--listen", "127.0.0.1:" + std::to_string(grpc_port), "--http", "127.0.0.1:" + std::to_string(http_port),
       "--quiet", "--max-upload-mb", "4"},
      dir + "/server.log");
  httplib::Client c("127.0.0.1", http_port);
  c.set_read_timeout(10, 0);
  for (int k = 0; k < 300 && !c.Get("/v1/scenes"); ++k) std::this_thread::sleep_for(std::chrono::milliseconds(20));
  const fs::path examples = fs::path(o.source) / "examples" / "pull_test";
  const std::vector<std::string> bodies = {R"({"builtinScene": "sleeve_on_limb", "optimizer": {"budget": 0.3, "maxIterations": 5}, "label": "x"})",
                                           R"({"builtinScene": "arm_flexion", "body": ["height_m=1.7"], "optimizer": {"er": 0.02}})"};
  const std::vector<std::string> paths = {"/v1/jobs/1", "/v1/jobs?state=QUEUED&pageSize=5", "/v1/jobs/1/iterations/-1", "/v1/jobs/1/iterations/0/positions.f32",
                                          "/v1/jobs/1/iterations/-1/cut/report.json?minFeatureMm=3", "/v1/jobs/1/evaluation", "/v1/scenes"};
  const std::string scene = ReadBytes((examples / "all_cloth.json").string()), mesh = ReadBytes((examples / "sample.obj").string());
  for (int i = 0; i < o.cases; ++i) {
    std::mt19937_64 rng(o.seed * 4000037 + i);
    std::string what;
    const int kind = static_cast<int>(rng() % 4);
    httplib::Result res = [&] {
      if (kind < 2) {
        what = "POST /v1/jobs JSON";
        return c.Post("/v1/jobs", Mutate(bodies[rng() % bodies.size()], rng), "application/json");
      }
      if (kind == 2) {
        what = "POST /v1/jobs multipart";
        const bool mutate_scene = rng() % 2;
        httplib::MultipartFormDataItems items = {{"scene", mutate_scene ? Mutate(scene, rng) : scene, "scene.json", "application/json"},
                                                 {"sample.obj", mutate_scene ? mesh : Mutate(mesh, rng), "sample.obj", "text/plain"}};
        return c.Post("/v1/jobs", items);
      }
      std::string p = Mutate(paths[rng() % paths.size()], rng);
      // Keep it a request line: no spaces or control characters in the target.
      for (char& ch : p)
        if (static_cast<unsigned char>(ch) <= ' ' || static_cast<unsigned char>(ch) >= 127) ch = 'x';
      if (p.empty() || p[0] != '/') p = "/" + p;
      what = "GET " + p;
      return c.Get(p);
    }();
    if (!res)
      findings->push_back({"http", i, what + ": no response (" + httplib::to_string(res.error()) + ")"});
    else if (res->status >= 500)
      findings->push_back({"http", i, what + ": " + std::to_string(res->status) + " " + res->body.substr(0, 200)});
    else
      ++(res->status == 200 ? accepted : refused);
    if (waitpid(server.pid, nullptr, WNOHANG) != 0) {
      findings->push_back({"http", i, what + ": the server died"});
      server.pid = -1;
      return;
    }
  }
}

}  // namespace
}  // namespace kgd

int main(int argc, char** argv) {
  using namespace kgd;
  Options o;
  CLI::App app("kgd_fuzz: mutation harness over kgd's inputs");
  app.add_option("--source", o.source, "The repository (for examples/)")->required();
  app.add_option("--kgd", o.kgd, "The kgd binary (makes the seed design file)")->required();
  app.add_option("--server", o.server, "The kgd-server binary")->required();
  app.add_option("--cases", o.cases, "Cases per target")->capture_default_str();
  app.add_option("--seed", o.seed, "Seed of the mutations")->capture_default_str();
  app.add_option("--targets", o.targets, "Comma-separated: scene, proto, design, http")->capture_default_str();
  CLI11_PARSE(app, argc, argv);
  const std::string dir = (fs::temp_directory_path() / ("kgd_fuzz_" + std::to_string(getpid()))).string();
  fs::create_directories(dir);
  const std::string seed_file = dir + "/seed.h5";
  if (std::system((o.kgd + " design pull_test_all_cloth --budget 0.6 --er 0.05 --ar-max 0.05 --iterations 3 --out " + seed_file + " > /dev/null 2>&1").c_str()) != 0) {
    std::fprintf(stderr, "kgd_fuzz: cannot make the seed design file with %s\n", o.kgd.c_str());
    return 2;
  }
  std::vector<Finding> findings;
  auto wants = [&](const std::string& t) { return ("," + o.targets + ",").find("," + t + ",") != std::string::npos; };
  const auto t0 = std::chrono::steady_clock::now();
  auto report = [&](const char* target) {
    std::printf("%-7s %d cases, %.1f s: %d accepted, %d refused with an error; %zu findings so far\n", target, o.cases,
                std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count(), accepted, refused, findings.size());
    accepted = refused = 0;
    std::fflush(stdout);
  };
  if (wants("scene")) FuzzScene(o, dir, &findings), report("scene");
  if (wants("proto")) FuzzProto(o, seed_file, &findings), report("proto");
  if (wants("design")) FuzzDesignFile(o, dir, seed_file, &findings), report("design");
  if (wants("http")) FuzzHttp(o, dir, &findings), report("http");
  for (const Finding& f : findings) std::printf("FINDING %s case %d (seed %llu): %s\n", f.target.c_str(), f.index, static_cast<unsigned long long>(o.seed), f.what.c_str());
  if (findings.empty()) fs::remove_all(dir);
  std::printf("%s\n", findings.empty() ? "no crash, hang or internal error" : ("kept " + dir).c_str());
  return findings.empty() ? 0 : 1;
}
