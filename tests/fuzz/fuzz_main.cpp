// kgd_fuzz: a mutation harness over the inputs kgd takes from outside (`make fuzz` under the
// sanitizers; a few hundred cases per target in `make test` as the ctest fuzz_smoke).
//
//   scene    scene files and their meshes (LoadScene), mutated: the pull-test examples, a small scene
//            with a body motion written at the start, and scenes with a body exported at the start
//            (`kgd scene export`, --body-scenes)
//   proto    job specs with uploaded scene files as protobuf bytes and as JSON (the HTTP layer's
//            parser), pull-test and body scenes, iteration records and garments (RecordFromProto,
//            GarmentFromProto), mutated
//   design   design files (ReadDesignFile, and DesignFileWriter::Reopen's repair), mutated bytes
//   http     a real kgd-server --http with --auth-tokens and a finished job (the small motion scene
//            uploaded, run by a kgd-worker, which then stops, so that the jobs the cases create stay
//            queued): raw requests over loopback to every route (the job's iterations, cut files,
//            evaluation frames and baselines, watch, arrays) with real and mutated ids, JSON and
//            multipart bodies, valid, other users', unknown and mutated tokens, and mutated headers
//            (Content-Type, Content-Length, Transfer-Encoding, Last-Event-ID, Range, huge headers, odd
//            methods and versions, broken head bytes)
//
// Every case of the first three runs in a child process with a time limit, so that a crash or a hang is
// caught and named (target, case, seed) rather than ending the run. Each HTTP case must be answered
// (a request whose framing the case broke may instead be closed), never with a 5xx, never with a 2xx
// to a request without a valid token or to another user's (or a worker's) request for the finished
// job, and the server must stay up; before the cases, the finished job's routes are checked to answer
// (so that the cases reach them) and absurd export options to be refused by name. Mutations: bit flips,
// random bytes, deleted, duplicated or truncated ranges, and tokens that break parsers (numbers at the
// edges, NaN, empty strings, deep nesting). Exit 0: no crash, hang or internal error; 1: some (listed).
//
//   kgd_fuzz --source DIR --kgd KGD --server KGD_SERVER --worker KGD_WORKER [--cases N] [--seed S]
//            [--targets scene,proto,design,http] [--body-scenes sleeve_on_limb,arm_flexion]
#include <arpa/inet.h>
#include <google/protobuf/util/json_util.h>
#include <netinet/in.h>
#include <poll.h>
#include <signal.h>
#include <sys/socket.h>
#include <sys/wait.h>
#include <unistd.h>

#include <CLI/CLI.hpp>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <functional>
#include <nlohmann/json.hpp>
#include <random>
#include <regex>
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

namespace kgd {
namespace {
namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

std::string ReadBytes(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}
void WriteBytes(const std::string& path, const std::string& bytes) { std::ofstream(path, std::ios::binary) << bytes; }

const std::vector<std::string>& Tokens() {
  static const std::vector<std::string> tokens = {"-1", "0", "1e308", "-1e308", "1e-320", "nan", "NaN", "inf", "\"\"", "[]", "{}", "null",
                                                  "999999999999", "-2147483649", "2147483647", "65536", "true", "\"\\u0000\"", "[[[[[[[[[[[[[[[[",
                                                  "{\"a\":{\"a\":{\"a\":{", ",", ":", "\"", "\n", "f 1 2 99999999\n", "v nan 0 0\n"};
  return tokens;
}

// One to four mutations of `in`.
std::string Mutate(std::string s, std::mt19937_64& rng) {
  const std::vector<std::string>& tokens = Tokens();
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

template <typename T>
const T& Pick(const std::vector<T>& v, std::mt19937_64& rng) {
  return v[rng() % v.size()];
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
  std::string source, kgd, server, worker;
  int cases = 500;
  int scene_cases = -1;  // -1: `cases`
  uint64_t seed = 1;
  std::string targets = "scene,proto,design,http";
  std::string body_scenes = "sleeve_on_limb,arm_flexion";
};

// A scene with its files: the scene files of a folder (`scenes`) and every file they may name (`files`,
// relative to `dir`).
struct SeedScenes {
  std::string name;
  fs::path dir;
  std::vector<std::string> scenes, files;
};

SeedScenes FolderSeeds(const std::string& name, const fs::path& dir, const std::vector<std::string>& scenes) {
  SeedScenes s{name, fs::absolute(dir), scenes, {}};
  for (const auto& e : fs::recursive_directory_iterator(dir))
    if (e.is_regular_file()) s.files.push_back(fs::relative(e.path(), dir).string());
  std::sort(s.files.begin(), s.files.end());
  return s;
}

// A small scene with a body motion, written into `dir`: a closed cylinder (radius 4 cm, 30 cm long,
// 602 vertices) whose middle bulges by 6 % in the deformed pose and 3 % in the first of two frames, a
// garment cut from the band of its side between 6 and 18 cm of the 25 rings, attached at the band's
// ends. A design job on it takes well under a second, and its evaluation has frames.
void WriteMotionScene(const fs::path& dir) {
  fs::create_directories(dir);
  const double r = 0.04, length = 0.3, pi = 3.14159265358979323846;
  const int around = 24, rings = 25, band_lo = 6, band_hi = 18;
  auto write_pose = [&](const std::string& name, double bulge, bool lists) {
    std::ofstream out(dir / name), region, attach;
    if (lists) region.open(dir / "region.txt"), attach.open(dir / "attachment_body_faces.txt");
    char line[96];
    for (int j = 0; j < rings; ++j) {
      const double y = -length / 2 + length * j / (rings - 1), radius = r * (1 + bulge * std::exp(-(y / 0.06) * (y / 0.06)));
      for (int i = 0; i < around; ++i) {
        std::snprintf(line, sizeof line, "v %.9g %.9g %.9g\n", radius * std::cos(2 * pi * i / around), y, radius * std::sin(2 * pi * i / around));
        out << line;
      }
    }
    out << "v 0 " << -length / 2 << " 0\nv 0 " << length / 2 << " 0\n";
    int face = 0;
    for (int j = 0; j + 1 < rings; ++j)
      for (int i = 0; i < around; ++i) {
        const int a = j * around + i + 1, b = j * around + (i + 1) % around + 1, c = a + around, d = b + around;
        out << "f " << a << " " << c << " " << b << "\nf " << b << " " << c << " " << d << "\n";
        for (int k = 0; k < 2; ++k, ++face) {
          if (j >= band_lo && j < band_hi) region << face << "\n";
          if (j == band_lo || j == band_hi - 1) attach << face << "\n";
        }
      }
    const int bottom = rings * around + 1, top = bottom + 1;
    for (int i = 0; i < around; ++i)
      out << "f " << bottom << " " << i + 1 << " " << (i + 1) % around + 1 << "\nf " << top << " " << (rings - 1) * around + (i + 1) % around + 1 << " "
          << (rings - 1) * around + i + 1 << "\n";
  };
  write_pose("rest.obj", 0, true);
  write_pose("deformed.obj", 0.06, false);
  write_pose("frame_1.obj", 0.03, false);
  std::ofstream(dir / "scene.json") << R"({
  "name": "fuzz_motion",
  "body": {"rest": "rest.obj", "deformed": "deformed.obj", "frames": ["frame_1.obj", "deformed.obj"], "support_scale": 2.0},
  "garment": {"region": "region.txt", "subdivisions": 0, "design": "all_cloth"},
  "materials": {"lame": "solid3d", "cloth": {"youngs_modulus_Pa": 5e5, "poisson_ratio": 0.33, "thickness_m": 0.00027},
                "reinforced": {"youngs_modulus_Pa": 5.7e6, "poisson_ratio": 0.33, "thickness_m": 0.00035}},
  "effects": {"membrane": true, "relaxation": "exact", "fold_barrier": true, "contact": "unilateral", "friction": 0.0, "attachments": true,
              "clamps": false, "bending": false},
  "contact": {"stiffness_N_per_m": 5000.0},
  "attachments": {"body_faces": "attachment_body_faces.txt", "stiffness_N_per_m": 3000.0},
  "solver": {"method": "newton", "grad_tol": 1e-4}
}
)";
}

// The seeds: the pull-test examples, the small motion scene (WriteMotionScene), and each of
// `body_scenes` exported by `kgd scene export` into `dir`. A scene with motion frames keeps its first
// two, so that a case loads in well under a second.
Result<std::vector<SeedScenes>> MakeSeeds(const Options& o, const std::string& dir) {
  std::vector<SeedScenes> seeds;
  const fs::path examples = fs::path(o.source) / "examples" / "pull_test";
  std::vector<std::string> pull;
  for (const auto& e : fs::directory_iterator(examples))
    if (e.path().extension() == ".json") pull.push_back(e.path().filename().string());
  std::sort(pull.begin(), pull.end());
  seeds.push_back(FolderSeeds("pull_test", examples, pull));
  WriteMotionScene(fs::path(dir) / "seeds" / "motion");
  seeds.push_back(FolderSeeds("motion", fs::path(dir) / "seeds" / "motion", {"scene.json"}));
  std::stringstream names(o.body_scenes);
  for (std::string name; std::getline(names, name, ',');) {
    if (name.empty()) continue;
    const fs::path out = fs::path(dir) / "seeds" / name;
    if (std::system((o.kgd + " scene export " + name + " " + out.string() + " > " + dir + "/export.log 2>&1").c_str()) != 0)
      return Status::Error("cannot export the built-in scene " + name + " with " + o.kgd + " (" + dir + "/export.log)");
    const std::string scene_path = (out / "scene.json").string();
    nlohmann::json scene = nlohmann::json::parse(ReadBytes(scene_path), nullptr, false);
    if (scene.is_discarded()) return Status::Error(scene_path + ": not JSON");
    if (scene.contains("body") && scene["body"].contains("frames") && scene["body"]["frames"].size() > 2) {
      nlohmann::json& frames = scene["body"]["frames"];
      for (size_t k = 2; k < frames.size(); ++k) fs::remove(out / frames[k].get<std::string>());
      frames.erase(frames.begin() + 2, frames.end());
      WriteBytes(scene_path, scene.dump(2));
    }
    seeds.push_back(FolderSeeds(name, out, {"scene.json"}));
  }
  return seeds;
}

// A copy of `seed` in `work` whose file `victim` is mutated; the other files are links to the seed's.
void LayOut(const SeedScenes& seed, const fs::path& work, const std::string& victim, std::mt19937_64& rng) {
  fs::remove_all(work);
  for (const std::string& f : seed.files) {
    fs::create_directories((work / f).parent_path());
    if (f == victim)
      WriteBytes((work / f).string(), Mutate(ReadBytes((seed.dir / f).string()), rng));
    else
      fs::create_symlink(seed.dir / f, work / f);
  }
}

void FuzzScene(const Options& o, const std::string& dir, const std::vector<SeedScenes>& seeds, std::vector<Finding>* findings) {
  for (int i = 0; i < o.scene_cases; ++i) {
    std::mt19937_64 rng(o.seed * 1000003 + i);
    // Half the cases on the pull-test examples, half on the body scenes.
    const SeedScenes& seed = rng() % 2 ? seeds[0] : seeds[1 + rng() % (seeds.size() - 1)];
    const std::string scene = Pick(seed.scenes, rng);
    // Mostly the scene file; sometimes a mesh or a list it names.
    const std::string victim = rng() % 5 < 3 ? scene : Pick(seed.files, rng);
    const fs::path work = fs::path(dir) / "scene";
    LayOut(seed, work, victim, rng);
    const std::string path = (work / scene).string();
    const std::string what = InChild([&] { return LoadScene(path).ok(); }, 20);
    if (!what.empty()) findings->push_back({"scene", i, what + " (" + seed.name + "/" + victim + ")"});
  }
}

// A job spec uploading the scene `scene` of `seed` with all its files.
v1::JobSpec UploadSpec(const SeedScenes& seed, const std::string& scene, std::string* error) {
  v1::JobSpec spec;
  Result<v1::Scene> parsed = ParseSceneJson(ReadBytes((seed.dir / scene).string()), scene);
  if (!parsed.ok()) {
    *error = seed.name + ": " + parsed.message();
    return spec;
  }
  *spec.mutable_scene_files()->mutable_scene() = *parsed;
  for (const std::string& f : seed.files)
    if (f != scene && !f.ends_with(".json")) (*spec.mutable_scene_files()->mutable_files())[f] = ReadBytes((seed.dir / f).string());
  return spec;
}

void FuzzProto(const Options& o, const std::string& seed_file, const std::vector<SeedScenes>& seeds, std::vector<Finding>* findings) {
  // The specs: the pull test's all-cloth scene, and each body scene.
  std::vector<std::string> spec_json, spec_bytes;
  for (size_t k = 0; k < seeds.size(); ++k) {
    std::string error;
    const v1::JobSpec spec = UploadSpec(seeds[k], k == 0 ? "all_cloth.json" : seeds[k].scenes[0], &error);
    if (!error.empty()) {
      findings->push_back({"proto", -1, "seed scene: " + error});
      return;
    }
    spec_json.emplace_back();
    (void)google::protobuf::util::MessageToJsonString(spec, &spec_json.back());
    spec_bytes.push_back(spec.SerializeAsString());
  }
  Result<DesignFile> file = ReadDesignFile(seed_file);
  if (!file.ok() || file->iterations.empty()) {
    findings->push_back({"proto", -1, "seed design file: " + file.message()});
    return;
  }
  const std::string record = RecordToProto(file->iterations.back()).SerializeAsString();
  const std::string garment = GarmentToProto(file->header).SerializeAsString();
  const int faces = static_cast<int>(file->header.garment.faces.rows()), vertices = static_cast<int>(file->header.garment.vertices.rows());
  for (int i = 0; i < o.cases; ++i) {
    std::mt19937_64 rng(o.seed * 2000003 + i);
    const int kind = static_cast<int>(rng() % 4);
    // The pull test's spec as often as all the body scenes' together.
    const size_t spec = rng() % 2 ? 0 : 1 + rng() % (seeds.size() - 1);
    const std::string what = InChild(
        [&] {
          switch (kind) {
            case 0: {  // a job spec as the HTTP door parses it, then validated and turned into a scene
              v1::JobSpec s;
              return google::protobuf::util::JsonStringToMessage(Mutate(spec_json[spec], rng), &s).ok() && ValidateJobSpec(s).ok() &&
                     SceneOfJob(s).ok();
            }
            case 1: {  // the same as gRPC bytes
              v1::JobSpec s;
              return s.ParseFromString(Mutate(spec_bytes[spec], rng)) && ValidateJobSpec(s).ok() && SceneOfJob(s).ok();
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
    if (!what.empty())
      findings->push_back({"proto", i, what + " (" + kinds[kind] + (kind < 2 ? ", " + seeds[spec].name : std::string()) + ")"});
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

// ---- http ----

// A request as bytes: the head as given (method, target, version, headers) so that any of it can be
// broken, Host and Connection: close added, Content-Length from the body unless the case sets its own.
struct HttpCase {
  std::string method = "GET", target, version = "HTTP/1.1";
  std::vector<std::pair<std::string, std::string>> headers;
  std::string body;
  bool content_length = true;  // add Content-Length: body size (POST, or a body)
  bool mutate_head = false;    // the head's bytes mutated as a whole
  bool may_close = false;      // the case broke the framing: closing without an answer is an answer
  std::string who;             // whose credentials it carries
  bool valid_token = false;    // a token of this server's (the finished job's owner's or not)
  std::string what;            // for the report: method, target and the mutations
};

std::string Bytes(const HttpCase& c, std::mt19937_64& rng) {
  std::string head = c.method + " " + c.target + " " + c.version + "\r\nHost: 127.0.0.1\r\nConnection: close\r\n";
  for (const auto& [name, value] : c.headers) head += name + ": " + value + "\r\n";
  if (c.content_length && (c.method == "POST" || !c.body.empty())) head += "Content-Length: " + std::to_string(c.body.size()) + "\r\n";
  if (c.mutate_head) head = Mutate(head, rng);
  return head + "\r\n" + c.body;
}

struct HttpAnswer {
  int status = -1;
  std::string head, body;
};

// The answer to a request sent over a fresh loopback connection: the status (-1: the connection closed
// with none; -2: none within `timeout_s`) and, for a 5xx, the start of the body; other bodies are kept
// to `keep` bytes, and an event stream's (a watch, which lasts while its job runs) only with
// `whole_stream`. With `half_close` the sending side is closed after the request, so that a server
// waiting for bytes that never come (a Content-Length beyond the body) sees their end rather than its
// read timeout; cpp-httplib may then drop its answer, as for a client gone.
struct ExchangeOptions {
  size_t keep = 4096;
  bool whole_stream = false, half_close = false;
};
HttpAnswer Exchange(int port, const std::string& request, double timeout_s, const ExchangeOptions& options = {}) {
  HttpAnswer a;
  const int s = socket(AF_INET, SOCK_STREAM, 0);
  sockaddr_in addr{};
  addr.sin_family = AF_INET;
  addr.sin_port = htons(static_cast<uint16_t>(port));
  addr.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  if (connect(s, reinterpret_cast<sockaddr*>(&addr), sizeof addr) != 0) {
    close(s);
    return a;
  }
  const auto end = Clock::now() + std::chrono::duration<double>(timeout_s);
  auto left_ms = [&] { return static_cast<int>(std::max<long long>(0, std::chrono::duration_cast<std::chrono::milliseconds>(end - Clock::now()).count())); };
  // Send while reading: a server may answer (413, 400) and close before taking a large body.
  size_t sent = 0;
  bool closed = false, shut = false;
  std::string in;
  size_t head_end = std::string::npos, body_wanted = 0;
  while (true) {
    if (sent == request.size() && !shut) {
      if (options.half_close) shutdown(s, SHUT_WR);
      shut = true;
    }
    pollfd p{s, static_cast<short>(POLLIN | (shut ? 0 : POLLOUT)), 0};
    const int ms = left_ms();
    if (ms == 0 || poll(&p, 1, ms) <= 0) break;
    if (p.revents & POLLIN || p.revents & (POLLHUP | POLLERR)) {
      char buf[8192];
      const ssize_t n = recv(s, buf, sizeof buf, 0);
      if (n <= 0) {
        closed = true;
        break;
      }
      in.append(buf, static_cast<size_t>(n));
      if (head_end == std::string::npos && (head_end = in.find("\r\n\r\n")) != std::string::npos) {
        a.head = in.substr(0, head_end);
        a.status = a.head.rfind("HTTP/", 0) == 0 && a.head.size() > 12 ? std::atoi(a.head.c_str() + 9) : -1;
        const bool stream = a.head.find("text/event-stream") != std::string::npos;
        body_wanted = a.status >= 500 ? 300 : stream && !options.whole_stream ? 0 : options.keep;
      }
      if (head_end != std::string::npos && in.size() - head_end - 4 >= body_wanted) break;
    } else if (p.revents & POLLOUT) {
      const ssize_t n = send(s, request.data() + sent, request.size() - sent, MSG_NOSIGNAL);
      if (n <= 0)
        sent = request.size();  // the server closed its side: read what it said
      else
        sent += static_cast<size_t>(n);
    }
  }
  close(s);
  if (head_end != std::string::npos)
    a.body = in.substr(head_end + 4);
  else
    a.status = closed || !in.empty() ? -1 : -2;
  if (head_end != std::string::npos && a.status <= 0) a.status = -1;
  return a;
}

struct Server {
  test_support::Process server, worker;
  int http_port = 0, grpc_port = 0;
};

const char* const kAlice = "fuzz-alice-token-0123456789abcdef";
const char* const kBob = "fuzz-bob-token-0123456789abcdef";
const char* const kRoot = "fuzz-root-token-0123456789abcdef";
const char* const kWorker = "fuzz-worker-token-0123456789abcdef";

// GET `target` as alice (or `token`): the answer, waiting `timeout_s`.
HttpAnswer Get(int port, const std::string& target, const std::string& token = kAlice, double timeout_s = 30, size_t keep = 1 << 20) {
  std::string req = "GET " + target + " HTTP/1.1\r\nHost: 127.0.0.1\r\nConnection: close\r\n";
  if (!token.empty()) req += "Authorization: Bearer " + token + "\r\n";
  return Exchange(port, req + "\r\n", timeout_s, {.keep = keep, .whole_stream = true});
}

// The value of "key": "..." or "key": N in a JSON text (the first), or "".
std::string JsonField(const std::string& json, const std::string& key) {
  std::smatch m;
  if (std::regex_search(json, m, std::regex("\"" + key + "\":\\s*\"?([^\",}]*)"))) return m[1];
  return "";
}

// A multipart/form-data body of `parts` (name, filename, content).
std::string Multipart(const std::vector<std::array<std::string, 3>>& parts, const std::string& boundary) {
  std::string body;
  for (const auto& [name, filename, content] : parts)
    body += "--" + boundary + "\r\nContent-Disposition: form-data; name=\"" + name + "\"" + (filename.empty() ? "" : "; filename=\"" + filename + "\"") +
            "\r\nContent-Type: application/octet-stream\r\n\r\n" + content + "\r\n";
  return body + "--" + boundary + "--\r\n";
}

// The finished job: its id, its last iteration, its evaluation's frames and baselines.
struct FinishedJob {
  std::string id;
  int iterations = 0, frames = 0;
  std::vector<std::string> baselines;
};

// A server with tokens and a job finished by a kgd-worker, which is then stopped. "" or what failed.
std::string StartWithFinishedJob(const Options& o, const std::string& dir, const SeedScenes& motion, Server* s, FinishedJob* job) {
  std::ofstream(dir + "/tokens") << kAlice << " alice user\n" << kBob << " bob user\n" << kRoot << " root admin\n" << kWorker << " w worker\n";
  s->http_port = test_support::FreePort();
  s->grpc_port = test_support::FreePort();
  const std::string grpc = "127.0.0.1:" + std::to_string(s->grpc_port);
  s->server = test_support::Process::Spawn({o.server, "--data", dir + "/http-data", "--listen", grpc, "--http", "127.0.0.1:" + std::to_string(s->http_port),
                                            "--quiet", "--max-upload-mb", "4", "--auth-tokens", dir + "/tokens", "--max-jobs-per-minute", "0",
                                            "--max-queued-per-user", "0"},
                                           dir + "/server.log");
  const auto until = [](double seconds, const std::function<bool()>& done) {
    const auto end = Clock::now() + std::chrono::duration<double>(seconds);
    while (!done()) {
      if (Clock::now() > end) return false;
      std::this_thread::sleep_for(std::chrono::milliseconds(50));
    }
    return true;
  };
  if (!until(60, [&] { return Get(s->http_port, "/v1/scenes", kAlice, 5).status == 200; })) return "the server did not answer (" + dir + "/server.log)";
  s->worker = test_support::Process::Spawn({o.worker, "--server", grpc, "--name", "fuzz", "--token", kWorker}, dir + "/worker.log");
  // The motion scene uploaded with its files: a job of two iterations, evaluated over two frames.
  std::vector<std::array<std::string, 3>> parts = {{"scene", "scene.json", ReadBytes((motion.dir / "scene.json").string())},
                                                   {"spec", "spec.json", R"({"optimizer": {"budget": 0.5, "maxIterations": 2}, "label": "fuzz"})"}};
  for (const std::string& f : motion.files)
    if (f != "scene.json") parts.push_back({f, f, ReadBytes((motion.dir / f).string())});
  const std::string body = Multipart(parts, "kgdfuzz");
  const HttpAnswer created = Exchange(s->http_port,
                                      std::string("POST /v1/jobs HTTP/1.1\r\nHost: 127.0.0.1\r\nConnection: close\r\nAuthorization: Bearer ") + kAlice +
                                          "\r\nContent-Type: multipart/form-data; boundary=kgdfuzz\r\nContent-Length: " + std::to_string(body.size()) +
                                          "\r\n\r\n" + body,
                                      30);
  job->id = JsonField(created.body, "id");
  if (created.status != 200 || job->id.empty()) return "cannot create the job: " + std::to_string(created.status) + " " + created.body;
  std::string state;
  if (!until(600, [&] {
        state = JsonField(Get(s->http_port, "/v1/jobs/" + job->id, kAlice, 10).body, "state");
        return state == "SUCCEEDED" || state == "FAILED" || state == "CANCELLED";
      }) ||
      state != "SUCCEEDED")
    return "the job did not succeed (state " + state + "; " + dir + "/worker.log)";
  HttpAnswer evaluation;
  if (!until(60, [&] { return (evaluation = Get(s->http_port, "/v1/jobs/" + job->id + "/evaluation")).status == 200; }))
    return "the finished job has no evaluation: " + evaluation.body;
  s->worker.Signal(SIGKILL);
  s->worker.Wait();
  job->iterations = std::atoi(JsonField(Get(s->http_port, "/v1/jobs/" + job->id).body, "iterations").c_str());
  for (size_t at = 0; (at = evaluation.body.find("\"name\"", at)) != std::string::npos; ++at) job->baselines.push_back(JsonField(evaluation.body.substr(at, 200), "name"));
  const std::string frames = evaluation.body.substr(0, evaluation.body.find("\"baselines\""));
  for (size_t at = 0; (at = frames.find("\"solveStatus\"", at)) != std::string::npos; ++at) ++job->frames;
  return "";
}

// The finished job's routes answer, so that the cases reach them, and absurd export options are
// refused by name; another user's request is NOT_FOUND and one without a token UNAUTHENTICATED.
void CheckReach(int port, const FinishedJob& job, std::vector<Finding>* findings) {
  const std::string j = "/v1/jobs/" + job.id;
  struct Expect {
    std::string target, token;
    int status;
    std::string says;
  };
  const std::vector<Expect> expects = {
      {j, kAlice, 200, "SUCCEEDED"},
      {j + "/iterations/-1", kAlice, 200, "\"record\""},
      {j + "/iterations/0/positions.f32", kAlice, 200, ""},
      {j + "/iterations/-1/cut/report.json", kAlice, 200, "\"pieces\""},
      {j + "/evaluation", kAlice, 200, "\"frames\""},
      {j + "/evaluation/frames/1/positions.f32", kAlice, 200, ""},
      {j + "/evaluation/frames/2/body.f32", kAlice, 200, ""},
      {j + "/evaluation/baselines/line/design.u8", kAlice, 200, ""},
      {j + ":watch", kAlice, 200, "event: "},
      {j + "/iterations/-1/cut/patches.svg?sheetWidthMm=inf", kAlice, 400, "sheetWidthMm 'inf' is not a finite number"},
      {j + "/iterations/-1/cut/patches.svg?sheetWidthMm=1e300", kAlice, 400, "sheet width (--sheet-width-mm, sheetWidthMm) 1e+300 mm"},
      {j + "/iterations/-1/cut/pattern.svg?seamAllowanceMm=nan", kAlice, 400, "seamAllowanceMm 'nan'"},
      {j + "/iterations/-1/cut/pattern.svg?minFeatureMm=1e6", kAlice, 400, "minimum feature (--min-feature-mm, minFeatureMm) 1e+06 mm"},
      {j, kBob, 404, "NOT_FOUND"},
      {j + "/evaluation", kWorker, 403, "PERMISSION_DENIED"},
      {j, "", 401, "UNAUTHENTICATED"},
  };
  for (const Expect& e : expects) {
    const HttpAnswer a = Get(port, e.target, e.token, 60);
    if (a.status != e.status || a.body.find(e.says) == std::string::npos)
      findings->push_back({"http", -1, "GET " + e.target + " as " + (e.token.empty() ? "no one" : e.token == kAlice ? "alice" : e.token == kBob ? "bob" : "the worker") + ": expected " +
                                           std::to_string(e.status) + " saying '" + e.says + "', got " + std::to_string(a.status) + " " + a.body.substr(0, 200)});
  }
}


// A route of the finished job (or another id), with its parameters drawn.
std::string Route(const FinishedJob& job, std::mt19937_64& rng) {
  static const std::vector<std::string> numbers = {"-1", "0", "1", "2", "3", "-2", "99", "1e9", "x", "", "2147483648", "9223372036854775808", "00", "+1", "0x1"};
  const std::string id = rng() % 4 ? job.id : Pick(std::vector<std::string>{"0", "-1", "2", "3", "999999", "abc", "1.0", "9223372036854775808", job.id + "0"}, rng);
  const std::string it = rng() % 3 ? std::to_string(static_cast<int>(rng() % (job.iterations + 1)) - 1) : Pick(numbers, rng);
  const std::string j = "/v1/jobs/" + id;
  switch (rng() % 12) {
    case 0:
      return j + Pick(std::vector<std::string>{"", "/iterations/" + it, "/iterations/" + it + "?withGarment=true", "/design-file"}, rng);
    case 1:
    case 2:
      return j + "/iterations/" + it + "/" + Pick(std::vector<std::string>{"positions.f32", "energy.f32", "design.u8", "design.ply"}, rng);
    case 3:
    case 4: {  // cut files with options from the edges
      static const std::vector<std::string> values = {"3", "0", "-0", "-1", "inf", "-inf", "nan", "1e308", "1e-320", "0x10", "", "305", "100", "100.0001",
                                                      "1e4", "10000.5", "abc", "5e-324", " 3", "3 "};
      std::string q;
      for (const char* p : {"minFeatureMm", "seamAllowanceMm", "sheetWidthMm", "mirror"})
        if (rng() % 3 == 0) q += std::string(q.empty() ? "?" : "&") + p + "=" + (std::string(p) == "mirror" ? Pick(std::vector<std::string>{"false", "true", "0", ""}, rng) : Pick(values, rng));
      return j + "/iterations/" + it + "/cut/" +
             Pick(std::vector<std::string>{"pattern.svg", "pattern.dxf", "pattern.png", "patches.svg", "patches.dxf", "patches.png", "report.json", "x.svg"}, rng) + q;
    }
    case 5:
    case 6: {
      const std::string frame = rng() % 3 ? std::to_string(rng() % (job.frames + 2)) : Pick(numbers, rng);
      const std::string baseline = !job.baselines.empty() && rng() % 3 ? Pick(job.baselines, rng) : Pick(std::vector<std::string>{"line", "x", "", "..", "Line"}, rng);
      return j + Pick(std::vector<std::string>{"/evaluation", "/evaluation/frames/" + frame + "/positions.f32", "/evaluation/frames/" + frame + "/body.f32",
                                               "/evaluation/frames/" + frame + "/energy.f32", "/evaluation/baselines/" + baseline + "/positions.f32",
                                               "/evaluation/baselines/" + baseline + "/design.u8", "/evaluation/baselines/" + baseline + "/energy.f32"},
                      rng);
    }
    case 7:
      return j + Pick(std::vector<std::string>{"/garment/faces.u32", "/garment/rest.f32", "/body/vertices.f32", "/body/faces.u32"}, rng);
    case 8:
      return j + Pick(std::vector<std::string>{":watch", ":watch?fromIteration=" + it, ":watch?view=metrics", ":watch?fromIteration=" + it + "&view=metrics"}, rng);
    case 9:
      return Pick(std::vector<std::string>{"/v1/jobs", "/v1/jobs?state=SUCCEEDED&pageSize=5", "/v1/jobs?state=QUEUED", "/v1/jobs?state=nope",
                                           "/v1/jobs?pageSize=-1", "/v1/jobs?pageSize=1001", "/v1/jobs?pageToken=" + it, "/v1/jobs?pageSize=1&pageToken=abc"},
                  rng);
    case 10:
      return Pick(std::vector<std::string>{"/v1/scenes", "/metrics", "/v1/", "/v1", "/v1/jobs/", "/v1/jobs/" + id + "/", "/v1/jobs/" + id + ":nothing"}, rng);
    default:
      return Pick(std::vector<std::string>{"/", "/index.html", "/vendor/../../../../etc/passwd", "/..%2f..%2f..%2fetc%2fpasswd", "/%00", "/v1/%2e%2e/metrics",
                                           "/v1/jobs/" + id + "/iterations/%2e%2e/positions.f32"},
                  rng);
  }
}

void FuzzHttp(const Options& o, const std::string& dir, const std::vector<SeedScenes>& seeds, std::vector<Finding>* findings) {
  Server s;
  FinishedJob job;
  if (const std::string error = StartWithFinishedJob(o, dir, seeds[1] /* the motion scene */, &s, &job); !error.empty()) {
    findings->push_back({"http", -1, error});
    return;
  }
  std::printf("http    a finished job %s: %d iterations, %d evaluated frames, baselines %zu\n", job.id.c_str(), job.iterations, job.frames, job.baselines.size());
  CheckReach(s.http_port, job, findings);
  // Bodies: JSON specs, and multipart uploads of the pull test and of the body scenes (those under
  // the server's 4 MiB upload limit).
  const std::vector<std::string> bodies = {R"({"builtinScene": "sleeve_on_limb", "optimizer": {"budget": 0.3, "maxIterations": 5}, "label": "x"})",
                                           R"({"builtinScene": "arm_flexion", "body": ["height_m=1.7"], "optimizer": {"er": 0.02}})",
                                           R"({"builtinScene": "pull_test_x", "optimizer": {"budget": 0.5, "gradTol": 1e-6, "newtonMaxIterations": 20}})"};
  std::vector<std::vector<std::array<std::string, 3>>> uploads;
  for (const SeedScenes& seed : seeds) {
    const std::string scene = seed.name == "pull_test" ? "all_cloth.json" : seed.scenes[0];
    std::vector<std::array<std::string, 3>> parts = {{"scene", scene, ReadBytes((seed.dir / scene).string())}};
    size_t bytes = 0;
    for (const std::string& f : seed.files)
      if (!f.ends_with(".json")) parts.push_back({f, f, ReadBytes((seed.dir / f).string())}), bytes += parts.back()[2].size();
    if (bytes < (3u << 20)) uploads.push_back(parts);
  }
  const std::string spec_part = R"({"optimizer": {"budget": 0.5, "maxIterations": 3}, "label": "upload"})";
  const std::regex alices_job("^/v1/jobs/" + job.id + "([/:?].*)?$");
  int closed = 0;
  for (int i = 0; i < o.cases; ++i) {
    std::mt19937_64 rng(o.seed * 4000037 + i);
    HttpCase c;
    const int kind = static_cast<int>(rng() % 10);
    if (kind < 2) {
      c.method = "POST", c.target = "/v1/jobs", c.body = Mutate(Pick(bodies, rng), rng);
      c.headers.push_back({"Content-Type", "application/json"});
    } else if (kind < 4) {
      c.method = "POST", c.target = "/v1/jobs";
      std::vector<std::array<std::string, 3>> parts = Pick(uploads, rng);
      if (rng() % 2) parts.push_back({"spec", "spec.json", spec_part});
      if (rng() % 8 == 0) parts.erase(parts.begin() + static_cast<long>(rng() % parts.size()));
      std::array<std::string, 3>& victim = parts[rng() % parts.size()];
      victim[2] = Mutate(victim[2], rng);
      if (rng() % 8 == 0) victim[0] = Mutate(victim[0], rng);
      const std::string boundary = "kgdfuzz" + std::to_string(rng() % 100000);
      c.body = Multipart(parts, boundary);
      if (rng() % 6 == 0) c.body = Mutate(c.body, rng);  // the multipart framing itself
      c.headers.push_back({"Content-Type", "multipart/form-data; boundary=" + boundary});
    } else if (kind == 4) {
      c.method = "POST";
      c.target = "/v1/jobs/" + (rng() % 2 ? job.id : Pick(std::vector<std::string>{"1", "2", "0", "x", "-1", "99999999999999999999"}, rng)) + ":cancel";
    } else {
      c.target = Route(job, rng);
      if (rng() % 3 == 0) {
        c.target = Mutate(c.target, rng);
        // Keep it a request line: no spaces or control characters in the target.
        for (char& ch : c.target)
          if (static_cast<unsigned char>(ch) <= ' ' || static_cast<unsigned char>(ch) >= 127) ch = 'x';
        if (c.target.empty() || c.target[0] != '/') c.target = "/" + c.target;
      }
    }
    // Whose request: the owner, an admin, another user, the worker, no one, unknown and broken tokens.
    const std::string mutated = Mutate(kAlice, rng);
    switch (rng() % 20) {
      case 0:
      case 1:
        c.who = "root", c.valid_token = true, c.headers.push_back({"Authorization", std::string("Bearer ") + kRoot});
        break;
      case 2:
      case 3:
        c.who = "bob", c.valid_token = true, c.headers.push_back({"Authorization", std::string("Bearer ") + kBob});
        break;
      case 4:
        c.who = "worker", c.valid_token = true, c.headers.push_back({"Authorization", std::string("Bearer ") + kWorker});
        break;
      case 5:
        c.who = "no one";
        break;
      case 6:
        c.who = "an unknown token", c.headers.push_back({"Authorization", "Bearer not-a-token-of-this-server"});
        break;
      case 7: {
        std::string t = mutated;
        t.erase(std::remove_if(t.begin(), t.end(), [](char ch) { return ch == ' ' || ch == '\t'; }), t.end());
        c.who = "a mutated token", c.valid_token = t == kAlice;
        c.headers.push_back({"Authorization", "Bearer " + mutated});
        c.may_close = mutated.find_first_of("\r\n") != std::string::npos;
        break;
      }
      case 8:
        c.who = Pick(std::vector<std::string>{"Basic", "Bearer", "bearer alice", "two tokens"}, rng);
        c.headers.push_back({"Authorization", c.who == "Basic" ? "Basic YWxpY2U6cHc=" : c.who == "Bearer" ? "Bearer" : c.who == "bearer alice" ? std::string("bearer ") + kAlice
                                                                                                                                             : std::string("Bearer ") + kAlice + " " + kBob});
        c.valid_token = c.who == "bearer alice";  // the scheme is case-insensitive (RFC 9110 11.1)
        if (c.who == "bearer alice") c.who = "alice";
        break;
      case 9:
        c.who = "alice (cookie)";
        c.headers.push_back({"Cookie", std::string("theme=dark; kgd_token=") + kAlice});
        break;
      case 10:
        c.who = "a broken cookie", c.headers.push_back({"Cookie", "kgd_token=" + mutated + "; kgd_token="});
        c.may_close = mutated.find_first_of("\r\n") != std::string::npos;
        break;
      default:
        c.who = "alice", c.valid_token = true, c.headers.push_back({"Authorization", std::string("Bearer ") + kAlice});
    }
    // Header mutations, on four cases in ten.
    std::string mutations;
    if (rng() % 10 < 4) {
      switch (rng() % 12) {
        case 0: {
          const std::string type = Pick(std::vector<std::string>{"", "text/plain", "application/json; charset=utf-8", "multipart/form-data", "multipart/form-data; boundary=",
                                                                 "multipart/form-data; boundary=other", "application/jsonx", "application/x-www-form-urlencoded", "*/*"},
                                        rng);
          c.headers.erase(std::remove_if(c.headers.begin(), c.headers.end(), [](const auto& h) { return h.first == "Content-Type"; }), c.headers.end());
          c.headers.push_back({"Content-Type", type});
          mutations = "Content-Type: " + type;
          break;
        }
        case 1: {
          const std::string length = Pick(std::vector<std::string>{std::to_string(c.body.size() + 1 + rng() % 100), std::to_string(c.body.size() / 2), "-1", "abc",
                                                                    "99999999999999999999", "0", " 5", "1e3"},
                                          rng);
          c.content_length = false, c.may_close = true;
          c.headers.push_back({"Content-Length", length});
          if (rng() % 4 == 0) c.headers.push_back({"Content-Length", std::to_string(c.body.size())});
          mutations = "Content-Length: " + length;
          break;
        }
        case 2:
          c.content_length = false, c.may_close = true;
          c.headers.push_back({"Transfer-Encoding", "chunked"});
          if (rng() % 2) {  // well formed, perhaps cut
            std::ostringstream chunked;
            chunked << std::hex << c.body.size() << "\r\n" << c.body << "\r\n0\r\n\r\n";
            c.body = chunked.str();
            if (rng() % 2) c.body.resize(rng() % (c.body.size() + 1));
          }
          mutations = "Transfer-Encoding: chunked";
          break;
        case 3: {
          const std::string from = Pick(std::vector<std::string>{"", "0", "-1", "1", "2", "99999999999", "abc", "2147483647", "2147483648", " 1", "1.5", "-0"}, rng);
          c.target = "/v1/jobs/" + job.id + ":watch";
          c.headers.push_back({"Last-Event-ID", from});
          mutations = "Last-Event-ID: " + from;
          break;
        }
        case 4: {
          const std::string range =
              Pick(std::vector<std::string>{"bytes=0-10", "bytes=-5", "bytes=10-0", "bytes=0-0,5-6", "bytes=999999999-", "bytes=abc", "bytes=0-", "items=0-1",
                                            "bytes=" + std::string(200, '0') + "-1", "bytes=0-1,0-1,0-1,0-1,0-1,0-1,0-1,0-1,0-1,0-1,0-1,0-1,0-1,0-1,0-1"},
                   rng);
          c.headers.push_back({"Range", range});
          mutations = "Range: " + range;
          break;
        }
        case 5:  // huge headers
          c.may_close = true;
          if (rng() % 2)
            c.headers.push_back({"X-Fill", std::string(1024 * (1 + rng() % 128), 'a')}), mutations = "a huge header";
          else
            for (int k = 0; k < 300; ++k) c.headers.push_back({"X-Fill-" + std::to_string(k), "b"}), mutations = "300 headers";
          break;
        case 6:
          c.method = Pick(std::vector<std::string>{"PUT", "DELETE", "PATCH", "OPTIONS", "HEAD", "TRACE", "CONNECT", "FOO", "get", "POST"}, rng);
          c.may_close = c.method == "CONNECT" || c.method == "HEAD";  // HEAD: an answer with no body
          mutations = "method " + c.method;
          break;
        case 7:
          c.version = Pick(std::vector<std::string>{"HTTP/1.0", "HTTP/2", "HTTP/9.9", "HTTP/1.1x", "http/1.1", ""}, rng);
          c.may_close = true;
          mutations = "version '" + c.version + "'";
          break;
        case 8:
          c.mutate_head = true, c.may_close = true;
          mutations = "head bytes mutated";
          break;
        case 9: {
          const std::string encoding = Pick(std::vector<std::string>{"br", "gzip", "gzip, br", "*", "deflate;q=0", "identity;q=0, *;q=0"}, rng);
          c.headers.push_back({"Accept-Encoding", encoding});
          mutations = "Accept-Encoding: " + encoding;
          break;
        }
        case 10:  // a second of each header
          c.headers.insert(c.headers.end(), c.headers.begin(), c.headers.end());
          mutations = "headers doubled";
          break;
        default:
          c.target += std::string(c.target.find('?') == std::string::npos ? "?" : "&") + "q=" + std::string(1024 * (1 + rng() % 64), 'q');
          c.may_close = true;
          mutations = "a long target";
      }
    }
    if (c.who == "alice (cookie)") c.valid_token = c.method == "GET";  // the cookie is taken on GET requests only
    c.what = c.method + " " + (c.target.size() > 160 ? c.target.substr(0, 160) + "..." : c.target) + " as " + c.who + (mutations.empty() ? "" : ", " + mutations);
    const HttpAnswer a = Exchange(s.http_port, Bytes(c, rng), 60, {.half_close = c.may_close});
    const std::string said = " " + a.body.substr(0, 200);
    if (a.status == -2)
      findings->push_back({"http", i, c.what + ": no answer in 60 s"});
    else if (a.status == -1 && !c.may_close)
      findings->push_back({"http", i, c.what + ": the connection closed with no answer"});
    else if (a.status >= 500)
      findings->push_back({"http", i, c.what + ": " + std::to_string(a.status) + said});
    else if (a.status >= 200 && a.status < 300 && !c.valid_token && !c.mutate_head && (c.target.rfind("/v1/", 0) == 0 || c.target.rfind("/metrics", 0) == 0))
      findings->push_back({"http", i, c.what + ": answered " + std::to_string(a.status) + " without a valid token"});
    else if (a.status >= 200 && a.status < 300 && (c.who == "bob" || c.who == "worker") && !c.mutate_head && std::regex_match(c.target, alices_job))
      findings->push_back({"http", i, c.what + ": answered " + std::to_string(a.status) + " with alice's job"});
    else if (a.body.find("root:x:0:0") != std::string::npos)
      findings->push_back({"http", i, c.what + ": answered with /etc/passwd"});
    else if (a.status == -1)
      ++closed;
    else
      ++(a.status == 200 ? accepted : refused);
    if (waitpid(s.server.pid, nullptr, WNOHANG) != 0) {
      findings->push_back({"http", i, c.what + ": the server died (" + dir + "/server.log)"});
      s.server.pid = -1;
      return;
    }
  }
  std::printf("http    %d requests with broken framing closed without an answer\n", closed);
}

}  // namespace
}  // namespace kgd

int main(int argc, char** argv) {
  using namespace kgd;
  Options o;
  CLI::App app("kgd_fuzz: mutation harness over kgd's inputs");
  app.add_option("--source", o.source, "The repository (for examples/)")->required();
  app.add_option("--kgd", o.kgd, "The kgd binary (makes the seed design file and exports the body scenes)")->required();
  app.add_option("--server", o.server, "The kgd-server binary")->required();
  app.add_option("--worker", o.worker, "The kgd-worker binary (runs the HTTP target's finished job)")->required();
  app.add_option("--cases", o.cases, "Cases per target")->capture_default_str();
  app.add_option("--scene-cases", o.scene_cases, "Cases of the scene target (the cheapest; default: --cases)");
  app.add_option("--seed", o.seed, "Seed of the mutations")->capture_default_str();
  app.add_option("--targets", o.targets, "Comma-separated: scene, proto, design, http")->capture_default_str();
  app.add_option("--body-scenes", o.body_scenes, "Built-in scenes with a body whose exported files seed the scene, proto and http targets")
      ->capture_default_str();
  CLI11_PARSE(app, argc, argv);
  const std::string dir = (fs::temp_directory_path() / ("kgd_fuzz_" + std::to_string(getpid()))).string();
  fs::create_directories(dir);
  const auto t0 = Clock::now();
  const std::string seed_file = dir + "/seed.h5";
  if (std::system((o.kgd + " design pull_test_all_cloth --budget 0.6 --er 0.05 --ar-max 0.05 --iterations 3 --out " + seed_file + " > /dev/null 2>&1").c_str()) != 0) {
    std::fprintf(stderr, "kgd_fuzz: cannot make the seed design file with %s\n", o.kgd.c_str());
    return 2;
  }
  Result<std::vector<SeedScenes>> seeds = MakeSeeds(o, dir);
  if (!seeds.ok()) {
    std::fprintf(stderr, "kgd_fuzz: %s\n", seeds.message().c_str());
    return 2;
  }
  std::printf("seeds   %.1f s:", std::chrono::duration<double>(Clock::now() - t0).count());
  for (const SeedScenes& s : *seeds) std::printf(" %s (%zu files)", s.name.c_str(), s.files.size());
  std::printf("\n");
  std::vector<Finding> findings;
  auto wants = [&](const std::string& t) { return ("," + o.targets + ",").find("," + t + ",") != std::string::npos; };
  if (o.scene_cases < 0) o.scene_cases = o.cases;
  auto report = [&](const char* target) {
    std::printf("%-7s %d cases, %.1f s: %d accepted, %d refused with an error; %zu findings so far\n", target,
                std::string(target) == "scene" ? o.scene_cases : o.cases,
                std::chrono::duration<double>(Clock::now() - t0).count(), accepted, refused, findings.size());
    accepted = refused = 0;
    std::fflush(stdout);
  };
  if (wants("scene")) FuzzScene(o, dir, *seeds, &findings), report("scene");
  if (wants("proto")) FuzzProto(o, seed_file, *seeds, &findings), report("proto");
  if (wants("design")) FuzzDesignFile(o, dir, seed_file, &findings), report("design");
  if (wants("http")) FuzzHttp(o, dir, *seeds, &findings), report("http");
  for (const Finding& f : findings) std::printf("FINDING %s case %d (seed %llu): %s\n", f.target.c_str(), f.index, static_cast<unsigned long long>(o.seed), f.what.c_str());
  if (findings.empty()) fs::remove_all(dir);
  std::printf("%s\n", findings.empty() ? "no crash, hang or internal error" : ("kept " + dir).c_str());
  return findings.empty() ? 0 : 1;
}
