// Leases and timeouts against time and the network, with real processes on loopback: a kgd-server whose
// wall clock jumps an hour forward and back mid-job (libfaketime, Debian's faketime package), and a
// kgd-worker whose connection to the server goes through a proxy in this test that stops forwarding for
// longer than the lease. Each job moves on at most once, never runs twice into its design file, and
// ends at the design `kgd design` computes locally, bit for bit.
#include <fcntl.h>
#include <grpcpp/grpcpp.h>
#include <gtest/gtest.h>
#include <netinet/in.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <functional>
#include <future>
#include <string>
#include <thread>
#include <vector>

#include "kgd/v1/kgd.grpc.pb.h"
#include "store/design_file.h"
#include "tests/child_process.h"
#include "tests/job_client.h"
#include "tests/kgd_cli.h"

namespace kgd {
namespace {
namespace fs = std::filesystem;
using cli_test::Kgd;
using test_support::FreePort;
using test_support::JobClient;
using test_support::Process;
using test_support::WaitFor;
using test_support::ReadText;

constexpr double kLeaseS = 3;
constexpr const char* kFakeTime = "/usr/lib/x86_64-linux-gnu/faketime/libfaketimeMT.so.1";

double WallNow() { return std::chrono::duration<double>(std::chrono::system_clock::now().time_since_epoch()).count(); }

size_t Count(const std::string& text, const std::string& what) {
  size_t n = 0;
  for (size_t at = text.find(what); at != std::string::npos; at = text.find(what, at + 1)) ++n;
  return n;
}

// The job both runs compute: sleeve_on_limb at a budget of 0.15.
v1::JobSpec Sleeve(int iterations) {
  v1::JobSpec spec;
  spec.set_builtin_scene("sleeve_on_limb");
  spec.mutable_optimizer()->set_max_iterations(iterations);
  spec.mutable_optimizer()->set_budget(0.15);
  return spec;
}

// `kgd design` of the same job, started at once beside the service (the file read when it is needed).
std::future<Result<DesignFile>> LocalRun(const std::string& dir, int iterations) {
  return std::async(std::launch::async, [dir, iterations]() -> Result<DesignFile> {
    const std::string path = dir + "/local.h5";
    const auto run = Kgd("design sleeve_on_limb --json --iterations " + std::to_string(iterations) + " --budget 0.15 --out " + path);
    if (run.exit_code != 0) return Status::Error("kgd design: exit " + std::to_string(run.exit_code) + ": " + run.output);
    return ReadDesignFile(path);
  });
}

// The job's design file equals the local run: one row per iteration, each bit for bit.
void ExpectSameAsLocal(const std::string& server_file, std::future<Result<DesignFile>>& local_run) {
  Result<DesignFile> local = local_run.get();
  ASSERT_TRUE(local.ok()) << local.message();
  Result<DesignFile> f = ReadDesignFile(server_file);
  ASSERT_TRUE(f.ok()) << f.message();
  ASSERT_EQ(f->iterations.size(), local->iterations.size()) << server_file;
  for (size_t k = 0; k < local->iterations.size(); ++k) {
    const BesoIteration &a = f->iterations[k], &b = local->iterations[k];
    ASSERT_EQ(a.iteration, static_cast<int>(k)) << "one row per iteration, in order";
    EXPECT_EQ(a.design, b.design) << "iteration " << k;
    EXPECT_EQ(a.energy_J, b.energy_J) << "iteration " << k;
    EXPECT_TRUE(a.positions == b.positions) << "iteration " << k;
    EXPECT_TRUE(a.sensitivity == b.sensitivity) << "iteration " << k;
  }
}

// A kgd-server and kgd-worker processes, each worker connecting to the given address; with `fake_time`
// all of them under libfaketime, their wall clock `offset_s` from the real one, changed at run time
// through a file (one machine's clock, stepped for every program on it).
class Service {
 public:
  Service(const std::string& name, bool fake_time, double offset_s = 0)
      : dir_((fs::temp_directory_path() / ("kgd_time_network_test_" + name + "_" + std::to_string(getpid()))).string()) {
    fs::remove_all(dir_);
    fs::create_directories(dir_);
    address_ = "127.0.0.1:" + std::to_string(FreePort());
    if (fake_time) {
      SetClockOffset(offset_s);
      // libfaketime reads the offset from the file at every clock call (FAKETIME_NO_CACHE). CLOCK_MONOTONIC
      // stays real (DONT_FAKE_MONOTONIC): stepping a machine's clock (settimeofday, an NTP step, an
      // administrator's `date -s`) moves CLOCK_REALTIME alone.
      clock_ = {"/usr/bin/env", std::string("LD_PRELOAD=") + kFakeTime, "FAKETIME_TIMESTAMP_FILE=" + dir_ + "/faketime",
                "FAKETIME_NO_CACHE=1", "DONT_FAKE_MONOTONIC=1"};
    }
    std::vector<std::string> args = clock_;
    for (const std::string& a : {std::string(KGD_SERVER_BINARY), std::string("--data"), dir_ + "/data", std::string("--listen"), address_,
                                 std::string("--lease-s"), std::to_string(kLeaseS)})
      args.push_back(a);
    server_ = Process::Spawn(args, dir_ + "/server.log");
    EXPECT_TRUE(WaitFor([&] { return Log().find("listening on") != std::string::npos; }, 30)) << Log();
    client_ = std::make_unique<JobClient>(address_);
  }
  ~Service() {
    workers_.clear();
    server_ = Process();
    if (!::testing::Test::HasFailure()) fs::remove_all(dir_);
  }

  // The server's wall clock from now on: the real one plus `offset_s`.
  void SetClockOffset(double offset_s) {
    std::ofstream(dir_ + "/faketime.tmp") << (offset_s >= 0 ? "+" : "") << static_cast<long long>(offset_s) << "\n";
    fs::rename(dir_ + "/faketime.tmp", dir_ + "/faketime");
  }

  // A kgd-worker with `env` (NAME=VALUE) added to its environment.
  int StartWorker(const std::string& server_address, const std::vector<std::string>& env = {}) {
    const int k = static_cast<int>(workers_.size());
    std::vector<std::string> args = clock_;
    if (!env.empty() && args.empty()) args.push_back("/usr/bin/env");
    args.insert(args.end(), env.begin(), env.end());
    for (const std::string& a : {std::string(KGD_WORKER_BINARY), std::string("--server"), server_address, std::string("--name"), "w" + std::to_string(k)})
      args.push_back(a);
    workers_.push_back(Process::Spawn(args, WorkerLogPath(k)));
    return k;
  }
  int StartWorker(const std::vector<std::string>& env = {}) { return StartWorker(address_, env); }
  void SignalWorker(int k, int sig) { workers_[k].Signal(sig); }
  std::string WorkerLogPath(int k) const { return dir_ + "/worker" + std::to_string(k) + ".log"; }

  std::string Log() const { return ReadText(dir_ + "/server.log"); }
  std::string Logs() const {
    std::string all = "server:\n" + Log();
    for (size_t k = 0; k < workers_.size(); ++k) all += "worker " + std::to_string(k) + ":\n" + ReadText(WorkerLogPath(k));
    return all;
  }
  const std::string& address() const { return address_; }
  const std::string& dir() const { return dir_; }
  std::string DataFile(int64_t id) const { return dir_ + "/data/jobs/job-" + std::to_string(id) + ".h5"; }

  grpc::Status Create(const v1::JobSpec& spec, v1::Job* job) { return client_->Create(spec, job); }
  v1::Job Get(int64_t id) { return client_->Get(id); }
  bool Finished(int64_t id) { return client_->Finished(id); }

 private:
  std::string dir_, address_;
  std::vector<std::string> clock_;  // the command line's start that runs a program under the test's clock
  Process server_;
  std::vector<Process> workers_;
  std::unique_ptr<JobClient> client_;
};

// A loopback TCP proxy to `target_port`: one thread polls the listening socket and every connection pair,
// each direction through a buffer of at most 64 KiB. Paused, it neither accepts, reads nor writes: the
// bytes wait in the kernel's socket buffers, as behind a cut cable, and flow again on Resume.
class LoopbackProxy {
 public:
  explicit LoopbackProxy(int target_port) : target_port_(target_port) {
    listener_ = socket(AF_INET, SOCK_STREAM, 0);
    const int one = 1;
    setsockopt(listener_, SOL_SOCKET, SO_REUSEADDR, &one, sizeof one);
    sockaddr_in a{};
    a.sin_family = AF_INET;
    a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    bind(listener_, reinterpret_cast<sockaddr*>(&a), sizeof a);
    listen(listener_, 16);
    socklen_t len = sizeof a;
    getsockname(listener_, reinterpret_cast<sockaddr*>(&a), &len);
    port_ = ntohs(a.sin_port);
    fcntl(listener_, F_SETFL, O_NONBLOCK);
    thread_ = std::thread([this] { Run(); });
  }
  ~LoopbackProxy() {
    stop_ = true;
    thread_.join();
    for (Pair& p : pairs_) close(p.a), close(p.b);
    close(listener_);
  }
  std::string address() const { return "127.0.0.1:" + std::to_string(port_); }
  void Pause() { forwarding_ = false; }
  void Resume() { forwarding_ = true; }

 private:
  struct Pair {
    int a, b;                  // the client's connection, the server's
    std::string to_b, to_a;    // bytes read, not yet written
  };
  static constexpr size_t kBuffer = 64 << 10;

  int Connect() const {
    const int s = socket(AF_INET, SOCK_STREAM, 0);
    sockaddr_in a{};
    a.sin_family = AF_INET;
    a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    a.sin_port = htons(static_cast<uint16_t>(target_port_));
    if (connect(s, reinterpret_cast<sockaddr*>(&a), sizeof a) != 0) {
      close(s);
      return -1;
    }
    fcntl(s, F_SETFL, O_NONBLOCK);
    return s;
  }

  // Moves bytes from `from` into `buf` (up to kBuffer) and from `buf` to `to`; false when a side closed.
  static bool Move(int from, int to, std::string* buf, short from_events, short to_events) {
    if ((from_events & (POLLIN | POLLHUP | POLLERR)) && buf->size() < kBuffer) {
      char chunk[16 << 10];
      const ssize_t n = read(from, chunk, std::min(sizeof chunk, kBuffer - buf->size()));
      if (n == 0 || (n < 0 && errno != EAGAIN && errno != EINTR)) return false;
      if (n > 0) buf->append(chunk, static_cast<size_t>(n));
    }
    if ((to_events & POLLOUT) && !buf->empty()) {
      const ssize_t n = write(to, buf->data(), buf->size());
      if (n < 0 && errno != EAGAIN && errno != EINTR) return false;
      if (n > 0) buf->erase(0, static_cast<size_t>(n));
    }
    return true;
  }

  void Run() {
    while (!stop_) {
      if (!forwarding_) {
        std::this_thread::sleep_for(std::chrono::milliseconds(20));
        continue;
      }
      std::vector<pollfd> fds = {{listener_, POLLIN, 0}};
      for (const Pair& p : pairs_) {
        fds.push_back({p.a, static_cast<short>((p.to_b.size() < kBuffer ? POLLIN : 0) | (p.to_a.empty() ? 0 : POLLOUT)), 0});
        fds.push_back({p.b, static_cast<short>((p.to_a.size() < kBuffer ? POLLIN : 0) | (p.to_b.empty() ? 0 : POLLOUT)), 0});
      }
      if (poll(fds.data(), fds.size(), 50) <= 0) continue;
      std::vector<Pair> kept;
      for (size_t i = 0; i < pairs_.size(); ++i) {
        Pair& p = pairs_[i];
        const short ea = fds[1 + 2 * i].revents, eb = fds[2 + 2 * i].revents;
        if (Move(p.a, p.b, &p.to_b, ea, eb) && Move(p.b, p.a, &p.to_a, eb, ea)) kept.push_back(std::move(p));
        else close(p.a), close(p.b);
      }
      if (fds[0].revents & POLLIN) {
        const int client = accept(listener_, nullptr, nullptr);
        if (client >= 0) {
          const int server = Connect();
          if (server < 0) close(client);
          else {
            fcntl(client, F_SETFL, O_NONBLOCK);
            kept.push_back({client, server, {}, {}});
          }
        }
      }
      pairs_ = std::move(kept);
    }
  }

  int target_port_, listener_ = -1, port_ = 0;
  std::atomic<bool> stop_{false}, forwarding_{true};
  std::vector<Pair> pairs_;
  std::thread thread_;
};

int PortOf(const std::string& address) { return std::atoi(address.substr(address.rfind(':') + 1).c_str()); }

bool HaveFakeTime() { return fs::exists(kFakeTime); }

// The wall clock of the server and its workers steps an hour forward mid-job, and later an hour back,
// while the job's worker is alive: no lease expires, the job is leased once and ends at the local run's
// design.
TEST(TimeAndNetwork, AServerClockSteppingAnHourForwardAndBackExpiresNoLiveLease) {
  if (!HaveFakeTime()) GTEST_SKIP() << kFakeTime << " is missing: scripts/setup.sh installs Debian's faketime";
  constexpr int kIterations = 60;
  constexpr double kDay = 86400;  // the server's clock a day ahead from the start: the job's times show it runs under libfaketime
  Service service("jump_forward_back", /*fake_time=*/true, kDay);
  auto local = LocalRun(service.dir(), kIterations);
  // Each iteration at least 0.4 s, on any machine: the job (>= 24 s) outlasts the two observations (12 s).
  const std::vector<std::string> slow = {"KGD_FAULT_POINT=worker.before_report@sleep=0.4"};
  service.StartWorker(slow);
  service.StartWorker(slow);
  v1::Job job;
  ASSERT_TRUE(service.Create(Sleeve(kIterations), &job).ok());
  EXPECT_NEAR(job.create_time_s(), WallNow() + kDay, 60) << "the server runs under libfaketime";
  ASSERT_TRUE(WaitFor([&] { return service.Get(job.id()).iterations() >= 3; }, 60)) << service.Logs();

  service.SetClockOffset(kDay + 3600);
  // Longer than a lease: the live worker's heartbeats keep it.
  EXPECT_FALSE(WaitFor([&] { return service.Log().find("lease expired") != std::string::npos; }, 2 * kLeaseS))
      << "an hour forward expired a live worker's lease\n" << service.Logs();
  v1::Job mid = service.Get(job.id());
  EXPECT_EQ(mid.state(), v1::RUNNING) << "the job outlasts the observation";
  EXPECT_EQ(mid.attempts(), 1);

  service.SetClockOffset(kDay);
  EXPECT_FALSE(WaitFor([&] { return service.Log().find("lease expired") != std::string::npos; }, 2 * kLeaseS)) << service.Logs();
  EXPECT_EQ(service.Get(job.id()).state(), v1::RUNNING) << "the job outlasts the observation";

  ASSERT_TRUE(WaitFor([&] { return service.Finished(job.id()); }, 120)) << service.Logs();
  const v1::Job after = service.Get(job.id());
  EXPECT_EQ(after.state(), v1::SUCCEEDED) << after.failure();
  EXPECT_EQ(after.attempts(), 1) << service.Logs();
  EXPECT_EQ(Count(service.Log(), "job " + std::to_string(job.id()) + " leased to"), 1u) << service.Logs();
  EXPECT_NEAR(after.update_time_s(), WallNow() + kDay, 60) << "the job's times are the server's wall clock";
  EXPECT_NEAR(after.last().report_time_s(), WallNow() + kDay, 60) << "the workers run under libfaketime";
  ExpectSameAsLocal(service.DataFile(job.id()), local);
}

// A worker frozen (SIGSTOP) just before the machine's clock steps an hour back: its lease still expires
// a lease duration after its last heartbeat (not an hour later), and the job moves on once, to the other
// worker, ending at the local run's design.
TEST(TimeAndNetwork, ALostWorkersLeaseExpiresOnTimeAfterTheServerClockStepsBack) {
  if (!HaveFakeTime()) GTEST_SKIP() << kFakeTime << " is missing: scripts/setup.sh installs Debian's faketime";
  constexpr int kIterations = 40;
  constexpr double kDay = 86400;
  Service service("jump_back_lost", /*fake_time=*/true, kDay);
  auto local = LocalRun(service.dir(), kIterations);
  service.StartWorker();
  service.StartWorker();
  v1::Job job;
  ASSERT_TRUE(service.Create(Sleeve(kIterations), &job).ok());
  EXPECT_NEAR(job.create_time_s(), WallNow() + kDay, 60) << "the server runs under libfaketime";
  ASSERT_TRUE(WaitFor([&] { return service.Get(job.id()).iterations() >= 3; }, 60)) << service.Logs();
  const v1::Job before = service.Get(job.id());
  const int frozen = before.worker() == "w0" ? 0 : 1;
  service.SignalWorker(frozen, SIGSTOP);
  service.SetClockOffset(kDay - 3600);
  const auto t0 = std::chrono::steady_clock::now();
  const bool expired = WaitFor([&] { return service.Log().find("lease expired") != std::string::npos; }, 4 * kLeaseS);
  const double waited = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  service.SignalWorker(frozen, SIGCONT);
  ASSERT_TRUE(expired) << "an hour back kept a lost worker's lease past " << 4 * kLeaseS << " s\n" << service.Logs();
  EXPECT_LE(waited, kLeaseS + 2) << "the lease expires a lease duration after the last heartbeat";

  ASSERT_TRUE(WaitFor([&] { return service.Finished(job.id()); }, 120)) << service.Logs();
  const v1::Job after = service.Get(job.id());
  EXPECT_EQ(after.state(), v1::SUCCEEDED) << after.failure();
  EXPECT_EQ(after.attempts(), 2) << service.Logs();
  EXPECT_EQ(Count(service.Log(), "lease expired"), 1u) << service.Logs();
  ExpectSameAsLocal(service.DataFile(job.id()), local);
}

// A worker cut off from the server (its connection through a proxy that stops forwarding) for longer
// than its lease: the server expires the lease and the job resumes on the second worker; when the
// connection comes back the first worker is told its lease is gone and stores nothing more. The design
// file has one row per iteration, equal to the local run's.
TEST(TimeAndNetwork, AWorkerCutOffLongerThanItsLeaseLosesTheJobOnceAndStoresNothingMore) {
  constexpr int kIterations = 40;
  Service service("cut_off", /*fake_time=*/false);
  auto local = LocalRun(service.dir(), kIterations);
  LoopbackProxy proxy(PortOf(service.address()));
  const int cut = service.StartWorker(proxy.address());
  v1::Job job;
  ASSERT_TRUE(service.Create(Sleeve(kIterations), &job).ok());
  ASSERT_TRUE(WaitFor([&] { return service.Get(job.id()).iterations() >= 3; }, 60)) << service.Logs();
  ASSERT_EQ(service.Get(job.id()).worker(), "w0");
  const int other = service.StartWorker();

  proxy.Pause();
  const auto t0 = std::chrono::steady_clock::now();
  ASSERT_TRUE(WaitFor([&] { return service.Log().find("lease expired") != std::string::npos; }, 4 * kLeaseS)) << service.Logs();
  EXPECT_GE(std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count(), kLeaseS - 1)
      << "the lease lasts its duration after the last heartbeat";
  ASSERT_TRUE(WaitFor([&] { return service.Get(job.id()).worker() == "w" + std::to_string(other); }, 30)) << service.Logs();
  proxy.Resume();

  // The cut-off worker's late heartbeat or report is refused: it gives the job up.
  const std::string lost = "job " + std::to_string(job.id()) + ": lost the server (";
  ASSERT_TRUE(WaitFor([&] { return ReadText(service.WorkerLogPath(cut)).find(lost) != std::string::npos; }, 30)) << service.Logs();
  EXPECT_NE(ReadText(service.WorkerLogPath(cut)).find("no longer held"), std::string::npos) << service.Logs();

  ASSERT_TRUE(WaitFor([&] { return service.Finished(job.id()); }, 120)) << service.Logs();
  const v1::Job after = service.Get(job.id());
  EXPECT_EQ(after.state(), v1::SUCCEEDED) << after.failure();
  EXPECT_EQ(after.attempts(), 2) << service.Logs();
  EXPECT_EQ(Count(service.Log(), "lease expired"), 1u) << service.Logs();
  EXPECT_EQ(Count(service.Log(), "job " + std::to_string(job.id()) + " leased to"), 2u) << service.Logs();
  EXPECT_NE(service.Log().find("job " + std::to_string(job.id()) + " leased to w" + std::to_string(other) + " (attempt 2, from iteration "),
            std::string::npos)
      << service.Logs();
  ExpectSameAsLocal(service.DataFile(job.id()), local);
}

}  // namespace
}  // namespace kgd
