// The HTTP/JSON API (server/http_gateway.h) as it runs for real: a kgd-server process with --http and a
// kgd-worker process on loopback, driven by an HTTP client. Create, watch by Server-Sent Events with a
// dropped connection and a Last-Event-ID resume, cancel, fetch iterations and their binary arrays,
// upload a scene file, and bad requests each answered with its status and message.
#include <google/protobuf/util/json_util.h>
#include <google/protobuf/util/message_differencer.h>
#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <map>
#include <set>
#include <sstream>
#include <thread>

#include "core/beso/quality.h"
#include "core/mesh/mesh_io.h"
#include "kgd/v1/kgd.pb.h"
#include "tests/child_process.h"
#include "tests/kgd_cli.h"
#include "tests/studio_test_data.h"
// After the Eigen-using headers above: see server/http_gateway.cpp.
#include <httplib.h>
#include <nlohmann/json.hpp>

namespace kgd {
namespace {
namespace fs = std::filesystem;
using test_support::FreePort;
using test_support::Process;
using test_support::WaitFor;

template <typename M>
M Parse(const std::string& json) {
  M m;
  const auto st = google::protobuf::util::JsonStringToMessage(json, &m);
  EXPECT_TRUE(st.ok()) << st.message() << "\n" << json;
  return m;
}

// A kgd-server with its HTTP door and one kgd-worker; shared by the tests (one per process).
class HttpService {
 public:
  HttpService() {
    // One service per test process (ctest runs each test in its own, in parallel).
    dir_ = (fs::temp_directory_path() / ("kgd_http_api_test_" + std::to_string(getpid()))).string();
    fs::remove_all(dir_);
    fs::create_directories(dir_);
    grpc_ = "127.0.0.1:" + std::to_string(FreePort());
    const std::string& grpc = grpc_;
    port_ = FreePort();
    server_ = Process::Spawn({KGD_SERVER_BINARY, "--data", dir_ + "/data", "--listen", grpc, "--http", "127.0.0.1:" + std::to_string(port_),
                              "--max-upload-mb", "1", "--max-watchers", "3"},
                             dir_ + "/server.log");
    worker_ = Process::Spawn({KGD_WORKER_BINARY, "--server", grpc, "--name", "w0"}, dir_ + "/worker.log");
    ok_ = WaitFor([&] { return Log().find("http on") != std::string::npos; }, 30);
  }
  ~HttpService() {
    server_.Signal(SIGKILL);
    worker_.Signal(SIGKILL);
    server_.Wait();
    worker_.Wait();
    if (!::testing::UnitTest::GetInstance()->failed_test_count()) fs::remove_all(dir_);
  }
  bool ok() const { return ok_; }
  std::string Log() const {
    std::ifstream in(dir_ + "/server.log");
    return std::string(std::istreambuf_iterator<char>(in), {});
  }
  httplib::Client Client() const {
    httplib::Client c("127.0.0.1", port_);
    c.set_read_timeout(60, 0);
    return c;
  }
  int port() const { return port_; }
  const std::string& dir() const { return dir_; }
  const std::string& grpc() const { return grpc_; }

 private:
  std::string dir_, grpc_;
  int port_ = 0;
  bool ok_ = false;
  Process server_, worker_;
};

// Destroyed at exit, which kills the server and the worker.
HttpService& Service() {
  static HttpService s;
  return s;
}

class HttpApi : public ::testing::Test {
 protected:
  void SetUp() override { ASSERT_TRUE(Service().ok()) << Service().Log(); }
};

std::string SleeveJob(int iterations, const std::string& label) {
  return R"({"builtinScene": "sleeve_on_limb", "optimizer": {"budget": 0.3, "maxIterations": )" + std::to_string(iterations) +
         R"(}, "label": ")" + label + R"("})";
}

v1::Job Create(const std::string& spec_json) {
  auto res = Service().Client().Post("/v1/jobs", spec_json, "application/json");
  EXPECT_TRUE(res) << "no response";
  if (!res) return {};
  EXPECT_EQ(res->status, 200) << res->body;
  return Parse<v1::Job>(res->body);
}

v1::Job Get(const std::string& id) {
  auto res = Service().Client().Get("/v1/jobs/" + id);
  return res && res->status == 200 ? Parse<v1::Job>(res->body) : v1::Job();
}

bool Ended(const std::string& id) {
  const v1::JobState s = Get(id).state();
  return s == v1::SUCCEEDED || s == v1::FAILED || s == v1::CANCELLED;
}

// One Server-Sent Event.
struct Event {
  std::string type, id, data;
};

// Reads the watch stream of job `id` until `stop` returns true for an event (or the stream ends);
// sends Last-Event-ID when `last_event_id` is not empty.
std::vector<Event> WatchEvents(const std::string& id, const std::string& last_event_id, const std::function<bool(const Event&)>& stop) {
  std::vector<Event> events;
  std::string buffer;
  httplib::Headers headers;
  if (!last_event_id.empty()) headers.emplace("Last-Event-ID", last_event_id);
  bool stopped = false;
  auto res = Service().Client().Get("/v1/jobs/" + id + ":watch?view=metrics", headers, [&](const char* data, size_t n) {
    buffer.append(data, n);
    for (size_t end; (end = buffer.find("\n\n")) != std::string::npos;) {
      const std::string block = buffer.substr(0, end);
      buffer.erase(0, end + 2);
      Event ev;
      std::istringstream lines(block);
      for (std::string line; std::getline(lines, line);) {
        if (line.rfind("event: ", 0) == 0) ev.type = line.substr(7);
        if (line.rfind("id: ", 0) == 0) ev.id = line.substr(4);
        if (line.rfind("data: ", 0) == 0) ev.data += line.substr(6);
      }
      if (ev.type.empty()) continue;  // retry and keep-alive comments
      events.push_back(ev);
      if (stop(ev)) {
        stopped = true;
        return false;  // drop the connection
      }
    }
    return true;
  });
  if (!stopped) {
    EXPECT_TRUE(res) << "watch stream failed";
  }
  return events;
}

TEST_F(HttpApi, ScenesListTheBuiltinScenesAndTheBodyMeasurements) {
  auto res = Service().Client().Get("/v1/scenes");
  ASSERT_TRUE(res);
  ASSERT_EQ(res->status, 200) << res->body;
  EXPECT_EQ(res->get_header_value("Content-Type"), "application/json");
  const auto r = Parse<v1::ListScenesResponse>(res->body);
  std::map<std::string, v1::BuiltinScene> by_name;
  for (const auto& s : r.scenes()) by_name[s.name()] = s;
  ASSERT_TRUE(by_name.count("arm_flexion"));
  EXPECT_EQ(by_name["arm_flexion"].garment(), "sleeve_arm");
  EXPECT_DOUBLE_EQ(by_name["arm_flexion"].budget(), 0.15);
  EXPECT_EQ(by_name["arm_flexion"].frames(), 8);
  EXPECT_TRUE(by_name["arm_flexion"].parametric_body());
  EXPECT_GT(by_name["arm_flexion"].garment_faces(), 10000);
  EXPECT_GT(by_name["arm_flexion"].garment_area_m2(), 0.04);
  ASSERT_TRUE(by_name.count("pull_test_line"));
  EXPECT_FALSE(by_name["pull_test_line"].parametric_body());
  // Each scene's motions (name, role, weight; the scene's own first) and whether its garment is mirror
  // symmetric, in plain JSON the web form reads.
  const nlohmann::json listed = nlohmann::json::parse(res->body);
  std::map<std::string, nlohmann::json> json_of;
  for (const nlohmann::json& s : listed["scenes"]) json_of[s["name"]] = s;
  EXPECT_EQ(json_of["arm_brace"]["motions"], nlohmann::json::parse(R"([{"name": "straighten", "role": "resist", "weight": 1},
                                                                       {"name": "bend", "role": "allow", "weight": 15}])"));
  EXPECT_EQ(json_of["arm_brace"]["symmetric"], false);
  EXPECT_EQ(json_of["arm_flexion"]["motions"], nlohmann::json::parse(R"([{"name": "arm_flexion", "role": "resist", "weight": 1}])"));
  EXPECT_EQ(json_of["posture_shirt"]["motions"][1]["name"], "reach_forward");
  EXPECT_EQ(json_of["posture_shirt"]["symmetric"], true);
  EXPECT_EQ(json_of["slouch"]["symmetric"], true);
  EXPECT_EQ(json_of["knee_brace"]["motions"][1]["role"], "allow");
  bool height = false;
  for (const auto& m : r.body_measurements())
    if (m.name() == "height_m") height = m.default_value() == 1.70 && m.min() < 1.70 && m.max() > 1.70;
  EXPECT_TRUE(height);
}

TEST_F(HttpApi, AWatchDroppedMidJobResumesWithLastEventIdWithNoGapAndNoDuplicate) {
  const v1::Job job = Create(SleeveJob(14, "sse"));
  ASSERT_EQ(job.state(), v1::QUEUED);
  const std::string id = std::to_string(job.id());
  // First connection: drop it after iteration 4.
  std::vector<Event> first = WatchEvents(id, "", [](const Event& e) { return e.type == "iteration" && e.id == "4"; });
  ASSERT_FALSE(first.empty());
  EXPECT_EQ(first.front().type, "job");
  // Second: resume after the last id seen, to the job's end (the stream ends with it).
  std::vector<Event> second = WatchEvents(id, "4", [](const Event&) { return false; });
  std::vector<int> iterations;
  for (const auto* part : {&first, &second})
    for (const Event& e : *part)
      if (e.type == "iteration") {
        const auto rec = Parse<v1::IterationRecord>(e.data);
        EXPECT_EQ(std::to_string(rec.metrics().iteration()), e.id);
        EXPECT_TRUE(rec.design().empty()) << "view=metrics sends no design";
        iterations.push_back(rec.metrics().iteration());
      }
  const v1::Job done = Get(id);
  EXPECT_EQ(done.state(), v1::SUCCEEDED) << done.failure();
  ASSERT_EQ(static_cast<int>(iterations.size()), done.iterations());
  // A finished job teaches the cost model these workers' speed: the predictions are theirs.
  v1::ListScenesResponse scenes;
  EXPECT_TRUE(WaitFor(
      [&] {
        scenes = Parse<v1::ListScenesResponse>(Service().Client().Get("/v1/scenes")->body);
        return scenes.machine_factor_jobs() >= 1;
      },
      10));
  EXPECT_TRUE(scenes.machine_factor() > 1.0 / 20 && scenes.machine_factor() < 20) << scenes.machine_factor();
  EXPECT_TRUE(fs::exists(Service().dir() + "/data/cost_calibration.json"));
  for (const v1::BuiltinScene& b : scenes.scenes()) {
    if (b.name() != "knee_flexion") continue;
    BesoSettings settings;
    settings.budget = b.budget();
    const JobCostPrediction reference = PredictJobCost({.garment_faces = b.garment_faces(), .frames = b.frames(), .builtin_body = true}, settings);
    EXPECT_NEAR(b.predicted_job_s().at("standard"), reference.total_s(scenes.machine_factor()), 1e-6 * reference.total_s());
  }
  for (int k = 0; k < static_cast<int>(iterations.size()); ++k) EXPECT_EQ(iterations[k], k) << "a gap or a duplicate";
  // The resumed stream's last job event says the job ended.
  v1::Job last_job;
  for (const Event& e : second)
    if (e.type == "job") last_job = Parse<v1::Job>(e.data);
  EXPECT_EQ(last_job.state(), v1::SUCCEEDED);
}

// A job of two motions (knee_brace, the allowed flexion at a weight the spec gives): every iteration
// the watch stream sends (what the page's charts read) carries both motions, each at a density ratio
// of exactly 1 in the fully reinforced iteration 0 and the first one giving the iteration's own
// figures; the ended job's last metrics carry the final motions, as the design file has them. (The job
// is cancelled once iteration 0 is in, so that no evaluation is run: iteration 1 is stored when the
// worker had begun it, which depends on when the cancel reaches it.)
TEST_F(HttpApi, ATwoMotionJobsMetricsCarryEachMotionAndTheEndedJobItsFinalMotions) {
  const v1::Job job = Create(R"({"builtinScene": "knee_brace", "optimizer": {"maxIterations": 1, "motionWeights": {"flex": 0.5}}, "label": "motions"})");
  ASSERT_EQ(job.spec().optimizer().motion_weights().at("flex"), 0.5);
  const std::string id = std::to_string(job.id());
  const std::vector<Event> events = WatchEvents(id, "", [&](const Event& e) {
    if (e.type == "iteration" && e.id == "0") Service().Client().Post("/v1/jobs/" + id + ":cancel", "", "application/json");
    return false;  // to the job's end
  });
  std::vector<v1::IterationMetrics> streamed;
  for (const Event& e : events)
    if (e.type == "iteration") streamed.push_back(Parse<v1::IterationRecord>(e.data).metrics());
  const v1::Job done = Get(id);
  ASSERT_TRUE(done.state() == v1::CANCELLED || done.state() == v1::SUCCEEDED) << v1::JobState_Name(done.state()) << " " << done.failure();
  ASSERT_EQ(static_cast<int>(streamed.size()), done.iterations());
  ASSERT_GE(streamed.size(), 1u);
  ASSERT_LE(streamed.size(), 2u);
  for (const v1::IterationMetrics& m : streamed) {
    ASSERT_EQ(m.motions_size(), 2) << "iteration " << m.iteration();
    EXPECT_EQ(m.motions(0).name(), "hyperextend");
    EXPECT_EQ(m.motions(0).role(), "resist");
    EXPECT_EQ(m.motions(0).weight(), 1.0);
    EXPECT_EQ(m.motions(1).name(), "flex");
    EXPECT_EQ(m.motions(1).role(), "allow");
    EXPECT_EQ(m.motions(1).weight(), 0.5) << "the spec's weight, not the scene's 1";
    EXPECT_EQ(m.motions(0).reinforced_energy_j(), m.reinforced_energy_j());
    EXPECT_EQ(m.motions(0).density_ratio(), m.density_ratio());
    for (const v1::MotionMetrics& mm : m.motions()) {
      EXPECT_GT(mm.reinforced_energy_j(), 0) << mm.name();
      if (m.iteration() == 0) {
        EXPECT_EQ(mm.density_ratio(), 1.0) << mm.name() << ": against its own fully reinforced design";
      }
    }
  }
  // The ended job's final motions, and its last iteration read back from the design file.
  const v1::IterationMetrics& final_metrics = streamed.back();
  EXPECT_TRUE(google::protobuf::util::MessageDifferencer::Equals(done.last(), final_metrics)) << done.last().DebugString();
  auto res = Service().Client().Get("/v1/jobs/" + id + "/iterations/" + std::to_string(final_metrics.iteration()));
  ASSERT_TRUE(res && res->status == 200);
  const v1::IterationMetrics from_file = Parse<v1::GetIterationResponse>(res->body).record().metrics();
  ASSERT_EQ(from_file.motions_size(), 2);
  for (int k = 0; k < 2; ++k)
    EXPECT_TRUE(google::protobuf::util::MessageDifferencer::Equals(from_file.motions(k), final_metrics.motions(k))) << from_file.motions(k).DebugString();
}

// One sample of the Prometheus text at /metrics, e.g. Sample(text, "kgd_jobs{state=\"SUCCEEDED\"}"); -1: absent.
double Sample(const std::string& text, const std::string& series) {
  std::istringstream lines(text);
  for (std::string line; std::getline(lines, line);)
    if (line.rfind(series + " ", 0) == 0) return std::stod(line.substr(series.size() + 1));
  return -1;
}

// The design file of a job, as the server stores it.
std::string StoredDesignFile(const std::string& id) {
  std::ifstream in(Service().dir() + "/data/jobs/job-" + id + ".h5", std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), {});
}

TEST_F(HttpApi, IterationsAndTheirBinaryArraysAgreeWithTheRecord) {
  const v1::Job job = Create(SleeveJob(6, "arrays"));
  const std::string id = std::to_string(job.id());
  ASSERT_TRUE(WaitFor([&] { return Ended(id); }, 300)) << Service().Log();
  auto cli = Service().Client();
  auto res = cli.Get("/v1/jobs/" + id + "/iterations/-1?withGarment=true");
  ASSERT_TRUE(res);
  ASSERT_EQ(res->status, 200) << res->body;
  const auto it = Parse<v1::GetIterationResponse>(res->body);
  const v1::IterationRecord& rec = it.record();
  const v1::Garment& g = it.garment();
  EXPECT_EQ(rec.metrics().iteration(), Get(id).iterations() - 1);
  const int nv = g.rest_vertices_size() / 3, nf = g.faces_size() / 3;
  ASSERT_GT(nf, 0);
  ASSERT_GT(g.cloth_thickness_m(), 0);
  ASSERT_GT(g.body_faces_size(), 0) << "the sleeve's scene has a body";
  const std::string n = std::to_string(rec.metrics().iteration());

  auto bytes = [&](const std::string& path) {
    auto r = cli.Get("/v1/jobs/" + id + path);
    EXPECT_TRUE(r && r->status == 200) << path << ": " << (r ? r->body : "no response");
    if (r) {
      EXPECT_EQ(r->get_header_value("Content-Type"), "application/octet-stream") << path;
    }
    return r ? r->body : std::string();
  };
  auto floats = [](const std::string& b) {
    std::vector<float> v(b.size() / 4);
    std::memcpy(v.data(), b.data(), v.size() * 4);
    return v;
  };
  auto uints = [](const std::string& b) {
    std::vector<uint32_t> v(b.size() / 4);
    std::memcpy(v.data(), b.data(), v.size() * 4);
    return v;
  };
  const std::vector<float> x = floats(bytes("/iterations/" + n + "/positions.f32"));
  ASSERT_EQ(static_cast<int>(x.size()), 3 * nv) << "12 bytes per vertex: a 28k-vertex iteration is 336 KB";
  for (int i = 0; i < 3 * nv; ++i) ASSERT_EQ(x[i], static_cast<float>(rec.positions(i))) << i;
  const std::vector<uint32_t> faces = uints(bytes("/garment/faces.u32"));
  ASSERT_EQ(static_cast<int>(faces.size()), 3 * nf);
  for (int i = 0; i < 3 * nf; ++i) ASSERT_EQ(faces[i], static_cast<uint32_t>(g.faces(i)));
  const std::vector<float> rest = floats(bytes("/garment/rest.f32"));
  ASSERT_EQ(static_cast<int>(rest.size()), 3 * nv);
  EXPECT_EQ(rest[3 * nv - 1], static_cast<float>(g.rest_vertices(3 * nv - 1)));
  const std::string design = bytes("/iterations/" + n + "/design.u8");
  EXPECT_EQ(design, rec.design());
  const std::vector<float> energy = floats(bytes("/iterations/" + n + "/energy.f32"));
  ASSERT_EQ(static_cast<int>(energy.size()), nf);
  for (int f = 0; f < nf; ++f) {
    const double t = rec.design()[f] ? g.reinforced_thickness_m() : g.cloth_thickness_m();
    ASSERT_FLOAT_EQ(energy[f], static_cast<float>(rec.energy_density_pa(f) * t)) << f;
  }
  EXPECT_EQ(uints(bytes("/body/faces.u32")).size(), static_cast<size_t>(g.body_faces_size()));
  EXPECT_EQ(floats(bytes("/body/vertices.f32")).size(), static_cast<size_t>(g.body_vertices_size()));

  auto ply = cli.Get("/v1/jobs/" + id + "/iterations/" + n + "/design.ply");
  ASSERT_TRUE(ply && ply->status == 200);
  EXPECT_EQ(ply->body.rfind("ply\nformat binary_little_endian 1.0\n", 0), 0u);
  EXPECT_NE(ply->body.find("element face " + std::to_string(nf) + "\n"), std::string::npos);
  EXPECT_NE(ply->get_header_value("Content-Disposition").find("attachment"), std::string::npos);

  // The evaluation: no motion on this scene (it says so), the Line and X of the final design's area.
  auto ev = cli.Get("/v1/jobs/" + id + "/evaluation");
  ASSERT_TRUE(ev && ev->status == 200) << (ev ? ev->body : "no response");
  const auto evaluation = Parse<v1::DesignEvaluation>(ev->body);
  EXPECT_EQ(evaluation.iteration(), rec.metrics().iteration());
  EXPECT_EQ(evaluation.frames_size(), 0);
  EXPECT_NE(evaluation.note().find("no motion frames"), std::string::npos) << evaluation.note();
  ASSERT_EQ(evaluation.baselines_size(), 2);
  EXPECT_TRUE(evaluation.baselines(0).positions().empty()) << "arrays come as binary";
  EXPECT_NEAR(evaluation.baselines(0).area_fraction(), rec.metrics().area_fraction(), 0.02);
  EXPECT_EQ(bytes("/evaluation/baselines/line/design.u8").size(), static_cast<size_t>(nf));
  EXPECT_EQ(floats(bytes("/evaluation/baselines/x/positions.f32")).size(), static_cast<size_t>(3 * nv));
  EXPECT_EQ(floats(bytes("/evaluation/baselines/x/energy.f32")).size(), static_cast<size_t>(nf));
  // A baseline as PLY: its own design per face (after 3 + 3 int indices; then its energy density).
  const std::string line_ply = bytes("/evaluation/baselines/line/design.ply");
  const size_t body_at = line_ply.find("end_header\n") + 11;
  ASSERT_EQ(line_ply.size(), body_at + 24 * static_cast<size_t>(nv) + 22 * static_cast<size_t>(nf)) << line_ply.substr(0, 300);
  std::string line_design(nf, '\0');
  for (int f = 0; f < nf; ++f) line_design[f] = line_ply[body_at + 24 * nv + 22 * f + 13];
  EXPECT_EQ(line_design, bytes("/evaluation/baselines/line/design.u8"));
  EXPECT_NE(line_design, rec.design()) << "the Line's, not the optimized design's";
  auto no_frame = cli.Get("/v1/jobs/" + id + "/evaluation/frames/1/positions.f32");
  ASSERT_TRUE(no_frame);
  EXPECT_EQ(no_frame->status, 404);
  EXPECT_NE(no_frame->body.find("not one of"), std::string::npos) << no_frame->body;
  auto no_baseline = cli.Get("/v1/jobs/" + id + "/evaluation/baselines/zigzag/design.u8");
  ASSERT_TRUE(no_baseline);
  EXPECT_EQ(no_baseline->status, 404);

  // Cut files, made on request by geometry alone; each file of the same export after the first comes
  // from the server's cache.
  const std::string before = cli.Get("/metrics")->body;
  auto cut = cli.Get("/v1/jobs/" + id + "/iterations/" + n + "/cut/patches.svg");
  ASSERT_TRUE(cut && cut->status == 200) << (cut ? cut->body : "no response");
  EXPECT_EQ(cut->get_header_value("Content-Type"), "image/svg+xml");
  EXPECT_NE(cut->body.find("width=\"305mm\""), std::string::npos);
  auto cut_png = cli.Get("/v1/jobs/" + id + "/iterations/" + n + "/cut/patches.png");
  ASSERT_TRUE(cut_png && cut_png->status == 200) << (cut_png ? cut_png->body : "no response");
  EXPECT_EQ(cut_png->get_header_value("Content-Type"), "image/png");
  EXPECT_EQ(cut_png->body.substr(0, 8), std::string("\x89PNG\r\n\x1a\n", 8));
  auto cut_report = cli.Get("/v1/jobs/" + id + "/iterations/" + n + "/cut/report.json?sheetWidthMm=500&mirror=false");
  ASSERT_TRUE(cut_report && cut_report->status == 200) << (cut_report ? cut_report->body : "no response");
  // The server never simulates: the last design's cleaned figures are its worker's (CleanedDesign).
  EXPECT_EQ(cut_report->body.find("\"not simulated\""), std::string::npos) << cut_report->body.substr(0, 400);
  EXPECT_NE(cut_report->body.find("\"pieces\""), std::string::npos);
  auto bad_cut = cli.Get("/v1/jobs/" + id + "/iterations/" + n + "/cut/patches.svg?sheetWidthMm=wide");
  ASSERT_TRUE(bad_cut);
  EXPECT_EQ(bad_cut->status, 400);
  EXPECT_NE(bad_cut->body.find("sheetWidthMm 'wide'"), std::string::npos) << bad_cut->body;

  // The same files through the CLI over gRPC: `kgd export JOB`.
  const std::string out = Service().dir() + "/cut-" + id;
  const auto exported = cli_test::Kgd("export " + id + " --iteration " + n + " --server " + Service().grpc() + " --out " + out);
  ASSERT_EQ(exported.exit_code, 0) << exported.output;
  std::ifstream svg(out + "/patches.svg");
  EXPECT_EQ(std::string(std::istreambuf_iterator<char>(svg), {}), cut->body) << "the same file as the HTTP download";
  const std::string after = cli.Get("/metrics")->body;
  auto served = [](const std::string& text, const std::string& source) {
    const double v = Sample(text, "kgd_exports_total{source=\"" + source + "\"}");
    return v < 0 ? 0.0 : v;
  };
  EXPECT_EQ(served(after, "computed") - served(before, "computed"), 2) << "patches.svg, then report.json with other options";
  EXPECT_EQ(served(after, "cache") - served(before, "cache"), 2) << "patches.png, and kgd export with the same options";
  EXPECT_EQ(exported.output.find("export: "), std::string::npos) << "an export from the cache has no stages to report:\n" << exported.output;
  // The page fires an iteration's downloads together: the requests of one export arriving while it is
  // being made wait for it and share it.
  {
    const std::string url = "/v1/jobs/" + id + "/iterations/" + n + "/cut/patches.svg?seamAllowanceMm=9";
    std::vector<std::string> bodies(4);
    std::vector<int> statuses(4, 0);
    std::vector<std::thread> downloads;
    for (int i = 0; i < 4; ++i)
      downloads.emplace_back([&, i] {
        auto res = Service().Client().Get(url);
        if (res) statuses[i] = res->status, bodies[i] = res->body;
      });
    for (std::thread& t : downloads) t.join();
    for (int i = 0; i < 4; ++i) {
      EXPECT_EQ(statuses[i], 200) << bodies[i];
      EXPECT_EQ(bodies[i], bodies[0]);
    }
    const std::string together = cli.Get("/metrics")->body;
    EXPECT_EQ(served(together, "computed") - served(after, "computed"), 1) << "one export made for four requests";
    EXPECT_EQ(served(together, "cache") - served(after, "cache"), 3);
  }
  // A cut file's name says which iteration it is of: the one asked for, and for -1 the last stored.
  EXPECT_EQ(cut->get_header_value("Content-Disposition"), "attachment; filename=\"job-" + id + "-iteration-" + n + "-patches.svg\"");
  auto first_report = cli.Get("/v1/jobs/" + id + "/iterations/1/cut/report.json");
  ASSERT_TRUE(first_report && first_report->status == 200) << (first_report ? first_report->body : "no response");
  EXPECT_EQ(first_report->get_header_value("Content-Disposition"), "attachment; filename=\"job-" + id + "-iteration-1-report.json\"");
  EXPECT_NE(first_report->body.find("\"iteration\": 1,"), std::string::npos) << first_report->body.substr(0, 200);
  auto last_svg = cli.Get("/v1/jobs/" + id + "/iterations/-1/cut/patches.svg");
  ASSERT_TRUE(last_svg && last_svg->status == 200) << (last_svg ? last_svg->body : "no response");
  EXPECT_EQ(last_svg->get_header_value("Content-Disposition"), "attachment; filename=\"job-" + id + "-iteration-" + n + "-patches.svg\"");
  EXPECT_EQ(last_svg->body, cut->body);
  // An option outside what `kgd export` takes is refused, naming it and its range.
  auto wide_seam = cli.Get("/v1/jobs/" + id + "/iterations/" + n + "/cut/pattern.svg?seamAllowanceMm=200");
  ASSERT_TRUE(wide_seam);
  EXPECT_EQ(wide_seam->status, 400);
  EXPECT_NE(wide_seam->body.find("seamAllowanceMm) 200 mm is not a finite number in [0, 100] mm"), std::string::npos) << wide_seam->body;
  // An export the server computes streams its stages before the files.
  const auto computed = cli_test::Kgd("export " + id + " --iteration " + n + " --seam-allowance-mm 12 --server " + Service().grpc() + " --out " + out + "-12");
  ASSERT_EQ(computed.exit_code, 0) << computed.output;
  size_t at = 0;
  for (const char* stage : {"export:   0% cleaning the design for manufacture", "export:  50% cutting and flattening the pattern",
                            "export:  85% nesting and drawing the sheets"}) {
    at = computed.output.find(stage, at);
    ASSERT_NE(at, std::string::npos) << stage << " missing or out of order in:\n" << computed.output;
  }
  EXPECT_TRUE(fs::exists(out + "-12/pattern.dxf"));
  const auto unknown = cli_test::Kgd("export 987654 --server " + Service().grpc() + " --out " + out + "-unknown");
  EXPECT_EQ(unknown.exit_code, 2) << unknown.output;
  EXPECT_NE(unknown.output.find("987654"), std::string::npos) << unknown.output;
  EXPECT_FALSE(fs::exists(out + "-unknown"));

  // The design file of an ended job, byte for byte as the server stores it.
  auto h5 = cli.Get("/v1/jobs/" + id + "/design-file");
  ASSERT_TRUE(h5 && h5->status == 200);
  EXPECT_EQ(h5->body, StoredDesignFile(id));
}

TEST_F(HttpApi, CancelStopsARunningJobWhoseDesignFileIsRefusedUntilItEnds) {
  const v1::Job job = Create(SleeveJob(400, "cancel"));
  const std::string id = std::to_string(job.id());
  ASSERT_TRUE(WaitFor([&] { return Get(id).iterations() >= 2; }, 300)) << Service().Log();
  // While it runs, its design file is refused (it is still being written).
  ASSERT_EQ(Get(id).state(), v1::RUNNING);
  auto early = Service().Client().Get("/v1/jobs/" + id + "/design-file");
  ASSERT_TRUE(early);
  EXPECT_EQ(early->status, 400) << early->body;
  EXPECT_NE(early->body.find("\"status\": \"FAILED_PRECONDITION\""), std::string::npos) << early->body;
  EXPECT_NE(early->body.find("job " + id + " is RUNNING: its design file is still being written"), std::string::npos) << early->body;
  auto res = Service().Client().Post("/v1/jobs/" + id + ":cancel", "", "application/json");
  ASSERT_TRUE(res);
  ASSERT_EQ(res->status, 200) << res->body;
  EXPECT_TRUE(Parse<v1::Job>(res->body).cancel_requested() || Parse<v1::Job>(res->body).state() == v1::CANCELLED);
  ASSERT_TRUE(WaitFor([&] { return Ended(id); }, 60));
  const v1::Job done = Get(id);
  EXPECT_EQ(done.state(), v1::CANCELLED);
  EXPECT_LT(done.iterations(), 400);
  // Now that it has ended, the design file is served, byte for byte as stored.
  auto h5 = Service().Client().Get("/v1/jobs/" + id + "/design-file");
  ASSERT_TRUE(h5);
  EXPECT_EQ(h5->status, 200) << h5->body;
  EXPECT_EQ(h5->get_header_value("Content-Type"), "application/x-hdf5");
  EXPECT_EQ(h5->body.substr(0, 8), std::string("\x89HDF\r\n\x1a\n", 8));
  EXPECT_EQ(h5->body, StoredDesignFile(id));
}

TEST_F(HttpApi, AJobListIsPagedAndFilteredByState) {
  Create(SleeveJob(1, "list-a"));
  Create(SleeveJob(1, "list-b"));
  auto cli = Service().Client();
  auto first = cli.Get("/v1/jobs?pageSize=1");
  ASSERT_TRUE(first && first->status == 200);
  const auto page1 = Parse<v1::ListJobsResponse>(first->body);
  ASSERT_EQ(page1.jobs_size(), 1);
  ASSERT_FALSE(page1.next_page_token().empty());
  auto second = cli.Get("/v1/jobs?pageSize=1&pageToken=" + page1.next_page_token());
  ASSERT_TRUE(second && second->status == 200);
  const auto page2 = Parse<v1::ListJobsResponse>(second->body);
  ASSERT_EQ(page2.jobs_size(), 1);
  EXPECT_LT(page2.jobs(0).id(), page1.jobs(0).id()) << "newest first";
  // Jobs in four states at once: list-b SUCCEEDED, a long one RUNNING (the fixture's worker runs one
  // job at a time), one QUEUED behind it, and one CANCELLED while queued.
  const std::string succeeded = std::to_string(page1.jobs(0).id());
  ASSERT_TRUE(WaitFor([&] { return Ended(succeeded); }, 300));
  ASSERT_EQ(Get(succeeded).state(), v1::SUCCEEDED) << Get(succeeded).failure();
  const std::string running = std::to_string(Create(SleeveJob(400, "list-running")).id());
  ASSERT_TRUE(WaitFor([&] { return Get(running).state() == v1::RUNNING; }, 300)) << Service().Log();
  const std::string queued = std::to_string(Create(SleeveJob(1, "list-queued")).id());
  const std::string cancelled = std::to_string(Create(SleeveJob(1, "list-cancelled")).id());
  ASSERT_TRUE(cli.Post("/v1/jobs/" + cancelled + ":cancel", "", "application/json"));
  ASSERT_EQ(Get(queued).state(), v1::QUEUED);
  ASSERT_EQ(Get(cancelled).state(), v1::CANCELLED);
  const std::map<std::string, std::string> mine = {{succeeded, "SUCCEEDED"}, {running, "RUNNING"}, {queued, "QUEUED"}, {cancelled, "CANCELLED"}};
  for (const char* state : {"SUCCEEDED", "RUNNING", "QUEUED", "CANCELLED", "FAILED"}) {
    auto res = cli.Get(std::string("/v1/jobs?pageSize=1000&state=") + state);
    ASSERT_TRUE(res && res->status == 200) << state;
    const auto list = Parse<v1::ListJobsResponse>(res->body);
    std::set<std::string> listed;
    for (const auto& j : list.jobs()) {
      EXPECT_EQ(v1::JobState_Name(j.state()), state) << "job " << j.id() << " listed under state=" << state;
      listed.insert(std::to_string(j.id()));
    }
    // Of this test's four jobs, exactly the one in that state.
    for (const auto& [id, its_state] : mine)
      EXPECT_EQ(listed.count(id), its_state == state ? 1u : 0u) << "job " << id << " (" << its_state << ") under state=" << state;
  }
  cli.Post("/v1/jobs/" + queued + ":cancel", "", "application/json");
  cli.Post("/v1/jobs/" + running + ":cancel", "", "application/json");
}

TEST_F(HttpApi, AnUploadedSceneFileWithItsMeshesRuns) {
  const std::string dir = Service().dir() + "/scene";
  const auto exported = cli_test::Kgd("scene export pull_test_line " + dir);
  ASSERT_EQ(exported.exit_code, 0) << exported.output;
  httplib::MultipartFormDataItems items;
  for (const auto& entry : fs::directory_iterator(dir)) {
    std::ifstream in(entry.path(), std::ios::binary);
    const std::string content(std::istreambuf_iterator<char>(in), {});
    const std::string name = entry.path().filename().string();
    items.push_back({name == "scene.json" ? "scene" : name, content, name, "application/octet-stream"});
  }
  items.push_back({"spec", R"({"optimizer": {"budget": 0.5, "maxIterations": 3}, "label": "upload"})", "spec.json", "application/json"});
  auto res = Service().Client().Post("/v1/jobs", items);
  ASSERT_TRUE(res);
  ASSERT_EQ(res->status, 200) << res->body;
  const v1::Job job = Parse<v1::Job>(res->body);
  EXPECT_TRUE(job.spec().has_scene_files());
  EXPECT_EQ(job.spec().label(), "upload");
  const std::string id = std::to_string(job.id());
  ASSERT_TRUE(WaitFor([&] { return Ended(id); }, 300));
  EXPECT_EQ(Get(id).state(), v1::SUCCEEDED) << Get(id).failure();
  // Without the meshes the scene names, the upload is refused and says which file is missing.
  httplib::MultipartFormDataItems scene_only;
  for (const auto& item : items)
    if (item.name == "scene") scene_only.push_back(item);
  res = Service().Client().Post("/v1/jobs", scene_only);
  ASSERT_TRUE(res);
  EXPECT_EQ(res->status, 400);
  EXPECT_NE(res->body.find("INVALID_ARGUMENT"), std::string::npos) << res->body;
}

// The studio page's region check on the studio test torso (tests/data/studio): the painted half mirrored
// is the region and the bands `kgd region` wrote from sleeve_rules.txt; a refusal is kgd region's.
TEST_F(HttpApi, ARegionCheckOfThePaintedHalfMirroredIsTheRegionAndBandsOfKgdRegion) {
  const std::string& dir = kStudioDataDir;
  const std::string obj = ReadText(dir + "rest.obj");
  const Result<TriMesh> body = ParseMesh(obj, "rest.obj");
  ASSERT_TRUE(body.ok()) << body.message();
  const Positions c = FaceCentroids(body->vertices, body->faces);
  const Result<std::vector<int>> region = ReadIndexList(dir + "garment_region.txt");
  const Result<std::vector<int>> attached = ReadIndexList(dir + "attachment_body_faces.txt");
  ASSERT_TRUE(region.ok() && attached.ok());
  std::vector<int> half, keep_in;  // the region's faces with x < 0; of them, those along the lower loop
  for (int f : *region)
    if (c(f, 0) < 0) {
      half.push_back(f);
      if (c(f, 1) < 1.02) keep_in.push_back(f);
    }
  auto check = [&](const httplib::MultipartFormDataItems& parts) {
    httplib::MultipartFormDataItems items = {{"body", obj, "rest.obj", "application/octet-stream"}};
    items.insert(items.end(), parts.begin(), parts.end());
    return Service().Client().Post("/v1/regions:check", items);
  };
  auto res = check({{"faces", JoinFaces(half), "", ""}, {"mirror", "true", "", ""}, {"attachWidthM", "0.02", "", ""}, {"keepIn", JoinFaces(keep_in), "", ""}});
  ASSERT_TRUE(res);
  ASSERT_EQ(res->status, 200) << res->body;
  const nlohmann::json a = nlohmann::json::parse(res->body);
  EXPECT_TRUE(a["valid"].get<bool>()) << res->body.substr(0, 2000);
  EXPECT_TRUE(a["mirrored"].get<bool>());
  EXPECT_EQ(a["faces"].get<std::vector<int>>(), *region);
  ASSERT_EQ(a["loops"].size(), 2u);
  std::set<int> bands;
  for (const auto& b : a["bands"])
    for (int f : b["faces"]) bands.insert(f);
  EXPECT_EQ(std::vector<int>(bands.begin(), bands.end()), *attached);
  EXPECT_EQ(a["subdividedFaces"].get<int>(), 4 * static_cast<int>(region->size()));
  EXPECT_EQ(a["keepIn"].size(), 2 * keep_in.size()) << "mirrored";
  EXPECT_EQ(a["keepInGarmentFaces"].size(), 4 * 2 * keep_in.size()) << "4 garment faces per body face at subdivisions 1";
  const double draft = a["predictedJobS"]["draft"], standard = a["predictedJobS"]["standard"], precise = a["predictedJobS"]["precise"];
  EXPECT_LT(0, draft);
  EXPECT_LT(draft, standard);
  EXPECT_LT(standard, precise);

  // Two pieces (two narrower bands): refused with the words `kgd region` prints for the same faces.
  std::vector<int> two;
  for (int f : *region)
    if (c(f, 1) < 1.06 || c(f, 1) > 1.14) two.push_back(f);
  res = check({{"faces", JoinFaces(two), "", ""}});
  ASSERT_TRUE(res);
  ASSERT_EQ(res->status, 200) << res->body;
  const nlohmann::json refused = nlohmann::json::parse(res->body);
  EXPECT_FALSE(refused["valid"].get<bool>());
  const std::string words = refused["refusal"];
  const auto cli = cli_test::Kgd("region " + dir + "rest.obj --plane 0,1.0,0,0,1,0 --plane 0,1.06,0,0,-1,0 --union --plane 0,1.14,0,0,1,0 " +
                                 "--plane 0,1.2,0,0,-1,0 --out " + Service().dir() + "/two/two");
  EXPECT_EQ(cli.exit_code, 2) << cli.output;
  ASSERT_EQ(words.rfind("rest.obj: ", 0), 0u) << words;
  EXPECT_NE(cli.output.find("kgd region: " + dir + words), std::string::npos) << cli.output << "\nvs\n" << words;
  EXPECT_NE(words.find("piece"), std::string::npos) << words;
}

TEST_F(HttpApi, ARegionCheckAndASceneBodyNameThePartOfABadRequest) {
  auto cli = Service().Client();
  const std::string obj = ReadText(kStudioDataDir + "rest.obj");
  auto post = [&](httplib::MultipartFormDataItems items) { return cli.Post("/v1/regions:check", items); };
  const std::string big(2 << 20, '#');
  struct Case {
    std::string what;
    httplib::Result res;
    int http;
    std::string message;
  };
  Case cases[] = {
      {"not multipart", cli.Post("/v1/regions:check", "faces=1", "application/x-www-form-urlencoded"), 415, "multipart/form-data"},
      {"no body", post({{"faces", "1 2 3", "", ""}}), 400, "part 'body'"},
      {"a mesh line that does not parse", post({{"body", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 q\n", "torso.obj", ""}, {"faces", "0", "", ""}}), 400,
       "part 'body': torso.obj:4"},
      {"a face out of range", post({{"body", obj, "rest.obj", ""}, {"faces", "5 2480", "", ""}}), 400,
       "part 'faces': face 2480 (item 2) is out of range: the body has 2480 faces"},
      {"a bad number", post({{"body", obj, "rest.obj", ""}, {"faces", "5", "", ""}, {"subdivisions", "two", "", ""}}), 400, "part 'subdivisions': 'two'"},
      {"an empty region", post({{"body", obj, "rest.obj", ""}, {"faces", "", "", ""}}), 400, "the region is empty"},
      {"an upload beyond --max-upload-mb", post({{"body", big, "big.obj", ""}, {"faces", "1", "", ""}}), 413, "larger"},
      // The built-in body of a scene (GET /v1/scenes/{name}/body/...): measurements named in lowerCamelCase too.
      {"a scene body of an unknown scene", cli.Get("/v1/scenes/moonwalk/body/rest.obj"), 404, "there is no built-in scene 'moonwalk'"},
      {"a scene body without the parametric body", cli.Get("/v1/scenes/pull_test_line/body/rest.obj"), 404, "has no parametric body"},
      {"a scene body of an unknown measurement", cli.Get("/v1/scenes/arm_flexion/body/rest.obj?shoeSize=9"), 400, "'shoe_size' is not known"},
  };
  for (const Case& c : cases) {
    ASSERT_TRUE(c.res) << c.what;
    EXPECT_EQ(c.res->status, c.http) << c.what << ": " << c.res->body;
    EXPECT_NE(c.res->body.find(c.message), std::string::npos) << c.what << ": " << c.res->body;
  }
}

TEST_F(HttpApi, BadRequestsGetTheirStatusAndAMessageAndTheServerCarriesOn) {
  auto cli = Service().Client();
  struct Case {
    std::string what;
    std::function<httplib::Result()> send;
    int http;
    std::string status, message;
  };
  const std::string big(2 << 20, 'x');
  const std::string known = std::to_string(Create(SleeveJob(1, "known")).id());
  const std::vector<Case> cases = {
      {"malformed JSON", [&] { return cli.Post("/v1/jobs", "{\"builtinScene\": ", "application/json"); }, 400, "INVALID_ARGUMENT", "kgd.v1.JobSpec"},
      {"unknown field", [&] { return cli.Post("/v1/jobs", R"({"scene": "arm_flexion"})", "application/json"); }, 400, "INVALID_ARGUMENT", "scene"},
      {"budget out of range", [&] { return cli.Post("/v1/jobs", R"({"builtinScene": "arm_flexion", "optimizer": {"budget": 1.5}})", "application/json"); },
       400, "INVALID_ARGUMENT", "budget"},
      {"unknown scene", [&] { return cli.Post("/v1/jobs", R"({"builtinScene": "moonwalk"})", "application/json"); }, 400, "INVALID_ARGUMENT", "moonwalk"},
      {"wrong content type", [&] { return cli.Post("/v1/jobs", "builtinScene=arm_flexion", "text/plain"); }, 415, "INVALID_ARGUMENT", "text/plain"},
      {"oversize upload", [&] { return cli.Post("/v1/jobs", big, "application/json"); }, 413, "RESOURCE_EXHAUSTED", "larger"},
      {"unknown job", [&] { return cli.Get("/v1/jobs/987654"); }, 404, "NOT_FOUND", "job 987654"},
      {"job id not a number", [&] { return cli.Get("/v1/jobs/abc"); }, 400, "INVALID_ARGUMENT", "'abc'"},
      {"cancel an unknown job", [&] { return cli.Post("/v1/jobs/987654:cancel", "", "application/json"); }, 404, "NOT_FOUND", "987654"},
      {"watch an unknown job", [&] { return cli.Get("/v1/jobs/987654:watch"); }, 404, "NOT_FOUND", "987654"},
      {"iteration not stored", [&] { return cli.Get("/v1/jobs/" + known + "/iterations/100000"); }, 404, "NOT_FOUND", "100000"},
      {"iteration not a number", [&] { return cli.Get("/v1/jobs/" + known + "/iterations/last"); }, 400, "INVALID_ARGUMENT", "'last'"},
      {"bad state filter", [&] { return cli.Get("/v1/jobs?state=DONE"); }, 400, "INVALID_ARGUMENT", "DONE"},
      {"negative motion weight",
       [&] { return cli.Post("/v1/jobs", R"({"builtinScene": "knee_brace", "optimizer": {"motionWeights": {"flex": -1}}})", "application/json"); },
       400, "INVALID_ARGUMENT", "motion 'flex': weight -1 must be finite and >= 0"},
      {"unknown motion",
       [&] { return cli.Post("/v1/jobs", R"({"builtinScene": "knee_brace", "optimizer": {"motionWeights": {"kick": 1}}})", "application/json"); },
       400, "INVALID_ARGUMENT", "motion 'kick': scene 'knee_brace' has no motion of this name"},
      {"unknown resource", [&] { return cli.Get("/v2/things"); }, 404, "NOT_FOUND", "/v2/things"},
  };
  for (const Case& c : cases) {
    auto res = c.send();
    ASSERT_TRUE(res) << c.what << ": no response (" << httplib::to_string(res.error()) << ")";
    EXPECT_EQ(res->status, c.http) << c.what << ": " << res->body;
    EXPECT_EQ(res->get_header_value("Content-Type"), "application/json") << c.what;
    EXPECT_NE(res->body.find("\"status\": \"" + c.status + "\""), std::string::npos) << c.what << ": " << res->body;
    EXPECT_NE(res->body.find(c.message), std::string::npos) << c.what << ": " << res->body;
  }
  // Unharmed: it still lists, creates and runs jobs.
  const v1::Job job = Create(SleeveJob(2, "after"));
  ASSERT_TRUE(WaitFor([&] { return Ended(std::to_string(job.id())); }, 300));
  EXPECT_EQ(Get(std::to_string(job.id())).state(), v1::SUCCEEDED);
}

TEST_F(HttpApi, ThePageAndItsLibrariesAreServed) {
  auto cli = Service().Client();
  auto index = cli.Get("/");
  ASSERT_TRUE(index && index->status == 200);
  EXPECT_NE(index->body.find("<script type=\"module\" src=\"/app.js\">"), std::string::npos);
  auto app = cli.Get("/app.js");
  ASSERT_TRUE(app && app->status == 200);
  EXPECT_EQ(app->get_header_value("Content-Type"), "text/javascript");
  if (!fs::exists(fs::path(KGD_SOURCE_DIR) / "client/web/node_modules/three"))
    GTEST_SKIP() << "client/web/node_modules is not installed (npm ci --prefix client/web); the page's libraries are not served";
  auto three = cli.Get("/vendor/three/build/three.module.min.js");
  ASSERT_TRUE(three && three->status == 200);
  EXPECT_EQ(three->get_header_value("Content-Type"), "text/javascript");
  EXPECT_EQ(three->get_header_value("Cache-Control"), "public, max-age=86400");
  // A browser accepts Brotli too; the server answers with gzip (or nothing), never the slow Brotli.
  httplib::Client raw("127.0.0.1", Service().port());
  raw.set_decompress(false);
  auto packed = raw.Get("/vendor/three/build/three.module.min.js", {{"Accept-Encoding", "gzip, deflate, br"}});
  ASSERT_TRUE(packed && packed->status == 200);
  EXPECT_NE(packed->get_header_value("Content-Encoding"), "br");
  EXPECT_LT(packed->body.size(), three->body.size()) << "sent uncompressed";
}

TEST_F(HttpApi, MetricsCountJobsIterationsWritesAndWatchers) {
  const v1::Job job = Create(SleeveJob(3, "metrics"));
  const std::string id = std::to_string(job.id());
  ASSERT_TRUE(WaitFor([&] { return Ended(id); }, 300));
  auto res = Service().Client().Get("/metrics");
  ASSERT_TRUE(res && res->status == 200);
  EXPECT_EQ(res->get_header_value("Content-Type").rfind("text/plain; version=0.0.4", 0), 0u);
  const std::string& text = res->body;
  EXPECT_GE(Sample(text, "kgd_jobs{state=\"SUCCEEDED\"}"), 1) << text;
  EXPECT_GE(Sample(text, "kgd_jobs{state=\"QUEUED\"}"), 0) << text;
  EXPECT_GE(Sample(text, "kgd_queue_depth"), 0) << text;
  EXPECT_GE(Sample(text, "kgd_jobs_created_total"), 1) << text;
  // Iterations 0..3 of this job at least, each timed by the worker and written to HDF5 and SQLite.
  const double iterations = Sample(text, "kgd_iterations_total");
  EXPECT_GE(iterations, 4) << text;
  EXPECT_EQ(Sample(text, "kgd_iteration_seconds_count"), iterations) << text;
  EXPECT_EQ(Sample(text, "kgd_hdf5_write_seconds_count"), iterations) << text;
  EXPECT_EQ(Sample(text, "kgd_sqlite_commit_seconds_count"), iterations) << text;
  EXPECT_GT(Sample(text, "kgd_sqlite_commit_seconds_sum"), 0) << text;
  EXPECT_GE(Sample(text, "kgd_lease_expiries_total"), 0) << text;
  // An open watch shows while it is open.
  const std::string running = std::to_string(Create(SleeveJob(400, "watched")).id());
  std::atomic<bool> close{false};
  std::thread watch([&] { Service().Client().Get("/v1/jobs/" + running + ":watch?view=metrics", [&](const char*, size_t) { return !close.load(); }); });
  EXPECT_TRUE(WaitFor([&] {
    auto m = Service().Client().Get("/metrics");
    return m && Sample(m->body, "kgd_watchers") >= 1;
  }, 60));
  close = true;
  Service().Client().Post("/v1/jobs/" + running + ":cancel", "", "application/json");
  watch.join();
}

TEST_F(HttpApi, TheDataFolderAndItsFilesAreTheOwnersAlone) {
  const std::string id = std::to_string(Create(SleeveJob(1, "private")).id());
  ASSERT_TRUE(WaitFor([&] { return Ended(id); }, 300));
  const fs::path data = fs::path(Service().dir()) / "data";
  auto mode = [](const fs::path& p) { return fs::status(p).permissions() & fs::perms::all; };
  EXPECT_EQ(mode(data), fs::perms::owner_all);
  EXPECT_EQ(mode(data / "jobs"), fs::perms::owner_all);
  const fs::perms rw = fs::perms::owner_read | fs::perms::owner_write;
  EXPECT_EQ(mode(data / "kgd.sqlite"), rw);
  EXPECT_EQ(mode(data / "jobs" / ("job-" + id + ".h5")), rw);
  for (const auto& entry : fs::recursive_directory_iterator(data))
    EXPECT_EQ(mode(entry.path()) & (fs::perms::group_all | fs::perms::others_all), fs::perms::none) << entry.path();
}

TEST_F(HttpApi, WatchesBeyondTheLimitAreRefusedUntilOneCloses) {
  // The fixture's server takes --max-watchers 3.
  const std::string id = std::to_string(Create(SleeveJob(400, "many watchers")).id());
  std::atomic<bool> close{false};
  std::atomic<int> open{0};
  std::vector<std::thread> watches;
  for (int w = 0; w < 3; ++w)
    watches.emplace_back([&] {
      bool counted = false;
      Service().Client().Get("/v1/jobs/" + id + ":watch?view=metrics", [&](const char*, size_t) {
        if (!counted) ++open, counted = true;
        return !close.load();
      });
    });
  ASSERT_TRUE(WaitFor([&] { return open == 3; }, 60));
  auto refused = Service().Client().Get("/v1/jobs/" + id + ":watch");
  ASSERT_TRUE(refused);
  EXPECT_EQ(refused->status, 429);
  EXPECT_NE(refused->body.find("RESOURCE_EXHAUSTED"), std::string::npos) << refused->body;
  EXPECT_NE(refused->body.find("--max-watchers"), std::string::npos) << refused->body;
  close = true;
  Service().Client().Post("/v1/jobs/" + id + ":cancel", "", "application/json");
  for (auto& t : watches) t.join();
  // The closed watches free their places.
  EXPECT_TRUE(WaitFor([&] {
    auto again = Service().Client().Get("/v1/jobs/" + id + ":watch?view=metrics");
    return again && again->status == 200;
  }, 60));
}

// Bad specs are refused when they are submitted (400 INVALID_ARGUMENT naming the field and the value),
// before a job exists: an iteration limit above the server's, a body of 5 m, a scene file without a
// garment, and a photo sent as the garment's OBJ (its bytes escaped, never raw) or as the scene file.
TEST_F(HttpApi, BadSpecsAreRefusedAtSubmissionWithMessagesForPeople) {
  auto cli = Service().Client();
  const int jobs_before = Parse<v1::ListJobsResponse>(cli.Get("/v1/jobs?pageSize=1000")->body).jobs_size();
  auto refused = [](const httplib::Result& res, const std::string& message) {
    ASSERT_TRUE(res);
    EXPECT_EQ(res->status, 400) << res->body;
    const nlohmann::json body = nlohmann::json::parse(res->body);
    EXPECT_EQ(body["error"]["status"], "INVALID_ARGUMENT") << res->body;
    const std::string text = body["error"]["message"];
    EXPECT_EQ(text, message);
    for (const char c : text) EXPECT_FALSE(static_cast<unsigned char>(c) < 0x20) << "a control character in " << text;
  };
  refused(cli.Post("/v1/jobs", R"({"builtinScene": "sleeve_on_limb", "optimizer": {"maxIterations": 2001}})", "application/json"),
          "spec.optimizer.max_iterations: 2001 is above this server's limit of 2000 iterations (--max-iterations)");
  refused(cli.Post("/v1/jobs", R"({"builtinScene": "knee_flexion", "body": ["height_m=5"]})", "application/json"),
          "spec.body: body measurement height_m = 5 is outside [1.2, 2.2]");
  const std::string png("\x89PNG\r\n\x1a\n\0\0\0\rIHDR\0\0\0\x10", 20);
  const std::string triangle = "v 0 0 0\nv 0.1 0 0\nv 0 0.1 0\nf 1 2 3\n";
  refused(cli.Post("/v1/jobs", httplib::MultipartFormDataItems{{"scene", R"({"body": {"mesh": "body.obj"}})", "scene.json", "application/json"},
                                                                {"body.obj", triangle, "body.obj", "text/plain"}}),
          "spec.scene_files.scene: garment: missing (give garment.rest, or garment.region with body.rest and body.deformed)");
  refused(cli.Post("/v1/jobs", httplib::MultipartFormDataItems{{"scene", R"({"garment": {"rest": "garment.obj"}})", "scene.json", "application/json"},
                                                                {"garment.obj", png, "garment.obj", "application/octet-stream"}}),
          R"(spec.scene_files.scene.garment.rest: garment.obj is not an OBJ or PLY mesh (line 1: "\x89PNG" is not text))");
  refused(cli.Post("/v1/jobs", httplib::MultipartFormDataItems{{"scene", png, "photo.png", "image/png"}}),
          "part 'scene' (photo.png) is not a JSON scene file: it is not text");
  EXPECT_EQ(Parse<v1::ListJobsResponse>(cli.Get("/v1/jobs?pageSize=1000")->body).jobs_size(), jobs_before) << "no job was made";
  // The page checks the iteration limit against the server's before it submits.
  EXPECT_EQ(Parse<v1::ListScenesResponse>(cli.Get("/v1/scenes")->body).max_iterations(), 2000);
}

// A job that stops at its iteration limit short of the budget says so (Job.ended, kept once it has
// ended), and the cut files of its last design report the cleaned design simulated as `kgd export`
// does on the job's design file: the same density ratio, bit for bit, and the same solve status.
TEST_F(HttpApi, AJobSaysHowItEndedAndItsLastDesignsCutFilesReportTheCleanedDesignAsKgdExportDoes) {
  const v1::Job job = Create(SleeveJob(3, "ended"));
  const std::string id = std::to_string(job.id());
  ASSERT_TRUE(WaitFor([&] { return Ended(id); }, 300)) << Service().Log();
  const v1::Job done = Get(id);
  ASSERT_EQ(done.state(), v1::SUCCEEDED) << done.failure();
  ASSERT_EQ(done.iterations(), 4);
  char area[32];
  std::snprintf(area, sizeof area, "%.1f %%", 100 * done.last().area_fraction());
  ASSERT_GT(done.last().area_fraction(), 0.3);
  EXPECT_EQ(done.ended(), "stopped at the iteration limit (3) at " + std::string(area) + " of the garment, above the budget of 30 %");
  EXPECT_EQ(done.phase(), v1::JOB_PHASE_UNSPECIFIED);

  auto res = Service().Client().Get("/v1/jobs/" + id + "/iterations/-1/cut/report.json");
  ASSERT_TRUE(res && res->status == 200) << (res ? res->body : "no response");
  const nlohmann::json service = nlohmann::json::parse(res->body);
  const std::string out = Service().dir() + "/export-" + id;
  const auto exported = cli_test::Kgd("export " + done.data_file() + " --iteration 3 --out " + out);
  ASSERT_EQ(exported.exit_code, 0) << exported.output;
  std::ifstream in(out + "/report.json");
  const nlohmann::json local = nlohmann::json::parse(in);
  EXPECT_EQ(service["iteration"], 3);
  EXPECT_NE(service["cleaned"]["solve_status"], "not simulated");
  EXPECT_EQ(service["cleaned"]["solve_status"], local["cleaned"]["solve_status"]);
  // The cleaned design (a few faces fewer) resists nearly as the stored one: the sleeve, a garment of its
  // own, keeps its attachments where the job had them.
  EXPECT_NEAR(service["cleaned"]["density_ratio"].get<double>(), service["density_ratio"].get<double>(), 0.05 * service["density_ratio"].get<double>())
      << res->body;
  EXPECT_EQ(service["cleaned"]["density_ratio"].get<double>(), local["cleaned"]["density_ratio"].get<double>()) << res->body;
  EXPECT_EQ(service["cleaned"]["area_fraction"].get<double>(), local["cleaned"]["area_fraction"].get<double>());
  // An earlier iteration's report is still made by geometry alone.
  auto first = Service().Client().Get("/v1/jobs/" + id + "/iterations/1/cut/report.json");
  ASSERT_TRUE(first && first->status == 200);
  EXPECT_EQ(nlohmann::json::parse(first->body)["cleaned"]["solve_status"], "not simulated");
}

}  // namespace
}  // namespace kgd
