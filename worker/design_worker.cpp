#include "worker/design_worker.h"

#include <grpcpp/grpcpp.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstdio>
#include <mutex>
#include <optional>
#include <thread>
#include <vector>

#include "core/util/fault_point.h"
#include "core/util/pinned_kernels.h"
#include "job/design_job.h"
#include "job/fabrication_export.h"
#include "kgd/v1/kgd.grpc.pb.h"
#include "proto/job_spec.h"
#include "proto/records.h"
#include "store/design_file.h"
#include "worker/machine_speed.h"

namespace kgd::worker {
namespace {

std::string DefaultName() {
  char host[256] = {};
  gethostname(host, sizeof host - 1);
  return std::string(host) + ":" + std::to_string(getpid());
}

std::string Percent(double fraction) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.1f %%", 100 * fraction);
  return buf;
}

// How a design loop that ran `history` ended, for people (kgd.v1.Job.ended): DescribeBesoEnd's reason
// with where the last design stands against the budget.
std::string EndSentence(const DesignJob& job, const std::vector<BesoIteration>& history) {
  const BesoSettings& s = job.settings();
  const BesoEnd end = BesoEndOf(history, s, job.header.rest_area_m2.sum());
  const std::string why = DescribeBesoEnd(end, history, s);
  if (end == BesoEnd::kRunning || end == BesoEnd::kNothingToResist) return why;
  const BesoIteration& last = history.back();
  char budget[32];
  std::snprintf(budget, sizeof budget, "%g %%", 100 * s.budget);
  // DescribeBesoEnd's note on a pressure limit says where the design stands itself.
  const bool noted = why.find(':') != std::string::npos || why.find(" at ") != std::string::npos;
  if (end == BesoEnd::kConverged)
    return noted ? why : "converged at the budget: " + Percent(last.area_fraction) + " of the garment reinforced (budget " + budget + ")";
  const std::string stopped = "stopped at the iteration limit (" + std::to_string(s.max_iterations) + ")";
  if (noted) return "stopped at the " + why;
  return stopped + " at " + Percent(last.area_fraction) + " of the garment, " +
         (last.area_fraction > s.budget * (1 + 1e-9) ? "above the budget of " : "within the budget of ") + budget;
}

}  // namespace

struct DesignWorker::Impl {
  WorkerOptions options;
  std::shared_ptr<grpc::Channel> channel;
  std::unique_ptr<v1::WorkerService::Stub> stub;
  std::atomic<bool> stop{false};
  std::vector<std::thread> slots;
  // This machine's speed, known before the first lease (worker/machine_speed.h); none when it failed.
  std::once_flag speed_once;
  std::optional<v1::MachineSpeed> speed;

  void Log(const std::string& line) {
    if (!options.quiet) std::fprintf(stderr, "kgd-worker %s: %s\n", options.name.c_str(), line.c_str());
  }

  void Slot(int index) {
    const std::string name = options.jobs > 1 ? options.name + "/" + std::to_string(index) : options.name;
    // Before the first job: every slot waits for the one measurement.
    if (options.measure_speed)
      std::call_once(speed_once, [&] {
        Result<v1::MachineSpeed> s = MachineSpeedOfThisMachine();
        if (s.ok()) {
          speed = *s;
          char factor[32];
          std::snprintf(factor, sizeof factor, "%.3g", s->measured_s() / s->predicted_s());
          Log(std::string("speed: ") + factor + " x the cost model's reference machine (" + s->what() + ")");
        } else {
          Log("speed not measured: " + s.message());
        }
      });
    bool speed_sent = false;
    double backoff = 0.1;
    while (!stop) {
      v1::LeaseJobRequest req;
      req.set_worker(name);
      req.set_wait_s(2);
      req.set_kernels(RunningKernels());  // jobs whose iterations ran at another level are not ours to resume
      if (speed && !speed_sent) *req.mutable_speed() = *speed;
      v1::LeaseJobResponse lease;
      grpc::ClientContext ctx;
      Authorize(options.connection, &ctx);
      ctx.set_deadline(std::chrono::system_clock::now() + std::chrono::seconds(10));
      const grpc::Status st = stub->LeaseJob(&ctx, req, &lease);
      if (!st.ok()) {
        // The server is away (restarting, draining): try again, a little later each time.
        std::this_thread::sleep_for(std::chrono::duration<double>(backoff));
        backoff = std::min(2 * backoff, 1.0);
        continue;
      }
      backoff = 0.1;
      speed_sent = true;
      if (lease.leased()) RunLeasedJob(lease);
    }
  }

  void RunLeasedJob(const v1::LeaseJobResponse& lease) {
    Log("job " + std::to_string(lease.job_id()) + ": attempt " + std::to_string(lease.attempt()) +
        (lease.history_size() ? ", resuming after iteration " + std::to_string(lease.history_size() - 1) : ""));
    grpc::ClientContext ctx;
    Authorize(options.connection, &ctx);
    std::unique_ptr<grpc::ClientReaderWriter<v1::WorkerMessage, v1::ServerMessage>> stream = stub->RunJob(&ctx);
    std::mutex write_mu;
    auto send = [&](v1::WorkerMessage msg) {
      msg.set_lease_id(lease.lease_id());
      std::lock_guard lock(write_mu);
      return stream->Write(msg);
    };
    // The stream, its reader and the heartbeats run from the start: building a large scene may take
    // longer than the lease.
    std::atomic<bool> cancel{false}, drain{false}, lost{false}, done{false};
    std::atomic<int> acknowledged{0};  // iterations the server has stored, from its latest reply
    std::string server_error;
    {
      v1::WorkerMessage hello;
      hello.set_heartbeat(true);
      if (!send(hello)) lost = true;
    }
    std::thread reader([&] {
      v1::ServerMessage reply;
      while (stream->Read(&reply)) {
        if (!reply.error().empty()) {
          server_error = reply.error();
          lost = true;
        }
        if (reply.cancel()) cancel = true;
        if (reply.drain()) drain = true;
        acknowledged = std::max(acknowledged.load(), reply.acknowledged_iterations());
      }
      lost = true;
    });
    std::thread heartbeat([&] {
      const auto period = std::chrono::duration<double>(std::max(0.05, lease.lease_duration_s() / 4));
      auto next = std::chrono::steady_clock::now() + period;
      while (!done) {
        std::this_thread::sleep_for(std::chrono::milliseconds(20));
        if (std::chrono::steady_clock::now() < next) continue;
        next += period;
        v1::WorkerMessage m;
        m.set_heartbeat(true);
        if (!send(m)) lost = true;
      }
    });

    // What the job comes to: run.ok() with the flags, or a failure reason.
    std::string failure;
    Result<std::vector<BesoIteration>> run = Status::Error("not run");
    Result<DesignJob> job = Status::Error("");
    SolverSettings scene_solver;  // the scene's own, before the job's overrides: what `kgd export` simulates with
    {
      Result<SceneSpec> scene = SceneOfJob(lease.spec());
      if (!scene.ok()) failure = scene.message();
      else {
        scene_solver = scene->solver;
        const std::vector<std::string> body(lease.spec().body().begin(), lease.spec().body().end());
        job = NewDesignJob(std::move(scene).value(), lease.spec().optimizer(), JobSceneName(lease.spec()), JoinWords(body));
        if (!job.ok()) failure = job.message();
      }
    }
    if (failure.empty() && lease.history_size() > 0) {
      for (const v1::IterationMetrics& m : lease.history()) job->history.push_back(MetricsFromProto(m));
      Result<BesoIteration> last = RecordFromProto(lease.last(), static_cast<int>(job->header.garment.faces.rows()),
                                                   static_cast<int>(job->header.garment.vertices.rows()));
      if (!last.ok()) failure = "checkpoint: " + last.message();
      else if (last->iteration != job->history.back().iteration) failure = "checkpoint: the last record is not the last iteration";
      else job->history.back() = std::move(last).value();
    }
    if (failure.empty()) {
      v1::WorkerMessage start;
      *start.mutable_start()->mutable_garment() = GarmentToProto(job->header);
      start.mutable_start()->set_scene(job->header.scene);
      start.mutable_start()->set_body(job->header.body);
      start.mutable_start()->set_settings_json(BesoSettingsToJson(job->settings()));
      start.mutable_start()->set_kernels(RunningKernels());
      start.mutable_start()->set_grad_tol(job->header.grad_tol);
      start.mutable_start()->set_max_newton_iterations(job->header.max_newton_iterations);
      if (!send(start)) lost = true;
      auto keep_going = [&] { return !(cancel || drain || lost || stop); };
      // Iteration 0 and the last, for the evaluation after the loop (a resumed job's come from its history).
      std::optional<BesoIteration> first, last;
      if (!job->history.empty()) first = job->history.front(), last = job->history.back();
      auto on_iteration = [&](const BesoIteration& it) {
        if (it.iteration == 0) first = it;
        last = it;
        v1::WorkerMessage m;
        *m.mutable_iteration() = RecordToProto(it);
        m.mutable_iteration()->mutable_metrics()->set_report_time_s(
            std::chrono::duration<double>(std::chrono::system_clock::now().time_since_epoch()).count());
        FaultPoint("worker.before_report", it.iteration);
        if (!send(m)) lost = true;
        FaultPoint("worker.after_report", it.iteration);
        // At most one report ahead of the server's replies: cancel and drain arrive on them, and a worker
        // whose iterations outrun the server's commits would otherwise run on for several iterations
        // after a cancel. Normally the reply to the previous report is long in.
        while (acknowledged < it.iteration && keep_going()) std::this_thread::sleep_for(std::chrono::milliseconds(1));
        FaultPoint("worker.after_acknowledged", it.iteration);
        return keep_going();
      };
      if (keep_going()) {
        run = RunDesignJob(*job, on_iteration);
        if (!run.ok()) failure = run.message();
      }
      // How the design loop ended, said before the evaluation starts (the job's phase turns to EVALUATING).
      if (failure.empty() && keep_going() && last) {
        std::vector<BesoIteration> history;
        for (const BesoIteration& it : job->history) history.push_back(MetricsOnly(it));
        for (const BesoIteration& it : *run) history.push_back(MetricsOnly(it));
        if (!history.empty() && BesoFinished(history, job->settings(), job->header.rest_area_m2.sum())) {
          v1::WorkerMessage m;
          m.set_ended(EndSentence(*job, history));
          if (!send(m)) lost = true;
        }
      }
      // The last design cleaned for manufacture and simulated again, as `kgd export` does: the service's
      // cut files of it report its figures. An extra, as the evaluation below.
      if (failure.empty() && keep_going() && first && last) {
        SceneSpec scene = job->scene;
        scene.solver = scene_solver;
        scene.design = last->design;
        StartFromStoredEquilibrium(&scene, last->positions);
        const CleaningOptions cleaning;
        Result<CleanedSimulation> cleaned = SimulateCleanedDesign(scene, first->reinforced_density_J_per_m2, cleaning);
        if (cleaned.ok()) {
          v1::WorkerMessage m;
          v1::CleanedDesign* c = m.mutable_cleaned();
          c->set_iteration(last->iteration);
          c->set_min_feature_m(cleaning.min_feature_m);
          c->set_design(std::string(cleaned->cleaned.design.begin(), cleaned->cleaned.design.end()));
          c->set_area_fraction(cleaned->area_fraction);
          c->set_density_ratio(cleaned->density_ratio);
          c->set_solve_status(cleaned->solve_status);
          if (!send(m)) lost = true;
        } else {
          Log("job " + std::to_string(lease.job_id()) + ": the cleaned design not simulated: " + cleaned.message());
        }
      }
      // The finished design over the motion and beside the baselines: a failure here is reported in the
      // log and costs the job nothing (the evaluation is an extra, the design is done).
      if (failure.empty() && keep_going() && first && last) {
        Result<DesignEvaluation> evaluation = EvaluateDesign(*job, *first, *last);
        if (evaluation.ok()) {
          v1::WorkerMessage m;
          *m.mutable_evaluation() = EvaluationToProto(*evaluation);
          if (!send(m)) lost = true;
        } else {
          Log("job " + std::to_string(lease.job_id()) + ": no evaluation: " + evaluation.message());
        }
      }
    }
    done = true;
    heartbeat.join();
    v1::WorkerMessage end;
    std::string outcome;
    if (lost) {
      outcome = "lost the server";
    } else if (!failure.empty()) {
      end.set_fail(failure);
      outcome = "failed: " + failure;
    } else if (cancel || drain || stop) {
      end.set_release(true);
      outcome = cancel ? "cancelled" : "released";
    } else {
      end.set_complete(true);
      outcome = "complete";
    }
    if (!lost) send(end);
    {
      std::lock_guard lock(write_mu);
      stream->WritesDone();
    }
    reader.join();  // after this, server_error is the reader's no more
    stream->Finish();
    if (!server_error.empty()) outcome += " (" + server_error + ")";
    Log("job " + std::to_string(lease.job_id()) + ": " + outcome);
  }
};

Result<std::unique_ptr<DesignWorker>> DesignWorker::Start(const WorkerOptions& options) {
  if (options.jobs < 1) return Status::Error("--jobs " + std::to_string(options.jobs) + ": must be at least 1");
  auto w = std::unique_ptr<DesignWorker>(new DesignWorker);
  w->impl_ = std::make_unique<Impl>();
  Impl& m = *w->impl_;
  m.options = options;
  if (m.options.name.empty()) m.options.name = DefaultName();
  grpc::ChannelArguments args;
  args.SetMaxReceiveMessageSize(256 << 20);
  args.SetMaxSendMessageSize(256 << 20);
  // Reconnect quickly after a server restart (the default backoff grows to two minutes).
  args.SetInt(GRPC_ARG_MAX_RECONNECT_BACKOFF_MS, 1000);
  args.SetInt(GRPC_ARG_INITIAL_RECONNECT_BACKOFF_MS, 100);
  // Not GRPC_ARG_MIN_RECONNECT_BACKOFF_MS: gRPC takes it as the connect timeout too, and a TLS
  // handshake does not finish in 100 ms on a loaded machine (the worker would never connect).
  Result<std::shared_ptr<grpc::Channel>> channel = OpenChannel(options.connection, args);
  if (!channel.ok()) return channel.status();
  m.channel = std::move(channel).value();
  m.stub = v1::WorkerService::NewStub(m.channel);
  for (int i = 0; i < options.jobs; ++i) m.slots.emplace_back([&m, i] { m.Slot(i); });
  return w;
}

DesignWorker::~DesignWorker() {
  Stop();
  Wait();
}

void DesignWorker::Stop() { impl_->stop = true; }

void DesignWorker::Wait() {
  for (std::thread& t : impl_->slots)
    if (t.joinable()) t.join();
}

}  // namespace kgd::worker
