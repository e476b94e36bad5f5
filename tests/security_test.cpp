// The design service's security as it runs for real: a kgd-server process with --auth-tokens (and,
// for the TLS cases, certificates from a throwaway CA that openssl makes in the test), a kgd-worker
// with a worker token, reached over gRPC and HTTP. No token is UNAUTHENTICATED; a user cannot see,
// watch, fetch, export or cancel another's job on any RPC or HTTP route (NOT_FOUND, the same answer
// as for a job that does not exist); a worker token cannot list or read; an admin sees all; a
// non-loopback address without TLS and tokens is refused.
#include <grpcpp/grpcpp.h>
#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <functional>
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

bool WaitFor(const std::function<bool()>& done, double timeout_s) {
  const auto end = std::chrono::steady_clock::now() + std::chrono::duration<double>(timeout_s);
  while (std::chrono::steady_clock::now() < end) {
    if (done()) return true;
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  return done();
}

std::string ReadText(const std::string& path) {
  std::ifstream in(path);
  return std::string(std::istreambuf_iterator<char>(in), {});
}

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

TEST_F(Security, AUserCannotSeeWatchFetchExportOrCancelAnothersJobOnAnyRoute) {
  const v1::Job job = CreateAs(kAlice, 3);
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
    grpc::Status evs = stub->GetEvaluation(As(token).get(), ev, &evr);
    // A job without an evaluation is NOT_FOUND for its owner too; only the wording differs.
    out.push_back({"GetEvaluation", evs.error_code() == grpc::StatusCode::NOT_FOUND && evs.error_message().find("has no evaluation") != std::string::npos
                                        ? grpc::Status::OK
                                        : evs});
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

  // HTTP: every route on the job, as bob: 404 NOT_FOUND; as alice: not 404 and not 401/403.
  const std::vector<std::string> gets = {"", ":watch", "/iterations/-1", "/iterations/0/positions.f32", "/iterations/0/energy.f32",
                                         "/iterations/0/design.u8", "/iterations/0/design.ply", "/iterations/-1/cut/report.json",
                                         "/garment/faces.u32", "/garment/rest.f32", "/body/vertices.f32", "/design-file", "/evaluation"};
  for (const std::string& route : gets) {
    auto bob = Http(kBob).Get("/v1/jobs/" + id + route);
    ASSERT_TRUE(bob) << route;
    EXPECT_EQ(bob->status, 404) << route << ": " << bob->body;
    EXPECT_NE(bob->body.find("\"NOT_FOUND\""), std::string::npos) << route;
    EXPECT_NE(bob->body.find("job " + id + " does not exist"), std::string::npos) << route << ": " << bob->body;
    auto alice = Http(kAlice).Get("/v1/jobs/" + id + route);
    ASSERT_TRUE(alice) << route;
    EXPECT_TRUE(alice->status != 401 && alice->status != 403 && (alice->status != 404 || alice->body.find("does not exist") == std::string::npos))
        << route << ": " << alice->status << " " << alice->body;
  }
  auto cancel = Http(kBob).Post("/v1/jobs/" + id + ":cancel", "", "application/json");
  ASSERT_TRUE(cancel);
  EXPECT_EQ(cancel->status, 404);
  auto list = Http(kBob).Get("/v1/jobs");
  ASSERT_TRUE(list && list->status == 200);
  EXPECT_EQ(list->body.find("\"id\":\"" + id + "\""), std::string::npos) << list->body;
  auto root_list = Http(kRoot).Get("/v1/jobs");
  ASSERT_TRUE(root_list && root_list->status == 200);
  EXPECT_NE(root_list->body.find("\"id\":\"" + id + "\""), std::string::npos) << root_list->body;
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

// A throwaway CA and a server certificate for 127.0.0.1 it signed, by openssl; empty when openssl is absent.
std::string MakeCertificates(const std::string& dir) {
  fs::create_directories(dir);
  const std::string cmd = "cd " + dir +
                          " && openssl req -x509 -newkey rsa:2048 -nodes -keyout ca.key -out ca.pem -days 1 -subj /CN=kgd-test-ca 2>/dev/null"
                          " && openssl req -newkey rsa:2048 -nodes -keyout server.key -out server.csr -subj /CN=127.0.0.1 2>/dev/null"
                          " && printf 'subjectAltName=IP:127.0.0.1,DNS:localhost\\n' > san.ext"
                          " && openssl x509 -req -in server.csr -CA ca.pem -CAkey ca.key -CAcreateserial -out server.pem -days 1 -extfile san.ext 2>/dev/null";
  return std::system(cmd.c_str()) == 0 ? dir : "";
}

TEST(SecurityTls, GrpcAndHttpRoundTripsOverTlsWithAThrowawayCa) {
  const std::string certs = MakeCertificates((fs::temp_directory_path() / ("kgd_security_tls_" + std::to_string(getpid()))).string());
  if (certs.empty()) GTEST_SKIP() << "openssl is not installed: no throwaway CA";
  SecureService tls({"--tls-cert", certs + "/server.pem", "--tls-key", certs + "/server.key"}, {"--tls-ca", certs + "/ca.pem"}, "tls");
  ASSERT_TRUE(tls.ok()) << tls.Log();
  // The CLI over TLS with a token: a job submitted, run by the TLS worker, watched to its end.
  cli_test::CommandRun r = cli_test::Kgd("submit sleeve_on_limb --iterations 2 --watch --json --server " + tls.grpc() + " --tls-ca " + certs +
                                         "/ca.pem --token " + kAlice);
  EXPECT_EQ(r.exit_code, 0) << r.output << tls.Log();
  EXPECT_NE(r.output.find("SUCCEEDED"), std::string::npos) << r.output;
  // Without the CA the client does not trust the server; plaintext does not reach it.
  r = cli_test::Kgd("jobs --server " + tls.grpc() + " --token " + kAlice);
  EXPECT_EQ(r.exit_code, 1) << r.output;
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
  expect_limit(http.Post("/v1/jobs", Job(51), "application/json"), "--max-iterations");
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

}  // namespace
}  // namespace kgd
