#include <sys/stat.h>
#include "client/service_commands.h"

#include <grpcpp/grpcpp.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <memory>
#include <nlohmann/json.hpp>
#include <thread>

#include "client/metrics_json.h"
#include "client/optimizer_flags.h"
#include "core/mesh/mesh_io.h"
#include "core/util/termination.h"
#include "kgd/v1/kgd.grpc.pb.h"
#include "proto/job_spec.h"
#include "job/fabrication_export.h"
#include "proto/records.h"
#include "proto/connection.h"
#include "server/service_flags.h"
#include "worker/design_worker.h"

namespace kgd::cli {

std::string DefaultServer() { return ConnectionFromEnvironment().server; }

// The token and TLS CA of this run's client commands (--token, --tls-ca; defaults from the environment).
Connection& ClientConnection() {
  static Connection c = ConnectionFromEnvironment();
  return c;
}

void AddServerOptions(CLI::App* command, std::string* server, const std::string& what) {
  command->add_option("--server", *server, what + " (default: $KGD_SERVER or 127.0.0.1:7447)")->capture_default_str();
  command->add_option("--token", ClientConnection().token, "Your token, for a server with --auth-tokens (default: $KGD_TOKEN)");
  command->add_option("--tls-ca", ClientConnection().tls_ca,
                      "PEM file of the CA that signed the server's certificate: connect over TLS (default: $KGD_TLS_CA)");
}

namespace {

// A stub on the server with this run's token and TLS; null (after a message) when the CA file is bad.
std::unique_ptr<v1::DesignService::Stub> Connect(const std::string& server) {
  grpc::ChannelArguments args;
  args.SetMaxReceiveMessageSize(256 << 20);
  args.SetMaxSendMessageSize(256 << 20);
  args.SetInt(GRPC_ARG_MAX_RECONNECT_BACKOFF_MS, 1000);
  Connection c = ClientConnection();
  c.server = server;
  Result<std::shared_ptr<grpc::Channel>> channel = OpenChannel(c, args);
  if (!channel.ok()) {
    std::fprintf(stderr, "kgd: %s\n", channel.message().c_str());
    return nullptr;
  }
  return v1::DesignService::NewStub(*channel);
}

// What a server that cannot be reached should make the user do, from gRPC's error: a plaintext
// connection that a server closes at once is one with TLS; a failed handshake, the wrong CA (or a
// server without TLS).
std::string ReachHint(const std::string& error) {
  const std::string& ca = ClientConnection().tls_ca;
  if (ca.empty() && error.find("Socket closed") != std::string::npos)
    return "the server closed the plaintext connection: a server with TLS needs the CA that signed its certificate (--tls-ca, or $KGD_TLS_CA)";
  if (!ca.empty() && error.find("andshake failed") != std::string::npos)
    return "the TLS handshake failed: the server must serve TLS with a certificate signed by the CA in " + ca + " (--tls-ca)";
  return "start one with `kgd serve --data DIR` or set --server";
}

// gRPC errors as exit codes: unknown job and bad requests are the user's (2), the rest the server's (1).
int FailRpc(const char* command, const std::string& server, const grpc::Status& st) {
  const bool users = st.error_code() == grpc::StatusCode::NOT_FOUND || st.error_code() == grpc::StatusCode::INVALID_ARGUMENT ||
                     st.error_code() == grpc::StatusCode::RESOURCE_EXHAUSTED;
  // The server's own refusal (it takes no new jobs now: its disk is full, it drains) reached the user.
  const bool refused = st.error_message().rfind("the server takes no new jobs now", 0) == 0;
  if (!refused && (st.error_code() == grpc::StatusCode::UNAVAILABLE || st.error_code() == grpc::StatusCode::DEADLINE_EXCEEDED))
    std::fprintf(stderr, "kgd %s: cannot reach the design server at %s (%s); %s\n", command, server.c_str(), st.error_message().c_str(),
                 ReachHint(st.error_message()).c_str());
  else
    std::fprintf(stderr, "kgd %s: %s\n", command, st.error_message().c_str());
  return users ? 2 : 1;
}

void SetDeadline(grpc::ClientContext* ctx, double seconds) {
  ctx->set_deadline(std::chrono::system_clock::now() + std::chrono::milliseconds(static_cast<int64_t>(seconds * 1000)));
}

std::string StateName(v1::JobState s) { return v1::JobState_Name(s); }

nlohmann::ordered_json JobJson(const v1::Job& job) {
  nlohmann::ordered_json j;
  j["id"] = job.id();
  j["scene"] = JobSceneName(job.spec());
  j["label"] = job.spec().label();
  j["state"] = StateName(job.state());
  if (job.state() == v1::RUNNING && job.phase() != v1::JOB_PHASE_UNSPECIFIED) j["phase"] = v1::JobPhase_Name(job.phase());
  j["iterations"] = job.iterations();
  j["attempts"] = job.attempts();
  j["create_time_s"] = job.create_time_s();
  j["update_time_s"] = job.update_time_s();
  if (job.iterations() > 0) j["last"] = MetricsJson(job.last());
  if (!job.failure().empty()) j["failure"] = job.failure();
  if (!job.worker().empty()) j["worker"] = job.worker();
  if (!job.kernels().empty()) j["kernels"] = job.kernels();
  if (job.cancel_requested()) j["cancel_requested"] = true;
  if (!job.paused().empty()) j["paused"] = job.paused();
  if (!job.data_file().empty()) j["data_file"] = job.data_file();
  return j;
}

std::atomic<bool> g_interrupted{false};
extern "C" void OnWatchInterrupt(int) { g_interrupted = true; }

// ---------------------------------------------------------------------------------------------------

struct WatchOptions {
  std::string server = DefaultServer();
  int64_t job = 0;
  int from = 0;
  bool json = false;
  double retry_s = 60;
};

int ExitForState(v1::JobState s) { return s == v1::SUCCEEDED ? 0 : s == v1::FAILED ? 3 : 4; }

bool Terminal(v1::JobState s) { return s == v1::SUCCEEDED || s == v1::FAILED || s == v1::CANCELLED; }

// A running job past its last iteration: its final design simulated over the motion and beside Line and X.
bool Evaluating(const v1::Job& job) { return job.state() == v1::RUNNING && job.phase() == v1::EVALUATING; }

void PrintSummary(const v1::Job& job) {
  std::printf("job %lld %s%s after %d iterations", static_cast<long long>(job.id()), StateName(job.state()).c_str(),
              Evaluating(job) ? " (evaluating the final design)" : "", job.iterations());
  if (job.iterations() > 0)
    std::printf(": area %.1f%%, reinforced energy density %.4g J/m^2 = %.3f x fully reinforced", 100 * job.last().area_fraction(),
                job.last().reinforced_density_j_per_m2(), job.last().density_ratio());
  std::printf("\n");
  if (!job.failure().empty()) std::printf("failure: %s\n", job.failure().c_str());
  if (!job.data_file().empty()) std::printf("design history: %s (on the server; kgd get %lld --out design.ply)\n", job.data_file().c_str(),
                                            static_cast<long long>(job.id()));
}

// Follows a job to its end; after a dropped stream it reconnects from the next iteration it lacks.
int RunWatch(const WatchOptions& o) {
  auto stub = Connect(o.server);
  if (!stub) return 2;
  const bool bar = !o.json && isatty(STDOUT_FILENO);
  int next = o.from;
  v1::Job job;
  bool have_job = false;
  auto last_contact = std::chrono::steady_clock::now();
  g_interrupted = false;
  std::signal(SIGINT, OnWatchInterrupt);
  int result = 130;
  while (!g_interrupted) {
    grpc::ClientContext ctx;
    Authorize(ClientConnection(), &ctx);
    v1::WatchJobRequest req;
    req.set_id(o.job);
    req.set_from_iteration(next);
    std::atomic<bool> reading{true};
    // Ctrl-C while blocked in Read: cancel the call from beside it.
    std::thread canceller([&] {
      while (reading && !g_interrupted) std::this_thread::sleep_for(std::chrono::milliseconds(20));
      if (g_interrupted) ctx.TryCancel();
    });
    auto reader = stub->WatchJob(&ctx, req);
    v1::WatchJobEvent ev;
    bool out_of_order = false;
    while (reader->Read(&ev)) {
      last_contact = std::chrono::steady_clock::now();
      if (ev.has_job()) {
        const bool changed = !have_job || ev.job().state() != job.state() || ev.job().paused() != job.paused();
        const bool was_paused = have_job && !job.paused().empty();
        job = ev.job();
        have_job = true;
        if (changed && !bar) {
          nlohmann::ordered_json j{{"event", "state"}, {"job", job.id()}, {"state", StateName(job.state())}};
          if (!job.failure().empty()) j["failure"] = job.failure();
          if (!job.paused().empty()) j["paused"] = job.paused();
          std::printf("%s\n", j.dump().c_str());
        } else if (changed && bar && !job.paused().empty()) {
          std::printf("\njob %lld paused: %s; it continues by itself when the server can store again\n", static_cast<long long>(job.id()),
                      job.paused().c_str());
        } else if (changed && bar && was_paused) {
          std::printf("\njob %lld continues\n", static_cast<long long>(job.id()));
        }
      } else if (ev.has_iteration()) {
        const v1::IterationMetrics& m = ev.iteration().metrics();
        if (m.iteration() != next) {
          std::fprintf(stderr, "kgd watch: the stream sent iteration %d where %d was due\n", m.iteration(), next);
          out_of_order = true;
          ctx.TryCancel();
          break;
        }
        ++next;
        if (bar) {
          std::printf("\rjob %lld  it %3d  area %5.1f%%  ratio %.3f  %.2f s/it   ", static_cast<long long>(job.id()), m.iteration(),
                      100 * m.area_fraction(), m.density_ratio(), m.total_s());
        } else {
          nlohmann::ordered_json j{{"event", "iteration"}, {"job", job.id()}};
          j.update(MetricsJson(m));
          j["reinforced_faces"] = std::count(ev.iteration().design().begin(), ev.iteration().design().end(), '\1');
          std::printf("%s\n", j.dump().c_str());
        }
      }
      std::fflush(stdout);
    }
    const grpc::Status st = reader->Finish();
    reading = false;
    canceller.join();
    if (out_of_order) return 1;
    if (g_interrupted) break;
    if (st.ok() && have_job && Terminal(job.state())) {
      if (bar) {
        std::printf("\n");
        PrintSummary(job);
      }
      result = ExitForState(job.state());
      break;
    }
    if (st.error_code() == grpc::StatusCode::NOT_FOUND || st.error_code() == grpc::StatusCode::INVALID_ARGUMENT)
      return FailRpc("watch", o.server, st);
    if (std::chrono::steady_clock::now() - last_contact > std::chrono::duration<double>(o.retry_s)) return FailRpc("watch", o.server, st);
    // Dropped (server restarting, network): reconnect and continue after the last iteration received.
    if (bar) std::printf("\r(reconnecting to %s ...)%-30s", o.server.c_str(), "");
    std::fflush(stdout);
    std::this_thread::sleep_for(std::chrono::milliseconds(300));
  }
  std::signal(SIGINT, SIG_DFL);
  if (result == 130) {
    if (bar) std::printf("\n");
    std::fprintf(stderr, "kgd watch: stopped watching (the job goes on); continue with: kgd watch %lld --from %d\n",
                 static_cast<long long>(o.job), next);
  }
  return result;
}

// ---------------------------------------------------------------------------------------------------

struct SubmitOptions {
  std::string server = DefaultServer();
  std::string scene, label;
  std::vector<std::string> body;
  OptimizerFlags optimizer;
  bool watch = false, json = false;
};

int RunSubmit(const SubmitOptions& o) {
  v1::CreateJobRequest req;
  v1::JobSpec& spec = *req.mutable_spec();
  if (std::filesystem::exists(o.scene)) {
    Result<v1::SceneFiles> files = ReadSceneFiles(o.scene);
    if (!files.ok()) {
      std::fprintf(stderr, "kgd submit: %s\n", files.message().c_str());
      return 2;
    }
    *spec.mutable_scene_files() = std::move(files).value();
  } else {
    spec.set_builtin_scene(o.scene);
  }
  for (const std::string& b : o.body) spec.add_body(b);
  *spec.mutable_optimizer() = ToProto(o.optimizer);
  spec.set_label(o.label);
  if (Status st = ValidateJobSpec(spec); !st.ok()) {  // the server checks too; this saves a round trip
    std::fprintf(stderr, "kgd submit: %s\n", st.message().c_str());
    return 2;
  }
  auto stub = Connect(o.server);
  if (!stub) return 2;
  grpc::ClientContext ctx;
  Authorize(ClientConnection(), &ctx);
  SetDeadline(&ctx, 30);
  v1::Job job;
  const grpc::Status st = stub->CreateJob(&ctx, req, &job);
  if (!st.ok()) return FailRpc("submit", o.server, st);
  if (o.json) std::printf("%s\n", JobJson(job).dump().c_str());
  else std::printf("job %lld queued (%s)\n", static_cast<long long>(job.id()), JobSceneName(spec).c_str());
  std::fflush(stdout);
  if (!o.watch) return 0;
  WatchOptions w;
  w.server = o.server;
  w.job = job.id();
  w.json = o.json;
  return RunWatch(w);
}

int RunJobs(const std::string& server, const std::string& state, int limit, bool json) {
  v1::ListJobsRequest req;
  if (!state.empty()) {
    v1::JobState s;
    std::string upper = state;
    for (char& c : upper) c = static_cast<char>(std::toupper(static_cast<unsigned char>(c)));
    if (!v1::JobState_Parse(upper, &s) || s == v1::JOB_STATE_UNSPECIFIED) {
      std::fprintf(stderr, "kgd jobs: --state %s: not one of queued, running, succeeded, failed, cancelled\n", state.c_str());
      return 2;
    }
    req.set_state_filter(s);
  }
  auto stub = Connect(server);
  if (!stub) return 2;
  std::vector<v1::Job> jobs;
  for (;;) {
    req.set_page_size(std::min(limit - static_cast<int>(jobs.size()), 1000));
    grpc::ClientContext ctx;
    Authorize(ClientConnection(), &ctx);
    SetDeadline(&ctx, 30);
    v1::ListJobsResponse page;
    const grpc::Status st = stub->ListJobs(&ctx, req, &page);
    if (!st.ok()) return FailRpc("jobs", server, st);
    for (const v1::Job& j : page.jobs()) jobs.push_back(j);
    if (page.next_page_token().empty() || static_cast<int>(jobs.size()) >= limit) break;
    req.set_page_token(page.next_page_token());
  }
  if (json) {
    nlohmann::ordered_json all = nlohmann::ordered_json::array();
    for (const v1::Job& j : jobs) all.push_back(JobJson(j));
    std::printf("%s\n", all.dump().c_str());
    return 0;
  }
  std::printf("%6s  %-10s  %-22s  %5s  %7s  %7s  %s\n", "id", "state", "scene", "iters", "area_%", "ratio", "label");
  for (const v1::Job& j : jobs) {
    std::printf("%6lld  %-10s  %-22s  %5d  ", static_cast<long long>(j.id()), StateName(j.state()).c_str(), JobSceneName(j.spec()).c_str(),
                j.iterations());
    if (j.iterations() > 0) std::printf("%7.1f  %7.3f  ", 100 * j.last().area_fraction(), j.last().density_ratio());
    else std::printf("%7s  %7s  ", "-", "-");
    std::printf("%s\n", j.spec().label().c_str());
  }
  return 0;
}

int RunJob(const std::string& server, int64_t id, bool json) {
  auto stub = Connect(server);
  if (!stub) return 2;
  grpc::ClientContext ctx;
  Authorize(ClientConnection(), &ctx);
  SetDeadline(&ctx, 30);
  v1::GetJobRequest req;
  req.set_id(id);
  v1::Job job;
  const grpc::Status st = stub->GetJob(&ctx, req, &job);
  if (!st.ok()) return FailRpc("job", server, st);
  if (json) {
    std::printf("%s\n", JobJson(job).dump().c_str());
    return 0;
  }
  std::printf("job %lld: %s%s, scene %s%s%s\n", static_cast<long long>(job.id()), StateName(job.state()).c_str(),
              Evaluating(job) ? " (evaluating the final design over the motion and beside Line and X)" : "",
              JobSceneName(job.spec()).c_str(),
              job.spec().label().empty() ? "" : ", label ", job.spec().label().c_str());
  std::printf("attempts %d%s%s\n", job.attempts(), job.worker().empty() ? "" : ", worker ", job.worker().c_str());
  if (!job.paused().empty())
    std::printf("paused: %s; it continues by itself, losing nothing, when the server can store again\n", job.paused().c_str());
  // A queued job with iterations resumes only at their kernel level (server/job_store.h LeaseNext).
  if (!job.kernels().empty()) {
    std::string line = "kernels " + job.kernels();
    if (job.state() == v1::QUEUED && job.iterations() > 0)
      line += job.kernels() == "unknown" ? ": no worker resumes it (an older worker computed its iterations without saying its kernels)"
                                         : std::string(": waits for ") + (job.kernels() == "native" ? "a " : "an ") + job.kernels() + " worker";
    std::printf("%s\n", line.c_str());
  }
  PrintSummary(job);
  return 0;
}

int RunCancel(const std::string& server, int64_t id) {
  auto stub = Connect(server);
  if (!stub) return 2;
  grpc::ClientContext ctx;
  Authorize(ClientConnection(), &ctx);
  SetDeadline(&ctx, 30);
  v1::CancelJobRequest req;
  req.set_id(id);
  v1::Job job;
  const grpc::Status st = stub->CancelJob(&ctx, req, &job);
  if (!st.ok()) return FailRpc("cancel", server, st);
  if (job.state() == v1::RUNNING) std::printf("job %lld: cancel requested; it stops after its current iteration\n", static_cast<long long>(id));
  else std::printf("job %lld: %s\n", static_cast<long long>(id), StateName(job.state()).c_str());
  return 0;
}

int RunGet(const std::string& server, int64_t id, int iteration, const std::string& out, bool json) {
  auto stub = Connect(server);
  if (!stub) return 2;
  grpc::ClientContext ctx;
  Authorize(ClientConnection(), &ctx);
  SetDeadline(&ctx, 60);
  v1::GetIterationRequest req;
  req.set_id(id);
  req.set_iteration(iteration);
  req.set_with_garment(!out.empty());
  v1::GetIterationResponse resp;
  const grpc::Status st = stub->GetIteration(&ctx, req, &resp);
  if (!st.ok()) return FailRpc("get", server, st);
  if (!out.empty()) {
    DesignFileHeader h;
    if (Status g = GarmentFromProto(resp.garment(), &h); !g.ok()) {
      std::fprintf(stderr, "kgd get: the server sent a bad garment: %s\n", g.message().c_str());
      return 1;
    }
    Result<BesoIteration> it = RecordFromProto(resp.record(), static_cast<int>(h.garment.faces.rows()), static_cast<int>(h.garment.vertices.rows()));
    if (!it.ok()) {
      std::fprintf(stderr, "kgd get: the server sent a bad iteration: %s\n", it.message().c_str());
      return 1;
    }
    if (Status w = WriteGarmentPly(out, it->positions, h.garment.faces, it->design, it->energy_density_Pa); !w.ok()) {
      std::fprintf(stderr, "kgd get: %s\n", w.message().c_str());
      return 2;
    }
  }
  const v1::IterationMetrics& m = resp.record().metrics();
  if (json) {
    nlohmann::ordered_json j = MetricsJson(m);
    j["job"] = id;
    if (!out.empty()) j["file"] = out;
    std::printf("%s\n", j.dump().c_str());
  } else {
    std::printf("job %lld iteration %d: area %.2f%%, energy %.6g J, reinforced density %.6g J/m^2, ratio %.4f%s%s\n",
                static_cast<long long>(id), m.iteration(), 100 * m.area_fraction(), m.energy_j(), m.reinforced_density_j_per_m2(),
                m.density_ratio(), out.empty() ? "" : "; wrote ", out.c_str());
  }
  return 0;
}

struct ServeOptions {
  server::ServiceFlags service;
  int workers = 1;
  int jobs_per_worker = 1;
  bool no_http = false;
};

int RunServe(const ServeOptions& o) {
  Result<server::HostOptions> options = server::HostOptionsOf(o.service);
  if (!options.ok()) {
    std::fprintf(stderr, "kgd serve: %s\n", options.message().c_str());
    return 1;
  }
  if (o.no_http) options->http.address.clear();
  options->in_process_workers = o.workers > 0;
  umask(077);  // the data folder's files (SQLite, HDF5) are the owner's alone: 0600
  BlockTerminationSignals();
  auto host = server::ServiceHost::Start(*options);
  if (!host.ok()) {
    std::fprintf(stderr, "kgd serve: %s\n", host.message().c_str());
    return 1;
  }
  std::vector<std::unique_ptr<worker::DesignWorker>> workers;
  for (int i = 0; i < o.workers; ++i) {
    worker::WorkerOptions wo;
    wo.connection = (*host)->worker_connection();
    wo.jobs = o.jobs_per_worker;
    wo.quiet = options->service.quiet;
    wo.name = "serve-" + std::to_string(getpid()) + "-" + std::to_string(i);
    auto w = worker::DesignWorker::Start(wo);
    if (!w.ok()) {
      std::fprintf(stderr, "kgd serve: %s\n", w.message().c_str());
      return 2;
    }
    workers.push_back(std::move(w).value());
  }
  std::printf("listening on %s; data in %s; %d in-process worker%s\n", (*host)->grpc_address().c_str(), options->service.data_dir.c_str(), o.workers,
              o.workers == 1 ? "" : "s");
  if (!(*host)->http_url().empty()) std::printf("web page and HTTP API: %s\n", (*host)->http_url().c_str());
  std::fflush(stdout);
  WaitForTerminationSignal();
  (*host)->Shutdown([&] {
    for (auto& w : workers) w->Stop();
    for (auto& w : workers) w->Wait();
  });
  return 0;
}

}  // namespace

void AddServiceCommands(CLI::App& app, int* exit_code) {
  auto serve = std::make_shared<ServeOptions>();
  serve->service.host.http.web_dir = KGD_WEB_DIR;  // and the HTTP door on its default address
  CLI::App* sv = app.add_subcommand("serve", "Run the design service with in-process workers on a data folder (Ctrl-C drains and stops)");
  server::AddServiceFlags(sv, &serve->service);
  sv->add_option("--workers", serve->workers, "In-process workers (0: only external kgd-worker processes)")->check(CLI::NonNegativeNumber)->capture_default_str();
  sv->add_flag("--no-http", serve->no_http, "gRPC only: no web page, no HTTP API");
  sv->callback([serve, exit_code] { *exit_code = RunServe(*serve); });

  auto submit = std::make_shared<SubmitOptions>();
  CLI::App* sb = app.add_subcommand("submit", "Queue a design job on the design service");
  sb->add_option("scene", submit->scene, "Scene file (JSON; sent with the files it names) or a built-in scene name")->required();
  sb->add_option("--body", submit->body, "A measurement of the parametric body, name=value in SI (repeatable)");
  sb->add_option("--label", submit->label, "Free text shown in listings");
  AddServerOptions(sb, &submit->server, "The design server, host:port");
  sb->add_flag("--watch", submit->watch, "Then follow the job as `kgd watch` does");
  sb->add_flag("--json", submit->json, "Print JSON (the job; with --watch, one line per event)");
  AddOptimizerFlags(sb, &submit->optimizer);
  sb->callback([submit, exit_code] { *exit_code = RunSubmit(*submit); });

  auto watch = std::make_shared<WatchOptions>();
  CLI::App* wt = app.add_subcommand("watch", "Follow a job live: a progress bar on a terminal, JSON lines otherwise; reconnects when dropped");
  wt->add_option("job", watch->job, "Job id")->required();
  wt->add_option("--from", watch->from, "Replay stored iterations from this one")->check(CLI::NonNegativeNumber);
  AddServerOptions(wt, &watch->server, "The design server, host:port");
  wt->add_option("--retry-s", watch->retry_s, "Give up after this long without reaching the server")->capture_default_str();
  wt->add_flag("--json", watch->json, "One JSON line per event");
  wt->callback([watch, exit_code] { *exit_code = RunWatch(*watch); });

  struct Common {
    std::string server = DefaultServer();
    int64_t job = 0;
    bool json = false;
    std::string state, out;
    int limit = 50, iteration = -1;
  };
  auto c = std::make_shared<Common>();
  CLI::App* js = app.add_subcommand("jobs", "List jobs, newest first");
  js->add_option("--state", c->state, "Only jobs in this state (queued, running, succeeded, failed, cancelled)");
  js->add_option("--limit", c->limit, "At most this many")->check(CLI::PositiveNumber)->capture_default_str();
  AddServerOptions(js, &c->server, "The design server, host:port");
  js->add_flag("--json", c->json, "Print as a JSON array");
  js->callback([c, exit_code] { *exit_code = RunJobs(c->server, c->state, c->limit, c->json); });

  CLI::App* jb = app.add_subcommand("job", "Show one job");
  jb->add_option("job", c->job, "Job id")->required();
  AddServerOptions(jb, &c->server, "The design server, host:port");
  jb->add_flag("--json", c->json, "Print as JSON");
  jb->callback([c, exit_code] { *exit_code = RunJob(c->server, c->job, c->json); });

  CLI::App* cn = app.add_subcommand("cancel", "Cancel a job (a running one stops after its current iteration)");
  cn->add_option("job", c->job, "Job id")->required();
  AddServerOptions(cn, &c->server, "The design server, host:port");
  cn->callback([c, exit_code] { *exit_code = RunCancel(c->server, c->job); });

  CLI::App* hl = app.add_subcommand("health", "Exit 0 when the design server answers gRPC health checking with SERVING (for probes)");
  AddServerOptions(hl, &c->server, "The design server, host:port");
  hl->callback([c, exit_code] {
    Connection conn = ClientConnection();
    conn.server = c->server;
    const Status st = CheckHealth(conn, 5);
    if (!st.ok()) std::fprintf(stderr, "kgd health: %s\n", st.message().c_str());
    *exit_code = st.ok() ? 0 : 1;
  });

  CLI::App* gt = app.add_subcommand("get", "Fetch one stored iteration of a job: metrics, and with --out its design on the garment as PLY");
  gt->add_option("job", c->job, "Job id")->required();
  gt->add_option("--iteration", c->iteration, "Which iteration (default: the last stored)");
  gt->add_option("--out", c->out, "Write the equilibrium garment as PLY with per-face design and energy_density_Pa");
  AddServerOptions(gt, &c->server, "The design server, host:port");
  gt->add_flag("--json", c->json, "Print the metrics as JSON");
  gt->callback([c, exit_code] { *exit_code = RunGet(c->server, c->job, c->iteration, c->out, c->json); });
}

void PrintExportProgress(const std::string& stage, double fraction) { std::fprintf(stderr, "export: %3.0f%% %s\n", 100 * fraction, stage.c_str()); }

int RunExportJob(const ExportJobRequest& r) {
  auto stub = Connect(r.server);
  if (!stub) return 2;
  grpc::ClientContext ctx;
  Authorize(ClientConnection(), &ctx);
  SetDeadline(&ctx, 300);
  v1::ExportDesignRequest req;
  req.set_id(r.job);
  req.set_iteration(r.iteration);
  req.set_min_feature_mm(r.min_feature_mm);
  req.set_seam_allowance_mm(r.seam_allowance_mm);
  req.set_sheet_width_mm(r.sheet_width_mm);
  req.set_no_mirror(r.no_mirror);
  v1::ExportDesignResponse resp;
  auto reader = stub->ExportDesign(&ctx, req);
  for (v1::ExportDesignEvent e; reader->Read(&e);) {
    if (e.has_files()) resp = std::move(*e.mutable_files());
    else if (e.has_progress() && !r.json) PrintExportProgress(e.progress().stage(), e.progress().fraction());
  }
  const grpc::Status st = reader->Finish();
  if (!st.ok()) return FailRpc("export", r.server, st);
  std::vector<std::pair<std::string, std::string>> files(resp.files().begin(), resp.files().end());
  std::sort(files.begin(), files.end());
  if (Status w = WriteExportFiles(r.out, files); !w.ok()) {
    std::fprintf(stderr, "kgd export: %s\n", w.message().c_str());
    return 2;
  }
  if (r.json) {
    for (const auto& [name, contents] : files)
      if (name == "report.json") std::printf("%s", contents.c_str());
  } else {
    for (const auto& [name, contents] : files) std::printf("wrote %s\n", (std::filesystem::path(r.out) / name).string().c_str());
    std::printf("(made by the server by geometry alone; `kgd export` on the job's design file also simulates the cleaned design)\n");
  }
  return 0;
}

}  // namespace kgd::cli
