// The design worker: leases jobs from a design server (WorkerService), runs the BESO design engine on
// them, and reports every iteration with the state a resumed job needs (design, positions, energy
// densities, averaged sensitivities, target area). It needs no shared disk: the job comes with its
// scene, a resumed job with its checkpoint.
//
// A job stops early when the server says cancel (the job is cancelled) or drain (it is queued again),
// when the stream or lease is lost (the server queues it again), or when the worker is stopped.
// Connection loss is not an error: the worker keeps trying to reach the server.
#pragma once

#include <memory>
#include <string>

#include "core/util/status.h"
#include "proto/connection.h"

namespace kgd::worker {

struct WorkerOptions {
  Connection connection;                  // the design server: address, worker token, TLS CA
  int jobs = 1;                           // jobs run at once (threads)
  std::string name;                       // shown by the server; default host:pid
  bool quiet = false;
  // Measure this machine's speed before the first job and send it to the server (worker/machine_speed.h).
  bool measure_speed = true;
};

class DesignWorker {
 public:
  static Result<std::unique_ptr<DesignWorker>> Start(const WorkerOptions& options);
  ~DesignWorker();  // Stop() and Wait()

  // Stops leasing; running jobs stop after their current iteration and are released to the server.
  void Stop();
  // Blocks until every job slot has ended (after Stop).
  void Wait();

 private:
  DesignWorker() = default;
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace kgd::worker
