// The design service's costs, measured with real processes on loopback (a kgd-server, one kgd-worker):
//   latency   worker finishes an iteration -> a watcher receives it (p50, p99), with 1 and with 100
//             watchers of the job, and what 100 watchers cost the worker (mean seconds per iteration).
//             --pin: the worker on CPU 1 with one thread, the server and the watchers on CPU 0, so that
//             the worker's time shows what the server's work for watchers costs it, apart from the
//             watchers' own decoding (on a 2-core machine they otherwise share the worker's cores)
//   overhead  arm flexion (N iterations) through server + worker vs `kgd design` locally, wall time
//             to the last iteration's record
// Usage: service_benchmark [latency|overhead|all] [--scene S --iterations N --watchers W --pin (latency; sleeve_on_limb, 150, 100)]
//                          [--arm-iterations N (overhead)] [--repeat R (both; 3; `all` runs latency once)]
//                          [--json FILE: the figures as one JSON object, "kind": "service"]
// `make bench` (bench/run.sh) writes them into docs/PERFORMANCE.md, "Design service" (bench/tables.py).
#include <arpa/inet.h>
#include <grpcpp/grpcpp.h>
#include <netinet/in.h>
#include <sched.h>
#include <signal.h>
#include <sys/socket.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <mutex>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include "kgd/v1/kgd.grpc.pb.h"
#include "tests/child_process.h"

namespace {
namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

double UnixNow() { return std::chrono::duration<double>(std::chrono::system_clock::now().time_since_epoch()).count(); }

pid_t Spawn(const std::vector<std::string>& args, const std::string& log) {
  kgd::test_support::Process p = kgd::test_support::Process::Spawn(args, log);
  return std::exchange(p.pid, -1);  // this benchmark stops its processes itself
}

using kgd::test_support::FreePort;

// One latency run's figures (one line of output, one object of --json's "latency").
struct Latency {
  std::string scene;
  bool pinned = false;
  int watchers = 0;
  size_t iterations = 0, deliveries = 0;
  double p50_ms = 0, p99_ms = 0, max_ms = 0, worker_s_per_iteration = 0, server_cpu_ms_per_iteration = 0;
};

struct Overhead {
  int iterations = 0, repeat = 0;
  double local_s = 0, service_s = 0;
};

struct Service {
  std::string dir, address;
  pid_t server = -1, worker = -1;
  std::unique_ptr<kgd::v1::DesignService::Stub> stub;
  explicit Service(const std::string& name, bool pin = false) {
    dir = (fs::temp_directory_path() / ("kgd_service_benchmark_" + name)).string();
    fs::remove_all(dir);
    fs::create_directories(dir);
    address = "127.0.0.1:" + std::to_string(FreePort());
    // No cap on one job's watchers (the service's default is 64): the benchmark watches with 100.
    std::vector<std::string> server_cmd{KGD_SERVER_BINARY, "--data", dir + "/data", "--listen", address, "--max-watchers-per-job", "0", "--quiet"};
    std::vector<std::string> worker_cmd{KGD_WORKER_BINARY, "--server", address, "--quiet"};
    if (pin) {
      server_cmd.insert(server_cmd.begin(), {"/usr/bin/taskset", "-c", "0"});
      worker_cmd.insert(worker_cmd.begin(), {"/usr/bin/env", "OMP_NUM_THREADS=1", "/usr/bin/taskset", "-c", "1"});
    }
    server = Spawn(server_cmd, dir + "/server.log");
    worker = Spawn(worker_cmd, dir + "/worker.log");
    stub = kgd::v1::DesignService::NewStub(grpc::CreateChannel(address, grpc::InsecureChannelCredentials()));
  }
  ~Service() {
    for (pid_t p : {worker, server}) {
      kill(p, SIGTERM);
      waitpid(p, nullptr, 0);
    }
  }
  int64_t Submit(const std::string& scene, int iterations) {
    kgd::v1::CreateJobRequest req;
    req.mutable_spec()->set_builtin_scene(scene);
    req.mutable_spec()->mutable_optimizer()->set_max_iterations(iterations);
    for (int attempt = 0; attempt < 100; ++attempt) {
      grpc::ClientContext ctx;
      ctx.set_wait_for_ready(true);
      ctx.set_deadline(std::chrono::system_clock::now() + std::chrono::seconds(10));
      kgd::v1::Job job;
      if (stub->CreateJob(&ctx, req, &job).ok()) return job.id();
      std::this_thread::sleep_for(std::chrono::milliseconds(100));
    }
    std::fprintf(stderr, "service_benchmark: cannot submit to %s\n", address.c_str());
    std::exit(1);
  }
  kgd::v1::Job Get(int64_t id) {
    grpc::ClientContext ctx;
    kgd::v1::GetJobRequest req;
    req.set_id(id);
    kgd::v1::Job job;
    stub->GetJob(&ctx, req, &job);
    return job;
  }
  void WaitDone(int64_t id) {
    for (;;) {
      const kgd::v1::JobState s = Get(id).state();
      if (s == kgd::v1::SUCCEEDED || s == kgd::v1::FAILED || s == kgd::v1::CANCELLED) return;
      std::this_thread::sleep_for(std::chrono::milliseconds(100));
    }
  }
};

// CPU seconds (user + system) a process has used so far, from /proc.
double CpuSeconds(pid_t pid) {
  FILE* f = std::fopen(("/proc/" + std::to_string(pid) + "/stat").c_str(), "r");
  if (!f) return 0;
  char buf[4096] = {};
  const size_t n = std::fread(buf, 1, sizeof buf - 1, f);
  std::fclose(f);
  buf[n] = 0;
  const char* p = std::strrchr(buf, ')');  // fields 14 and 15 (utime, stime) after the command name
  unsigned long long utime = 0, stime = 0;
  if (p) std::sscanf(p + 2, "%*c %*d %*d %*d %*d %*d %*u %*u %*u %*u %*u %llu %llu", &utime, &stime);
  return static_cast<double>(utime + stime) / sysconf(_SC_CLK_TCK);
}

double Percentile(std::vector<double> v, double p) {
  if (v.empty()) return 0;
  std::sort(v.begin(), v.end());
  return v[std::min(v.size() - 1, static_cast<size_t>(p * (v.size() - 1) + 0.5))];
}

// One job of `iterations` sleeve iterations watched by `watchers` clients (spread over 10 connections).
// Returns the worker's seconds per iteration (all but the first, cold, iteration); its figures go to `out`.
std::vector<double> LatencyRun(const std::string& scene, int watchers, int iterations, bool pin, std::vector<Latency>* out) {
  if (pin) {  // this process (the watchers) beside the server on CPU 0
    cpu_set_t cpus;
    CPU_ZERO(&cpus);
    CPU_SET(0, &cpus);
    sched_setaffinity(0, sizeof cpus, &cpus);
  }
  Service service("latency_" + std::to_string(watchers), pin);
  std::vector<std::shared_ptr<grpc::Channel>> channels;
  for (int c = 0; c < std::min(watchers, 10); ++c) {
    grpc::ChannelArguments args;
    args.SetInt("kgd.benchmark.connection", c);  // distinct arguments: distinct connections
    channels.push_back(grpc::CreateCustomChannel(service.address, grpc::InsecureChannelCredentials(), args));
  }
  const double server_cpu0 = CpuSeconds(service.server);
  const int64_t id = service.Submit(scene, iterations);
  std::mutex mu;
  std::vector<double> latency_ms;
  std::vector<double> iteration_s;
  std::vector<std::thread> threads;
  std::atomic<int> received{0};
  int refused = 0;
  for (int w = 0; w < watchers; ++w) {
    threads.emplace_back([&, w] {
      auto stub = kgd::v1::DesignService::NewStub(channels[w % channels.size()]);
      grpc::ClientContext ctx;
      kgd::v1::WatchJobRequest req;
      req.set_id(id);
      auto reader = stub->WatchJob(&ctx, req);
      kgd::v1::WatchJobEvent ev;
      std::vector<double> mine, seconds;
      while (reader->Read(&ev)) {
        if (!ev.has_iteration()) continue;
        const double now = UnixNow();
        const auto& m = ev.iteration().metrics();
        // Live iterations only (replayed ones were reported before this watcher connected).
        if (m.iteration() > 1) mine.push_back(1e3 * (now - m.report_time_s()));
        if (w == 0 && m.iteration() > 0) seconds.push_back(m.total_s());
        ++received;
      }
      const grpc::Status status = reader->Finish();
      std::lock_guard lock(mu);
      if (!status.ok()) {
        ++refused;
        std::fprintf(stderr, "service_benchmark: watcher %d: %s\n", w, status.error_message().c_str());
      }
      latency_ms.insert(latency_ms.end(), mine.begin(), mine.end());
      iteration_s.insert(iteration_s.end(), seconds.begin(), seconds.end());
    });
  }
  for (std::thread& t : threads) t.join();
  if (refused > 0) {
    std::fprintf(stderr, "service_benchmark: %d of %d watchers failed: no figures\n", refused, watchers);
    std::exit(1);
  }
  service.WaitDone(id);
  const double server_cpu = CpuSeconds(service.server) - server_cpu0;
  double mean = 0;
  for (double s : iteration_s) mean += s;
  mean /= std::max<size_t>(1, iteration_s.size());
  const Latency l{scene, pin, watchers, iteration_s.size() + 1, latency_ms.size(), Percentile(latency_ms, 0.5), Percentile(latency_ms, 0.99),
                  Percentile(latency_ms, 1.0), mean, 1e3 * server_cpu / (iteration_s.size() + 1)};
  std::printf("latency  %s%s  watchers %3d  iterations %4zu  deliveries %6zu  p50 %7.2f ms  p99 %7.2f ms  max %7.2f ms  worker %.4f s/iteration  server CPU %.1f ms/iteration\n",
              scene.c_str(), pin ? " (pinned)" : "", watchers, l.iterations, l.deliveries, l.p50_ms, l.p99_ms, l.max_ms, l.worker_s_per_iteration,
              l.server_cpu_ms_per_iteration);
  std::fflush(stdout);
  out->push_back(l);
  return iteration_s;
}

// Local and service runs alternate `repeat` times; the fastest of each counts (this machine's timings
// vary by 20 % from run to run).
Overhead OverheadRun(int iterations, int repeat) {
  const std::string dir = (fs::temp_directory_path() / "kgd_service_benchmark_local").string();
  fs::create_directories(dir);
  const std::string cmd = std::string(KGD_BINARY) + " design arm_flexion --json --iterations " + std::to_string(iterations) + " --out " + dir +
                          "/arm.h5 > " + dir + "/local.log 2>&1";
  Service service("overhead");
  service.WaitDone(service.Submit("sleeve_on_limb", 1));  // the worker is connected and warm
  double local = 1e30, remote = 1e30;
  for (int r = 0; r < repeat; ++r) {
    auto t0 = Clock::now();
    if (std::system(cmd.c_str()) != 0) std::fprintf(stderr, "service_benchmark: local run failed (%s/local.log)\n", dir.c_str());
    local = std::min(local, std::chrono::duration<double>(Clock::now() - t0).count());
    // To the last iteration's record, as `kgd design` ends there (the service's job then evaluates the
    // final design over the motion and beside the baselines, which `kgd design` does not).
    t0 = Clock::now();
    const int64_t id = service.Submit("arm_flexion", iterations);
    grpc::ClientContext ctx;
    kgd::v1::WatchJobRequest req;
    req.set_id(id);
    auto reader = service.stub->WatchJob(&ctx, req);
    kgd::v1::WatchJobEvent ev;
    double last = -1;
    while (last < 0 && reader->Read(&ev))
      if (ev.has_iteration() && ev.iteration().metrics().iteration() >= iterations)
        last = std::chrono::duration<double>(Clock::now() - t0).count();
    ctx.TryCancel();
    reader->Finish();
    service.WaitDone(id);
    if (last < 0) {
      std::fprintf(stderr, "service_benchmark: the overhead job ended without its iteration %d\n", iterations);
      std::exit(1);
    }
    remote = std::min(remote, last);
  }
  std::printf("overhead arm_flexion %d iterations, best of %d: kgd design %.2f s, server + worker %.2f s (%+.1f %%)\n", iterations + 1, repeat,
              local, remote, 100 * (remote / local - 1));
  return {iterations + 1, repeat, local, remote};
}

// The figures as one JSON object for bench/tables.py; false when FILE cannot be written.
bool WriteJson(const std::string& path, const std::vector<Latency>& latency, const Overhead* overhead) {
  FILE* f = std::fopen(path.c_str(), "w");
  if (!f) return false;
  std::fprintf(f, "{\"kind\": \"service\", \"latency\": [");
  for (size_t i = 0; i < latency.size(); ++i) {
    const Latency& l = latency[i];
    std::fprintf(f,
                 "%s\n  {\"scene\": \"%s\", \"pinned\": %s, \"watchers\": %d, \"iterations\": %zu, \"deliveries\": %zu, \"p50_ms\": %.4f, "
                 "\"p99_ms\": %.4f, \"max_ms\": %.4f, \"worker_s_per_iteration\": %.6f, \"server_cpu_ms_per_iteration\": %.4f}",
                 i ? "," : "", l.scene.c_str(), l.pinned ? "true" : "false", l.watchers, l.iterations, l.deliveries, l.p50_ms, l.p99_ms, l.max_ms,
                 l.worker_s_per_iteration, l.server_cpu_ms_per_iteration);
  }
  std::fprintf(f, "]");
  if (overhead)
    std::fprintf(f, ",\n \"overhead\": {\"scene\": \"arm_flexion\", \"iterations\": %d, \"repeat\": %d, \"local_s\": %.4f, \"service_s\": %.4f}",
                 overhead->iterations, overhead->repeat, overhead->local_s, overhead->service_s);
  std::fprintf(f, "}\n");
  return std::fclose(f) == 0;
}

}  // namespace

int main(int argc, char** argv) {
  std::string what = "all", scene = "sleeve_on_limb", json;
  int iterations = 150, arm_iterations = 20, watchers = 100, repeat = 3;
  bool pin = false;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--iterations" && i + 1 < argc) iterations = std::atoi(argv[++i]);
    else if (a == "--arm-iterations" && i + 1 < argc) arm_iterations = std::atoi(argv[++i]);
    else if (a == "--watchers" && i + 1 < argc) watchers = std::atoi(argv[++i]);
    else if (a == "--repeat" && i + 1 < argc) repeat = std::atoi(argv[++i]);
    else if (a == "--scene" && i + 1 < argc) scene = argv[++i];
    else if (a == "--json" && i + 1 < argc) json = argv[++i];
    else if (a == "--pin") pin = true;
    else if (a == "latency" || a == "overhead" || a == "all") what = a;
    else {
      std::fprintf(stderr, "usage: service_benchmark [latency|overhead|all] [--iterations N] [--watchers W] [--scene S] [--pin] [--arm-iterations N] [--repeat R] [--json FILE]\n");
      return 2;
    }
  }
  std::vector<Latency> latency;
  std::optional<Overhead> overhead;
  if (what != "overhead") {
    // Runs alternate (this machine's timings drift); the worker's median over all of them compares.
    std::vector<double> one, many;
    for (int r = 0; r < (what == "latency" ? repeat : 1); ++r) {
      for (double s : LatencyRun(scene, 1, iterations, pin, &latency)) one.push_back(s);
      for (double s : LatencyRun(scene, watchers, iterations, pin, &latency)) many.push_back(s);
    }
    const double a = Percentile(one, 0.5), b = Percentile(many, 0.5);
    std::printf("worker   %s  median s/iteration over %zu and %zu iterations: 1 watcher %.4f, %d watchers %.4f (%+.1f %%)\n",
                scene.c_str(), one.size(), many.size(), a, watchers, b, 100 * (b / a - 1));
  }
  if (what != "latency") overhead = OverheadRun(arm_iterations, repeat);
  if (!json.empty() && !WriteJson(json, latency, overhead ? &*overhead : nullptr)) {
    std::fprintf(stderr, "service_benchmark: cannot write %s\n", json.c_str());
    return 1;
  }
  return 0;
}
