// The design service's security as it runs for real: a kgd-server process with --auth-tokens (and,
// for the TLS cases, certificates from a throwaway CA that openssl makes in the test), a kgd-worker
// with a worker token, reached over gRPC and HTTP. No token is UNAUTHENTICATED; a user cannot see,
// watch, fetch, export or cancel another's job on any RPC or HTTP route (NOT_FOUND, the same answer
// as for a job that does not exist) while the owner and an admin get each route's own answer (every
// route server/http_gateway.cpp registers is in the table); a worker token cannot list or read; a
// non-loopback address without TLS and tokens is refused; a client without the server's CA is told so.
#include <google/protobuf/util/json_util.h>
#include <grpcpp/grpcpp.h>
#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <functional>
#include <map>
#include <regex>
#include <thread>

#include "kgd/v1/kgd.grpc.pb.h"
#include "tests/child_process.h"
#include "tests/kgd_cli.h"
#include <httplib.h>

namespace kgd {
namespace {
namespace fs = std::filesystem;
using test_support::FreePort;
using test_support::Process;
using test_support::WaitFor;
using test_support::ReadText;

const std::string kAlice = "alice-token-0123456789abcdef", kBob = "bob-token-0123456789abcdef", kRoot = "root-token-0123456789abcdef",
                  kWorker = "worker-token-0123456789abcdef";

// A kgd-server with tokens, its HTTP door, and one kgd-worker with the worker token.
class SecureService {
 public:
  explicit SecureService(const std::vector<std::string>& extra_server_args = {}, const std::vector<std::string>& extra_worker_args = {},
                         const std::string& name = "plain") {
    dir_ = (fs::temp_directory_path() / ("kgd_security_test_" + std::to_string(getpid()) + "_" + name)).string();
    fs::remove_all(dir_);
    fs::create_directories(dir_);
    std::ofstream(dir_ + "/tokens") << "# token user role\n"
                                    << kAlice << " alice user\n"
                                    << kBob << " bob user\n\n"
                                    << kRoot << " root admin\n"
                                    << kWorker << " w worker\n";
    grpc_ = "127.0.0.1:" + std::to_string(FreePort());
    http_port_ = FreePort();
    std::vector<std::string> args = {KGD_SERVER_BINARY, "--data", dir_ + "/data", "--listen", grpc_, "--http",
                                     "127.0.0.1:" + std::to_string(http_port_), "--auth-tokens", dir_ + "/tokens"};
    args.insert(args.end(), extra_server_args.begin(), extra_server_args.end());
    server_ = Process::Spawn(args, dir_ + "/server.log");
    std::vector<std::string> wargs = {KGD_WORKER_BINARY, "--server", grpc_, "--name", "w0", "--token", kWorker};
    wargs.insert(wargs.end(), extra_worker_args.begin(), extra_worker_args.end());
    worker_ = Process::Spawn(wargs, dir_ + "/worker.log");
    ok_ = WaitFor([&] { return Log().find("http on") != std::string::npos; }, 30);
  }
  ~SecureService() {
    server_.Signal(SIGKILL);
    worker_.Signal(SIGKILL);
    server_.Wait();
    worker_.Wait();
    if (!::testing::UnitTest::GetInstance()->failed_test_count()) fs::remove_all(dir_);
  }
  bool ok() const { return ok_; }
  std::string Log() const { return ReadText(dir_ + "/server.log"); }
  const std::string& grpc() const { return grpc_; }
  int http_port() const { return http_port_; }
  const std::string& dir() const { return dir_; }

 private:
  std::string dir_, grpc_;
  int http_port_ = 0;
  bool ok_ = false;
  Process server_, worker_;
};

SecureService& Service() {
  static SecureService s;
  return s;
}

std::shared_ptr<grpc::Channel> Channel() {
  static std::shared_ptr<grpc::Channel> c = grpc::CreateChannel(Service().grpc(), grpc::InsecureChannelCredentials());
  return c;
}

// A call context with `token` (none when empty).
std::unique_ptr<grpc::ClientContext> As(const std::string& token) {
  auto ctx = std::make_unique<grpc::ClientContext>();
  if (!token.empty()) ctx->AddMetadata("authorization", "Bearer " + token);
  ctx->set_deadline(std::chrono::system_clock::now() + std::chrono::seconds(60));
  return ctx;
}

httplib::Client Http(const std::string& token) {
  httplib::Client c("127.0.0.1", Service().http_port());
  c.set_read_timeout(60, 0);
  if (!token.empty()) c.set_bearer_token_auth(token);
  return c;
}

v1::Job CreateAs(const std::string& token, int iterations) {
  auto stub = v1::DesignService::NewStub(Channel());
  v1::CreateJobRequest req;
  req.mutable_spec()->set_builtin_scene("sleeve_on_limb");
  req.mutable_spec()->mutable_optimizer()->set_max_iterations(iterations);
  v1::Job job;
  const grpc::Status st = stub->CreateJob(As(token).get(), req, &job);
  EXPECT_TRUE(st.ok()) << st.error_message();
  return job;
}

v1::JobState StateAs(const std::string& token, int64_t id) {
  auto stub = v1::DesignService::NewStub(Channel());
  v1::GetJobRequest req;
  req.set_id(id);
  v1::Job job;
  return stub->GetJob(As(token).get(), req, &job).ok() ? job.state() : v1::JOB_STATE_UNSPECIFIED;
}

bool Ended(v1::JobState s) { return s == v1::SUCCEEDED || s == v1::FAILED || s == v1::CANCELLED; }

class Security : public ::testing::Test {
 protected:
  void SetUp() override { ASSERT_TRUE(Service().ok()) << Service().Log(); }
};

TEST_F(Security, NoTokenOrAWrongOneIsUnauthenticatedOnBothDoors) {
  auto stub = v1::DesignService::NewStub(Channel());
  for (const std::string& token : {std::string(), std::string("not-a-token-of-this-server")}) {
    v1::ListJobsResponse list;
    grpc::Status st = stub->ListJobs(As(token).get(), {}, &list);
    EXPECT_EQ(st.error_code(), grpc::StatusCode::UNAUTHENTICATED) << token;
    EXPECT_NE(st.error_message().find("token"), std::string::npos) << st.error_message();
    EXPECT_EQ(st.error_message().find(token.empty() ? "\x01" : token), std::string::npos) << "the message echoes the token";
    v1::Job job;
    v1::CreateJobRequest create;
    create.mutable_spec()->set_builtin_scene("sleeve_on_limb");
    EXPECT_EQ(stub->CreateJob(As(token).get(), create, &job).error_code(), grpc::StatusCode::UNAUTHENTICATED);
    v1::ListScenesResponse scenes;
    EXPECT_EQ(stub->ListScenes(As(token).get(), {}, &scenes).error_code(), grpc::StatusCode::UNAUTHENTICATED);
    auto res = Http(token).Get("/v1/jobs");
    ASSERT_TRUE(res);
    EXPECT_EQ(res->status, 401);
    EXPECT_NE(res->body.find("UNAUTHENTICATED"), std::string::npos) << res->body;
    EXPECT_EQ(res->get_header_value("WWW-Authenticate"), "Bearer");
  }
  // The page itself is public (it asks for the token); the API is not.
  auto page = Http("").Get("/");
  ASSERT_TRUE(page);
  EXPECT_EQ(page->status, 200);
  // The browser's GET requests may carry the token as a cookie; a POST may not.
  httplib::Client c("127.0.0.1", Service().http_port());
  auto cookie_get = c.Get("/v1/jobs", {{"Cookie", "theme=dark; kgd_token=" + kAlice}});
  ASSERT_TRUE(cookie_get);
  EXPECT_EQ(cookie_get->status, 200) << cookie_get->body;
  auto cookie_post = c.Post("/v1/jobs", {{"Cookie", "kgd_token=" + kAlice}}, R"({"builtinScene": "sleeve_on_limb"})", "application/json");
  ASSERT_TRUE(cookie_post);
  EXPECT_EQ(cookie_post->status, 401);
}

// The routes server/http_gateway.cpp registers, as {method, path pattern}: a route added there
// without a request in this test's table fails the test.
std::vector<std::pair<std::string, std::string>> RegisteredRoutes() {
  const std::string source = ReadText(std::string(KGD_SOURCE_DIR) + "/server/http_gateway.cpp");
  const std::regex registration(R"re(http\.(Get|Post)\(\s*(?:R"\((.*?)\)"|"([^"]*)"))re");
  std::vector<std::pair<std::string, std::string>> out;
  for (auto it = std::sregex_iterator(source.begin(), source.end(), registration); it != std::sregex_iterator(); ++it)
    out.push_back({(*it)[1] == "Get" ? "GET" : "POST", (*it)[2].matched ? (*it)[2].str() : (*it)[3].str()});
  return out;
}

// A body strip of 6 x 2 quads of 1 cm as OBJ, stretched along x by `stretch` with its middle lifted
// `lift_m`.
std::string StripObj(double stretch, double lift_m) {
  std::string obj;
  for (int j = 0; j < 3; ++j)
    for (int i = 0; i < 7; ++i)
      obj += "v " + std::to_string(0.01 * i * stretch) + " " + std::to_string(0.01 * j) + " " + std::to_string(lift_m * (1 - std::abs(i - 3) / 3.0)) + "\n";
  for (int j = 0; j < 2; ++j)
    for (int i = 0; i < 6; ++i) {
      const int a = 7 * j + i + 1, b = a + 1, c = a + 7, d = c + 1;
      obj += "f " + std::to_string(a) + " " + std::to_string(b) + " " + std::to_string(d) + "\nf " + std::to_string(a) + " " + std::to_string(d) + " " +
             std::to_string(c) + "\n";
    }
  return obj;
}

// Alice's job for the route table, small enough to take a second: the strip's 24 faces are the
// garment, attached at both ends (two bands, so the evaluation has its Line and X baselines), over a
// motion of one frame (the deformed pose: 5 % longer, the middle lifted 2 mm); 3 iterations.
httplib::MultipartFormDataItems StripJob() {
  const std::string scene = R"({"body": {"rest": "rest.obj", "deformed": "pose.obj", "frames": ["pose.obj"]},
      "garment": {"region": "region.txt", "subdivisions": 1}, "attachments": {"body_faces": "ends.txt"}, "effects": {"attachments": true}})";
  std::string region;
  for (int f = 0; f < 24; ++f) region += std::to_string(f) + "\n";
  return {{"scene", scene, "scene.json", "application/json"},
          {"spec", R"({"optimizer": {"maxIterations": 3}})", "spec.json", "application/json"},
          {"rest.obj", StripObj(1, 0), "rest.obj", "text/plain"},
          {"pose.obj", StripObj(1.05, 0.002), "pose.obj", "text/plain"},
          {"region.txt", region, "region.txt", "text/plain"},
          {"ends.txt", "0\n1\n12\n13\n10\n11\n22\n23\n", "ends.txt", "text/plain"}};
}

TEST_F(Security, AUserCannotSeeWatchFetchExportOrCancelAnothersJobOnAnyRoute) {
  // Alice's job, created by HTTP (the route POST /v1/jobs) and run to its end.
  const httplib::MultipartFormDataItems upload = StripJob();
  auto created = Http(kAlice).Post("/v1/jobs", upload);
  ASSERT_TRUE(created);
  ASSERT_EQ(created->status, 200) << created->body;
  v1::Job job;
  ASSERT_TRUE(google::protobuf::util::JsonStringToMessage(created->body, &job).ok()) << created->body;
  EXPECT_EQ(job.owner(), "alice");
  ASSERT_TRUE(WaitFor([&] { return Ended(StateAs(kAlice, job.id())); }, 300));
  ASSERT_EQ(StateAs(kAlice, job.id()), v1::SUCCEEDED);
  const std::string id = std::to_string(job.id());
  const std::string missing = "987654";

  // gRPC: every call on the job, as bob (NOT_FOUND, worded as for a job that does not exist), as
  // alice and root (allowed).
  auto stub = v1::DesignService::NewStub(Channel());
  auto calls = [&](const std::string& token, int64_t job_id) {
    std::vector<std::pair<std::string, grpc::Status>> out;
    v1::GetJobRequest get;
    get.set_id(job_id);
    v1::Job j;
    out.push_back({"GetJob", stub->GetJob(As(token).get(), get, &j)});
    v1::GetIterationRequest it;
    it.set_id(job_id);
    it.set_iteration(-1);
    v1::GetIterationResponse itr;
    out.push_back({"GetIteration", stub->GetIteration(As(token).get(), it, &itr)});
    v1::GetEvaluationRequest ev;
    ev.set_id(job_id);
    v1::DesignEvaluation evr;
    out.push_back({"GetEvaluation", stub->GetEvaluation(As(token).get(), ev, &evr)});
    v1::ExportDesignRequest ex;
    ex.set_id(job_id);
    ex.set_iteration(-1);
    auto ex_ctx = As(token);
    auto ex_reader = stub->ExportDesign(ex_ctx.get(), ex);
    v1::ExportDesignEvent exr;
    while (ex_reader->Read(&exr)) {
    }
    out.push_back({"ExportDesign", ex_reader->Finish()});
    v1::WatchJobRequest w;
    w.set_id(job_id);
    auto ctx = As(token);
    auto reader = stub->WatchJob(ctx.get(), w);
    v1::WatchJobEvent e;
    while (reader->Read(&e)) {
    }
    out.push_back({"WatchJob", reader->Finish()});
    v1::CancelJobRequest cn;
    cn.set_id(job_id);
    out.push_back({"CancelJob", stub->CancelJob(As(token).get(), cn, &j)});
    return out;
  };
  const auto as_missing = calls(kAlice, std::stoll(missing));
  const auto as_bob = calls(kBob, job.id());
  ASSERT_EQ(as_bob.size(), as_missing.size());
  for (size_t k = 0; k < as_bob.size(); ++k) {
    EXPECT_EQ(as_bob[k].second.error_code(), grpc::StatusCode::NOT_FOUND) << as_bob[k].first << " as bob";
    // The same answer as for an id that does not exist, but for the number.
    std::string msg = as_bob[k].second.error_message(), ref = as_missing[k].second.error_message();
    ASSERT_NE(msg.find(id), std::string::npos) << as_bob[k].first << ": " << msg;
    ASSERT_NE(ref.find(missing), std::string::npos) << as_missing[k].first << ": " << ref;
    msg.replace(msg.find(id), id.size(), "N");
    ref.replace(ref.find(missing), missing.size(), "N");
    EXPECT_EQ(msg, ref) << as_bob[k].first;
  }
  for (const std::string& token : {kAlice, kRoot})
    for (const auto& [name, st] : calls(token, job.id())) EXPECT_TRUE(st.ok()) << name << " as " << token << ": " << st.error_message();

  // ListJobs: alice sees hers, bob none of hers, root all.
  auto listed = [&](const std::string& token) {
    v1::ListJobsResponse list;
    EXPECT_TRUE(stub->ListJobs(As(token).get(), {}, &list).ok());
    for (const v1::Job& j : list.jobs())
      if (j.id() == job.id()) return true;
    return false;
  };
  EXPECT_TRUE(listed(kAlice));
  EXPECT_FALSE(listed(kBob));
  EXPECT_TRUE(listed(kRoot));

  // HTTP: every route, by each kind of caller. The sizes the binary arrays must have.
  v1::GetIterationRequest ireq;
  ireq.set_id(job.id());
  ireq.set_iteration(-1);
  ireq.set_with_garment(true);
  v1::GetIterationResponse last;
  ASSERT_TRUE(stub->GetIteration(As(kAlice).get(), ireq, &last).ok());
  const v1::Garment& g = last.garment();
  const size_t nv = g.rest_vertices_size() / 3, nf = g.faces_size() / 3, body_floats = g.body_vertices_size(), body_ints = g.body_faces_size();
  ASSERT_GT(nf, 0u);
  ASSERT_GT(body_ints, 0u);
  // A body check: "" when the body is what the route serves, else what is wrong.
  using Check = std::function<std::string(const std::string&)>;
  auto bytes = [](size_t n) -> Check {
    return [n](const std::string& b) { return b.size() == n ? "" : std::to_string(b.size()) + " bytes, not " + std::to_string(n); };
  };
  auto starts = [](const std::string& prefix) -> Check {
    return [prefix](const std::string& b) { return b.rfind(prefix, 0) == 0 ? "" : "does not start with '" + prefix + "'"; };
  };
  auto has = [](const std::string& part) -> Check {
    return [part](const std::string& b) { return b.find(part) != std::string::npos ? "" : "has no '" + part + "'"; };
  };
  const std::string png(std::string("\x89PNG\r\n\x1a\n", 8)), hdf5(std::string("\x89HDF\r\n\x1a\n", 8));
  const std::string json = "application/json", octets = "application/octet-stream";
  // Who asks: the owner, an admin, another user, a worker, and no one (no token).
  enum Who { kOwner, kAdmin, kOther, kWorkerToken, kNobody };
  const std::map<Who, std::string> tokens = {{kOwner, kAlice}, {kAdmin, kRoot}, {kOther, kBob}, {kWorkerToken, kWorker}, {kNobody, ""}};
  struct Route {
    std::string method, path;  // path: with the job's id and a query where the route takes one
    std::map<Who, int> status;  // the HTTP status each caller gets (kNobody: 401 unless given)
    std::string type;           // the Content-Type of the success
    Check body;                 // the success's body
  };
  const std::map<Who, int> job_route = {{kOwner, 200}, {kAdmin, 200}, {kOther, 404}, {kWorkerToken, 403}};
  const std::string j = "/v1/jobs/" + id;
  std::vector<Route> routes = {
      {"GET", "/metrics", {{kOwner, 403}, {kAdmin, 200}, {kOther, 403}, {kWorkerToken, 403}}, "text/plain; version=0.0.4; charset=utf-8",
       has("kgd_jobs_created_total")},
      {"GET", "/v1/scenes", {{kOwner, 200}, {kAdmin, 200}, {kOther, 200}, {kWorkerToken, 200}}, json, has("\"sleeve_on_limb\"")},
      {"GET", "/v1/jobs?pageSize=1000&state=SUCCEEDED", {{kOwner, 200}, {kAdmin, 200}, {kWorkerToken, 403}}, json, has("\"id\":\"" + id + "\"")},
      // Alice's creation above; a worker cannot create.
      {"POST", "/v1/jobs", {{kWorkerToken, 403}}, json, has("\"owner\":\"alice\"")},
      {"GET", j, job_route, json, has("\"owner\":\"alice\"")},
      {"POST", j + ":cancel", job_route, json, has("\"state\":\"SUCCEEDED\"")},
      {"GET", j + ":watch", job_route, "text/event-stream", has("event: iteration")},
      {"GET", j + "/iterations/-1?withGarment=true", job_route, json, has("\"garment\"")},
      {"GET", j + "/iterations/-1/positions.f32", job_route, octets, bytes(12 * nv)},
      {"GET", j + "/iterations/-1/energy.f32", job_route, octets, bytes(4 * nf)},
      {"GET", j + "/iterations/-1/design.u8", job_route, octets, bytes(nf)},
      {"GET", j + "/iterations/-1/design.ply", job_route, octets, starts("ply\nformat binary_little_endian 1.0\n")},
      {"GET", j + "/evaluation", job_route, json, has("\"baselines\"")},
      {"GET", j + "/evaluation/frames/1/positions.f32", job_route, octets, bytes(12 * nv)},
      {"GET", j + "/evaluation/frames/1/body.f32", job_route, octets, bytes(4 * body_floats)},
      {"GET", j + "/evaluation/frames/1/energy.f32", job_route, octets, bytes(4 * nf)},
      {"GET", j + "/garment/faces.u32", job_route, octets, bytes(12 * nf)},
      {"GET", j + "/garment/rest.f32", job_route, octets, bytes(12 * nv)},
      {"GET", j + "/body/vertices.f32", job_route, octets, bytes(4 * body_floats)},
      {"GET", j + "/body/faces.u32", job_route, octets, bytes(4 * body_ints)},
      {"GET", j + "/design-file", job_route, "application/x-hdf5", starts(hdf5)},
      {"GET", j + "/iterations/-1/cut/pattern.svg", job_route, "image/svg+xml", has("<svg")},
      {"GET", j + "/iterations/-1/cut/patches.svg", job_route, "image/svg+xml", has("<svg")},
      {"GET", j + "/iterations/-1/cut/pattern.dxf", job_route, "application/dxf", has("SECTION")},
      {"GET", j + "/iterations/-1/cut/patches.dxf", job_route, "application/dxf", has("SECTION")},
      {"GET", j + "/iterations/-1/cut/pattern.png", job_route, "image/png", starts(png)},
      {"GET", j + "/iterations/-1/cut/patches.png", job_route, "image/png", starts(png)},
      {"GET", j + "/iterations/-1/cut/report.json", job_route, json, has("\"pieces\"")},
      // The studio's routes hold no job: every caller with a token, as for the scene list. A scene
      // without the parametric body has no body to serve (building one takes seconds: not here).
      {"POST", "/v1/regions:check", {{kOwner, 200}, {kAdmin, 200}, {kOther, 200}, {kWorkerToken, 200}}, json, has("\"valid\"")},
      {"GET", "/v1/scenes/sleeve_on_limb/body/rest.obj", {{kOwner, 404}, {kAdmin, 404}, {kOther, 404}, {kWorkerToken, 404}}, "", has("")},
      // The probes' routes need no token and say only whether the server lives and can store.
      {"GET", "/healthz", {{kNobody, 200}, {kOwner, 200}, {kAdmin, 200}, {kOther, 200}, {kWorkerToken, 200}}, "text/plain; charset=utf-8", has("ok")},
      {"GET", "/readyz", {{kNobody, 200}, {kOwner, 200}, {kAdmin, 200}, {kOther, 200}, {kWorkerToken, 200}}, "text/plain; charset=utf-8", has("ready")},
  };
  // A region of a square's two faces (the region check's answer, whatever its verdict).
  const httplib::MultipartFormDataItems region = {{"body", "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf 1 2 3\nf 1 3 4\n", "square.obj", "text/plain"},
                                                  {"faces", "0 1", "", "text/plain"}};
  for (const char* name : {"line", "x"}) {
    const std::string b = j + "/evaluation/baselines/" + name;
    routes.push_back({"GET", b + "/positions.f32", job_route, octets, bytes(12 * nv)});
    routes.push_back({"GET", b + "/design.u8", job_route, octets, bytes(nf)});
    routes.push_back({"GET", b + "/energy.f32", job_route, octets, bytes(4 * nf)});
  }
  // Every route the gateway registers is in the table.
  for (const auto& [method, pattern] : RegisteredRoutes()) {
    bool requested = false;
    for (const Route& r : routes) requested |= r.method == method && std::regex_match(r.path.substr(0, r.path.find('?')), std::regex(pattern));
    EXPECT_TRUE(requested) << method << " " << pattern << " (server/http_gateway.cpp) has no request in this test's table";
  }
  EXPECT_GE(RegisteredRoutes().size(), 20u) << "the routes were not found in server/http_gateway.cpp";

  for (const Route& r : routes) {
    std::map<Who, int> expected = r.status;
    expected.emplace(kNobody, 401);
    for (const auto& [who, status] : expected) {
      httplib::Client c = Http(tokens.at(who));
      const std::string what = r.method + " " + r.path + " as " + (who == kNobody ? "no one" : tokens.at(who));
      auto res = r.method == "GET"              ? c.Get(r.path)
                 : r.path == "/v1/jobs"          ? c.Post(r.path, upload)
                 : r.path == "/v1/regions:check" ? c.Post(r.path, region)
                                                 : c.Post(r.path, "", "application/json");
      ASSERT_TRUE(res) << what << ": " << httplib::to_string(res.error());
      EXPECT_EQ(res->status, status) << what << ": " << res->body.substr(0, 300);
      if (res->status != status) continue;
      if (status == 200) {
        EXPECT_EQ(res->get_header_value("Content-Type"), r.type) << what;
        const std::string wrong = r.body(res->body);
        EXPECT_EQ(wrong, "") << what;
        continue;
      }
      const std::map<int, std::string> names = {{401, "UNAUTHENTICATED"}, {403, "PERMISSION_DENIED"}, {404, "NOT_FOUND"}};
      EXPECT_NE(res->body.find("\"status\": \"" + names.at(status) + "\""), std::string::npos) << what << ": " << res->body;
      // Another user's job: the same answer as a job that does not exist.
      if (status == 404 && r.path.rfind("/v1/jobs/", 0) == 0) {
        EXPECT_NE(res->body.find("\"message\": \"job " + id + " does not exist\""), std::string::npos) << what << ": " << res->body;
      }
    }
  }
  // Bob's list does not show alice's job.
  auto list = Http(kBob).Get("/v1/jobs");
  ASSERT_TRUE(list && list->status == 200);
  EXPECT_EQ(list->body.find("\"id\":\"" + id + "\""), std::string::npos) << list->body;
}

TEST_F(Security, AWorkerTokenLeasesButCannotListOrReadAndAUserCannotLease) {
  auto stub = v1::DesignService::NewStub(Channel());
  v1::ListJobsResponse list;
  grpc::Status st = stub->ListJobs(As(kWorker).get(), {}, &list);
  EXPECT_EQ(st.error_code(), grpc::StatusCode::PERMISSION_DENIED);
  EXPECT_NE(st.error_message().find("worker"), std::string::npos) << st.error_message();
  v1::GetJobRequest get;
  get.set_id(1);
  v1::Job job;
  EXPECT_EQ(stub->GetJob(As(kWorker).get(), get, &job).error_code(), grpc::StatusCode::PERMISSION_DENIED);
  auto res = Http(kWorker).Get("/v1/jobs");
  ASSERT_TRUE(res);
  EXPECT_EQ(res->status, 403) << res->body;
  auto metrics = Http(kAlice).Get("/metrics");
  ASSERT_TRUE(metrics);
  EXPECT_EQ(metrics->status, 403) << "metrics are an admin's";
  metrics = Http(kRoot).Get("/metrics");
  ASSERT_TRUE(metrics);
  EXPECT_EQ(metrics->status, 200);
  // A user's token cannot take work from the queue.
  auto worker_stub = v1::WorkerService::NewStub(Channel());
  v1::LeaseJobRequest lease;
  lease.set_worker("impostor");
  v1::LeaseJobResponse leased;
  st = worker_stub->LeaseJob(As(kAlice).get(), lease, &leased);
  EXPECT_EQ(st.error_code(), grpc::StatusCode::PERMISSION_DENIED) << st.error_message();
  // The worker with its token ran the other tests' jobs: one more, end to end.
  const v1::Job mine = CreateAs(kBob, 1);
  ASSERT_TRUE(WaitFor([&] { return Ended(StateAs(kBob, mine.id())); }, 300));
  EXPECT_EQ(StateAs(kBob, mine.id()), v1::SUCCEEDED);
}

TEST_F(Security, ATokenFileWithAMistakeIsRefusedNamingTheLine) {
  const std::string dir = Service().dir();
  std::ofstream(dir + "/bad_tokens") << kAlice << " alice user\n" << kBob << " bob superuser\n";
  cli_test::CommandRun r = cli_test::Kgd("serve --data " + dir + "/bad_data --listen 127.0.0.1:0 --http 127.0.0.1:0 --auth-tokens " + dir + "/bad_tokens");
  EXPECT_EQ(r.exit_code, 1) << r.output;
  EXPECT_NE(r.output.find("bad_tokens:2"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("superuser"), std::string::npos) << r.output;
}

TEST_F(Security, ANonLoopbackAddressNeedsTlsAndTokensOrInsecure) {
  const std::string dir = Service().dir();
  cli_test::CommandRun r = cli_test::Kgd("serve --data " + dir + "/open_data --listen 0.0.0.0:0 --no-http");
  EXPECT_EQ(r.exit_code, 1) << r.output;
  EXPECT_NE(r.output.find("0.0.0.0:0 is reachable from other machines"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("--insecure"), std::string::npos) << r.output;
  // The HTTP door alike, even with tokens: it needs TLS too.
  r = cli_test::Kgd("serve --data " + dir + "/open_data --listen 127.0.0.1:0 --http 0.0.0.0:0 --auth-tokens " + dir + "/tokens");
  EXPECT_EQ(r.exit_code, 1) << r.output;
  EXPECT_NE(r.output.find("--http 0.0.0.0:0"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("needs TLS"), std::string::npos) << r.output;
  // --insecure serves it open (stopped at once by a kill after it says where it listens).
  Process open = Process::Spawn({KGD_SERVER_BINARY, "--data", dir + "/open_data", "--listen", "0.0.0.0:0", "--insecure"}, dir + "/open.log");
  EXPECT_TRUE(WaitFor([&] { return ReadText(dir + "/open.log").find("listening on") != std::string::npos; }, 30)) << ReadText(dir + "/open.log");
}

// A throwaway CA and a server certificate for 127.0.0.1 it signed, and another CA (other.pem) that
// signed nothing, by openssl; empty when openssl is absent.
std::string MakeCertificates(const std::string& dir) {
  fs::create_directories(dir);
  const std::string cmd = "cd " + dir +
                          " && openssl req -x509 -newkey rsa:2048 -nodes -keyout ca.key -out ca.pem -days 1 -subj /CN=kgd-test-ca 2>/dev/null"
                          " && openssl req -newkey rsa:2048 -nodes -keyout server.key -out server.csr -subj /CN=127.0.0.1 2>/dev/null"
                          " && printf 'subjectAltName=IP:127.0.0.1,DNS:localhost\\n' > san.ext"
                          " && openssl x509 -req -in server.csr -CA ca.pem -CAkey ca.key -CAcreateserial -out server.pem -days 1 -extfile san.ext 2>/dev/null"
                          " && openssl req -x509 -newkey ec -pkeyopt ec_paramgen_curve:prime256v1 -nodes -keyout other.key -out other.pem -days 1"
                          " -subj /CN=another-ca 2>/dev/null";
  return std::system(cmd.c_str()) == 0 ? dir : "";
}

// Runs `args` to its exit: {exit code, output}; {-1, output} when it is still running after 30 s or
// has written `serving` (then it is killed).
std::pair<int, std::string> RunToExit(const std::vector<std::string>& args, const std::string& log, const std::string& serving) {
  Process p = Process::Spawn(args, log);
  int status = 0;
  bool exited = false;
  WaitFor([&] {
    exited = exited || waitpid(p.pid, &status, WNOHANG) == p.pid;
    return exited || ReadText(log).find(serving) != std::string::npos;
  }, 30);
  if (exited) p.pid = -1;  // reaped
  return {exited && WIFEXITED(status) ? WEXITSTATUS(status) : -1, ReadText(log)};
}

TEST(SecurityTls, GrpcAndHttpRoundTripsOverTlsWithAThrowawayCa) {
  const std::string certs = MakeCertificates((fs::temp_directory_path() / ("kgd_security_tls_" + std::to_string(getpid()))).string());
  if (certs.empty()) GTEST_SKIP() << "openssl is not installed: no throwaway CA";
  // TLS without tokens on an address other machines reach: each door refuses to start, saying tokens are missing.
  const std::vector<std::string> tls_files = {"--tls-cert", certs + "/server.pem", "--tls-key", certs + "/server.key"};
  for (const std::string door : {"--listen", "--http"}) {
    std::vector<std::string> args = {KGD_SERVER_BINARY, "--data", certs + "/open_data", "--listen", door == "--listen" ? "0.0.0.0:0" : "127.0.0.1:0"};
    if (door == "--http") args.insert(args.end(), {"--http", "0.0.0.0:0"});
    args.insert(args.end(), tls_files.begin(), tls_files.end());
    const auto [exit_code, output] = RunToExit(args, certs + "/open" + door + ".log", door == "--listen" ? "listening on" : "http on");
    EXPECT_EQ(exit_code, 1) << door << ": " << output;
    EXPECT_NE(output.find("kgd-server: " + door +
                          " 0.0.0.0:0 is reachable from other machines: it needs tokens (--auth-tokens), or --insecure to serve it open"),
              std::string::npos)
        << output;
  }
  SecureService tls({"--tls-cert", certs + "/server.pem", "--tls-key", certs + "/server.key"}, {"--tls-ca", certs + "/ca.pem"}, "tls");
  ASSERT_TRUE(tls.ok()) << tls.Log();
  // The CLI over TLS with a token: a job submitted, run by the TLS worker, watched to its end.
  cli_test::CommandRun r = cli_test::Kgd("submit sleeve_on_limb --iterations 2 --watch --json --server " + tls.grpc() + " --tls-ca " + certs +
                                         "/ca.pem --token " + kAlice);
  EXPECT_EQ(r.exit_code, 0) << r.output << tls.Log();
  EXPECT_NE(r.output.find("SUCCEEDED"), std::string::npos) << r.output;
  // Without the CA the client connects in plaintext, which the server closes: the message says a
  // server with TLS needs the CA.
  r = cli_test::Kgd("jobs --server " + tls.grpc() + " --token " + kAlice);
  EXPECT_EQ(r.exit_code, 1) << r.output;
  EXPECT_NE(r.output.find("kgd jobs: cannot reach the design server at " + tls.grpc()), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("the server closed the plaintext connection: a server with TLS needs the CA that signed its certificate (--tls-ca"),
            std::string::npos)
      << r.output;
  // A CA that did not sign the server's certificate: the handshake fails, and says so.
  r = cli_test::Kgd("jobs --server " + tls.grpc() + " --token " + kAlice + " --tls-ca " + certs + "/other.pem");
  EXPECT_EQ(r.exit_code, 1) << r.output;
  EXPECT_NE(r.output.find("the TLS handshake failed: the server must serve TLS with a certificate signed by the CA in " + certs + "/other.pem (--tls-ca)"),
            std::string::npos)
      << r.output;
  // HTTPS with the CA.
  httplib::SSLClient https("127.0.0.1", tls.http_port());
  https.set_ca_cert_path((certs + "/ca.pem").c_str());
  https.enable_server_certificate_verification(true);
  https.set_bearer_token_auth(kAlice);
  auto res = https.Get("/v1/jobs");
  ASSERT_TRUE(res) << httplib::to_string(res.error());
  EXPECT_EQ(res->status, 200);
  EXPECT_NE(res->body.find("\"owner\":\"alice\""), std::string::npos) << res->body;
  httplib::Client plain("127.0.0.1", tls.http_port());
  EXPECT_FALSE(plain.Get("/v1/jobs")) << "plain HTTP answered on the HTTPS port";
  fs::remove_all(certs);
}

}  // namespace
}  // namespace kgd

namespace kgd {
namespace {

// A kgd-server without tokens and with the given limits, its HTTP door, and optionally a worker.
struct LimitedService {
  std::string dir;
  int http_port = 0;
  std::string grpc;
  Process server, worker;
  LimitedService(const std::string& name, const std::vector<std::string>& limits, bool with_worker) {
    dir = (fs::temp_directory_path() / ("kgd_security_limits_" + std::to_string(getpid()) + "_" + name)).string();
    fs::remove_all(dir);
    fs::create_directories(dir);
    grpc = "127.0.0.1:" + std::to_string(FreePort());
    http_port = FreePort();
    std::vector<std::string> args = {KGD_SERVER_BINARY, "--data", dir + "/data", "--listen", grpc, "--http", "127.0.0.1:" + std::to_string(http_port)};
    args.insert(args.end(), limits.begin(), limits.end());
    server = Process::Spawn(args, dir + "/server.log");
    if (with_worker) worker = Process::Spawn({KGD_WORKER_BINARY, "--server", grpc, "--name", "w"}, dir + "/worker.log");
    WaitFor([&] { return ReadText(dir + "/server.log").find("http on") != std::string::npos; }, 30);
  }
  ~LimitedService() { fs::remove_all(dir); }
  httplib::Client Http() const {
    httplib::Client c("127.0.0.1", http_port);
    c.set_read_timeout(60, 0);
    return c;
  }
};

// The response's status name and message, e.g. {"RESOURCE_EXHAUSTED", "..."}; {"OK", body} on success.
std::pair<std::string, std::string> Outcome(const httplib::Result& res) {
  if (!res) return {"NO_RESPONSE", httplib::to_string(res.error())};
  if (res->status == 200) return {"OK", res->body};
  const size_t s = res->body.find("\"status\": \"");
  return {s == std::string::npos ? "?" : res->body.substr(s + 11, res->body.find('"', s + 11) - s - 11), res->body};
}

std::string Job(int iterations) {
  return R"({"builtinScene": "sleeve_on_limb", "optimizer": {"maxIterations": )" + std::to_string(iterations) + "}}";
}

TEST(SecurityLimits, EachLimitIsHitAndNamed) {
  LimitedService s("requests",
                   {"--max-iterations", "50", "--max-mesh-vertices", "10", "--max-mesh-faces", "10", "--max-frames", "2", "--max-queued-per-user", "2",
                    "--max-watchers-per-job", "1", "--max-jobs-per-minute", "3"},
                   false);
  auto http = s.Http();
  auto expect_limit = [](const httplib::Result& res, const std::string& named) {
    const auto [status, message] = Outcome(res);
    EXPECT_EQ(status, "RESOURCE_EXHAUSTED") << message;
    EXPECT_NE(message.find(named), std::string::npos) << "the message names " << named << ": " << message;
  };
  // An iteration limit above the server's is a bad argument (400), naming the flag.
  {
    const auto res = http.Post("/v1/jobs", Job(51), "application/json");
    const auto [status, message] = Outcome(res);
    EXPECT_EQ(status, "INVALID_ARGUMENT") << message;
    EXPECT_EQ(res ? res->status : 0, 400);
    EXPECT_NE(message.find("51 is above this server's limit of 50 iterations (--max-iterations)"), std::string::npos) << message;
  }
  // An uploaded scene with a mesh of 12 vertices; then one with three motion frames.
  std::string obj;
  for (int i = 0; i < 12; ++i) obj += "v " + std::to_string(i) + " 0 0\n";
  httplib::MultipartFormDataItems big_mesh = {{"scene", R"({"garment": {"rest": "m.obj"}})", "scene.json", "application/json"},
                                              {"m.obj", obj, "m.obj", "text/plain"}};
  expect_limit(http.Post("/v1/jobs", big_mesh), "m.obj: vertices 12 is over the limit of 10 (--max-mesh-vertices)");
  std::string faces = "v 0 0 0\nv 1 0 0\nv 0 1 0\n";
  for (int i = 0; i < 11; ++i) faces += "f 1 2 3\n";
  httplib::MultipartFormDataItems many_faces = {{"scene", R"({"garment": {"rest": "m.obj"}})", "scene.json", "application/json"},
                                                {"m.obj", faces, "m.obj", "text/plain"}};
  expect_limit(http.Post("/v1/jobs", many_faces), "--max-mesh-faces");
  httplib::MultipartFormDataItems frames = {
      {"scene", R"({"body": {"rest": "r.obj", "deformed": "d.obj", "frames": ["a.obj", "b.obj", "c.obj"]}})", "scene.json", "application/json"}};
  expect_limit(http.Post("/v1/jobs", frames), "--max-frames");
  // The frames of the scene's other motions count too.
  httplib::MultipartFormDataItems motion_frames = {
      {"scene", R"({"body": {"rest": "r.obj", "deformed": "d.obj", "frames": ["a.obj"]},
                    "motions": [{"name": "m"}, {"name": "n", "deformed": "e.obj", "frames": ["f.obj", "g.obj"]}]})", "scene.json", "application/json"}};
  expect_limit(http.Post("/v1/jobs", motion_frames), "body.frames, motions[].frames: 3 frames; 3 is over the limit of 2 (--max-frames)");
  // And those of the scene's other bodies.
  httplib::MultipartFormDataItems body_frames = {
      {"scene", R"({"body": {"rest": "r.obj", "deformed": "d.obj", "frames": ["a.obj", "b.obj"]},
                    "bodies": [{"name": "M"}, {"name": "L", "rest": "s.obj", "deformed": "t.obj", "frames": ["u.obj"]}]})", "scene.json", "application/json"}};
  expect_limit(http.Post("/v1/jobs", body_frames), "body.frames, bodies[].frames: 3 frames; 3 is over the limit of 2 (--max-frames)");
  // Two jobs wait (no worker here); a third would be over the queue limit.
  const auto first = Outcome(http.Post("/v1/jobs", Job(5), "application/json"));
  ASSERT_EQ(first.first, "OK") << first.second;
  ASSERT_EQ(Outcome(http.Post("/v1/jobs", Job(5), "application/json")).first, "OK");
  expect_limit(http.Post("/v1/jobs", Job(5), "application/json"), "--max-queued-per-user");
  // One watch of job 1 is open; a second is refused while it lasts.
  std::atomic<bool> close{false}, open{false};
  std::thread watch([&] {
    s.Http().Get("/v1/jobs/1:watch?view=metrics", [&](const char*, size_t) {
      open = true;
      return !close.load();
    });
  });
  ASSERT_TRUE(WaitFor([&] { return open.load(); }, 30));
  expect_limit(http.Get("/v1/jobs/1:watch"), "--max-watchers-per-job");
  close = true;
  http.Post("/v1/jobs/1:cancel", "", "application/json");
  watch.join();
  // The third creation of the minute fits again in the queue; the fourth is over the rate.
  ASSERT_EQ(Outcome(http.Post("/v1/jobs", Job(5), "application/json")).first, "OK");
  http.Post("/v1/jobs/2:cancel", "", "application/json");
  expect_limit(http.Post("/v1/jobs", Job(5), "application/json"), "--max-jobs-per-minute");
  // Refusals change nothing stored: three jobs exist.
  const auto list = Outcome(http.Get("/v1/jobs"));
  EXPECT_EQ(list.first, "OK");
  EXPECT_NE(list.second.find("\"id\":\"3\""), std::string::npos) << list.second;
  EXPECT_EQ(list.second.find("\"id\":\"4\""), std::string::npos) << list.second;
}

TEST(SecurityLimits, AJobWhoseDesignFileOutgrowsTheLimitFailsNamingIt) {
  LimitedService s("file", {"--max-design-file-mb", "0.05", "--max-attempts", "1"}, true);
  auto http = s.Http();
  ASSERT_EQ(Outcome(http.Post("/v1/jobs", Job(200), "application/json")).first, "OK");
  std::string job;
  ASSERT_TRUE(WaitFor([&] {
    job = Outcome(http.Get("/v1/jobs/1")).second;
    return job.find("\"state\":\"FAILED\"") != std::string::npos;
  }, 300)) << job;
  EXPECT_NE(job.find("--max-design-file-mb"), std::string::npos) << job;
}

// ---- ports and pages: one server per port, and no other web site's page ----

// `kgd serve` as on a laptop: loopback, no tokens, no TLS, no workers (jobs stay queued), and one
// --allowed-host name.
class LaptopServe {
 public:
  explicit LaptopServe(const std::string& name) {
    dir_ = (fs::temp_directory_path() / ("kgd_security_laptop_" + std::to_string(getpid()) + "_" + name)).string();
    fs::remove_all(dir_);
    fs::create_directories(dir_);
    grpc_ = "127.0.0.1:" + std::to_string(FreePort());
    http_port_ = FreePort();
    server_ = Process::Spawn({KGD_BINARY, "serve", "--data", dir_ + "/data", "--listen", grpc_, "--http", "127.0.0.1:" + std::to_string(http_port_),
                              "--workers", "0", "--allowed-host", "kgd.test"},
                             dir_ + "/serve.log");
    ok_ = WaitFor([&] { return Log().find("web page and HTTP API") != std::string::npos; }, 30);
  }
  ~LaptopServe() {
    server_.Signal(SIGKILL);
    server_.Wait();
    if (!::testing::UnitTest::GetInstance()->failed_test_count()) fs::remove_all(dir_);
  }
  bool ok() const { return ok_; }
  std::string Log() const { return ReadText(dir_ + "/serve.log"); }
  int http_port() const { return http_port_; }
  const std::string& grpc() const { return grpc_; }
  const std::string& dir() const { return dir_; }
  pid_t pid() const { return server_.pid; }
  // A client of the HTTP door; a request's own Host header, when it gives one, replaces 127.0.0.1:PORT.
  httplib::Client Http() const {
    httplib::Client c("127.0.0.1", http_port_);
    c.set_read_timeout(30, 0);
    return c;
  }
  // The job list as the server itself answers it (Host 127.0.0.1:PORT, no Origin).
  std::string Jobs() const {
    auto res = Http().Get("/v1/jobs");
    return res && res->status == 200 ? res->body : "no answer";
  }

 private:
  std::string dir_, grpc_;
  int http_port_ = 0;
  bool ok_ = false;
  Process server_;
};

const char* kLabelledJob = R"({"builtinScene": "sleeve_on_limb", "optimizer": {"maxIterations": 2}, "label": "private-design-label"})";

// The studio's upload: a scene file (pull_test_line, exported into `dir`) and its meshes as multipart/form-data.
httplib::MultipartFormDataItems SceneUpload(const std::string& dir) {
  const cli_test::CommandRun exported = cli_test::Kgd("scene export pull_test_line " + dir);
  EXPECT_EQ(exported.exit_code, 0) << exported.output;
  httplib::MultipartFormDataItems items;
  for (const auto& entry : fs::directory_iterator(dir)) {
    const std::string name = entry.path().filename().string();
    items.push_back({name == "scene.json" ? "scene" : name, ReadText(entry.path().string()), name, "application/octet-stream"});
  }
  items.push_back({"spec", R"({"optimizer": {"maxIterations": 2}, "label": "uploaded"})", "spec.json", "application/json"});
  return items;
}

TEST(SecurityPorts, ASecondServerOnTakenPortsExitsNamingTheAddressAndWhatHoldsIt) {
  LaptopServe first("first");
  ASSERT_TRUE(first.ok()) << first.Log();
  const std::string grpc = first.grpc(), http = "127.0.0.1:" + std::to_string(first.http_port());
  const std::string dir = first.dir();
  // Both of the first's addresses: the gRPC one is refused first; nothing of the second's data folder is created.
  auto [code, out] = RunToExit({KGD_BINARY, "serve", "--data", dir + "/second", "--listen", grpc, "--http", http, "--workers", "0"},
                               dir + "/second.log", "listening on");
  EXPECT_NE(code, 0) << out;
  EXPECT_NE(code, -1) << "the second server started:\n" << out;
  EXPECT_NE(out.find("--listen " + grpc + ": address already in use"), std::string::npos) << out;
  EXPECT_NE(out.find("pid " + std::to_string(first.pid())), std::string::npos) << "the holder is named:\n" << out;
  EXPECT_FALSE(fs::exists(dir + "/second")) << out;
  // Its HTTP address alone, from kgd-server.
  std::tie(code, out) = RunToExit({KGD_SERVER_BINARY, "--data", dir + "/third", "--listen", "127.0.0.1:" + std::to_string(FreePort()), "--http", http},
                                  dir + "/third.log", "listening on");
  EXPECT_NE(code, 0) << out;
  EXPECT_NE(code, -1) << "the third server started:\n" << out;
  EXPECT_NE(out.find("--http " + http + ": address already in use"), std::string::npos) << out;
  EXPECT_NE(out.find("serve --data " + dir + "/data"), std::string::npos) << "the holder's command line:\n" << out;
  // The first still answers alone: a job created on it is in its list, every time.
  ASSERT_EQ(first.Http().Post("/v1/jobs", kLabelledJob, "application/json")->status, 200);
  for (int i = 0; i < 6; ++i) EXPECT_NE(first.Jobs().find("private-design-label"), std::string::npos) << "request " << i;
}

TEST(SecurityPages, AnotherSitesFormCannotCreateAJob) {
  LaptopServe s("csrf");
  ASSERT_TRUE(s.ok()) << s.Log();
  auto http = s.Http();
  // The multipart form any page may post cross-site without a preflight.
  const httplib::MultipartFormDataItems form = SceneUpload(s.dir() + "/scene");
  auto res = http.Post("/v1/jobs", {{"Origin", "https://evil.example"}}, form);
  ASSERT_TRUE(res);
  EXPECT_EQ(res->status, 403) << res->body;
  EXPECT_NE(res->body.find("https://evil.example"), std::string::npos) << res->body;
  // A text/plain body (the other kind a form or a no-cors fetch sends), a foreign Referer without an
  // Origin, an opaque origin (a sandboxed frame, a file), and another local port's page.
  res = http.Post("/v1/jobs", {{"Origin", "https://evil.example"}}, kLabelledJob, "text/plain");
  ASSERT_TRUE(res);
  EXPECT_EQ(res->status, 403) << res->body;
  res = http.Post("/v1/jobs", {{"Referer", "https://evil.example/attack.html?x=1"}}, kLabelledJob, "text/plain");
  ASSERT_TRUE(res);
  EXPECT_EQ(res->status, 403) << res->body;
  EXPECT_NE(res->body.find("https://evil.example (its Referer)"), std::string::npos) << res->body;
  res = http.Post("/v1/jobs", {{"Origin", "null"}}, kLabelledJob, "application/json");
  ASSERT_TRUE(res);
  EXPECT_EQ(res->status, 403) << res->body;
  res = http.Post("/v1/jobs", {{"Origin", "http://localhost:" + std::to_string(FreePort())}}, kLabelledJob, "application/json");
  ASSERT_TRUE(res);
  EXPECT_EQ(res->status, 403) << res->body;
  res = http.Post("/v1/jobs/1:cancel", {{"Origin", "https://evil.example"}}, "", "text/plain");
  ASSERT_TRUE(res);
  EXPECT_EQ(res->status, 403) << res->body;
  // No job was created.
  EXPECT_NE(s.Jobs().find("\"jobs\":[]"), std::string::npos) << s.Jobs();
}

TEST(SecurityPages, AForeignHostNameReadsNothing) {
  LaptopServe s("rebind");
  ASSERT_TRUE(s.ok()) << s.Log();
  auto http = s.Http();
  ASSERT_EQ(http.Post("/v1/jobs", kLabelledJob, "application/json")->status, 200);
  // A page whose name was rebound to 127.0.0.1: its requests carry its own name as the Host.
  const std::string evil = "evil.example:" + std::to_string(s.http_port());
  for (const std::string path : {"/v1/jobs", "/v1/jobs/1", "/v1/jobs/1:watch?view=metrics", "/", "/index.html", "/app.js"}) {
    // The answer's status and its first bytes (a watch that is served streams on while the job is
    // queued: its first event is enough).
    int status = 0;
    std::string body;
    http.Get(
        path, {{"Host", evil}}, [&](const httplib::Response& r) { return status = r.status, true; },
        [&](const char* data, size_t n) { return body.append(data, n), body.find("\n\n") == std::string::npos && body.size() < 4096; });
    EXPECT_EQ(status, 403) << path << ": " << body;
    EXPECT_NE(body.find("host '" + evil + "'"), std::string::npos) << path << ": " << body;
    EXPECT_EQ(body.find("private-design-label"), std::string::npos) << path << ": " << body;
  }
  auto res = http.Post("/v1/jobs", {{"Host", evil}, {"Origin", "http://" + evil}}, kLabelledJob, "application/json");
  ASSERT_TRUE(res);
  EXPECT_EQ(res->status, 403) << res->body;
  EXPECT_EQ(s.Jobs().find("\"id\":\"2\""), std::string::npos) << s.Jobs();
}

TEST(SecurityPages, TheServersOwnPageAndAnAllowedHostWork) {
  LaptopServe s("own");
  ASSERT_TRUE(s.ok()) << s.Log();
  auto http = s.Http();
  const std::string port = std::to_string(s.http_port());
  // The page at http://127.0.0.1:PORT/ and at http://localhost:PORT/: Chromium sends its Origin on its
  // same-origin POSTs (JSON and the studio's multipart upload).
  for (const std::string name : {"127.0.0.1", "localhost", "[::1]", "kgd.test"}) {
    const std::string host = name + ":" + port, origin = "http://" + host;
    auto res = http.Post("/v1/jobs", {{"Host", host}, {"Origin", origin}}, kLabelledJob, "application/json");
    ASSERT_TRUE(res) << host;
    EXPECT_EQ(res->status, 200) << host << ": " << res->body;
    res = http.Get("/v1/jobs", {{"Host", host}});
    ASSERT_TRUE(res) << host;
    EXPECT_EQ(res->status, 200) << host << ": " << res->body;
    EXPECT_NE(res->body.find("private-design-label"), std::string::npos) << host << ": " << res->body;
    res = http.Get("/", {{"Host", host}, {"Referer", origin + "/"}});
    ASSERT_TRUE(res) << host;
    EXPECT_EQ(res->status, 200) << host;
  }
  // An upload from its own page, with the Referer it sends beside its Origin.
  auto res = http.Post("/v1/jobs", {{"Origin", "http://127.0.0.1:" + port}, {"Referer", "http://127.0.0.1:" + port + "/#studio"}},
                       SceneUpload(s.dir() + "/scene"));
  ASSERT_TRUE(res);
  EXPECT_EQ(res->status, 200) << res->body;
  // A program (curl, the tests) sends neither Origin nor Referer.
  EXPECT_EQ(http.Post("/v1/jobs", kLabelledJob, "application/json")->status, 200);
  // The CLI talks gRPC and is not affected.
  const cli_test::CommandRun jobs = cli_test::Kgd("jobs --server " + s.grpc());
  EXPECT_EQ(jobs.exit_code, 0) << jobs.output;
  EXPECT_NE(jobs.output.find("private-design-label"), std::string::npos) << jobs.output;
}

}  // namespace
}  // namespace kgd
