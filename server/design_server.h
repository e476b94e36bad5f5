// The design server: DesignService for clients and WorkerService for workers (proto/kgd/v1/kgd.proto)
// over one data folder:
//   DIR/kgd.sqlite       the job store (server/job_store.h): queue, leases, iteration metrics
//   DIR/jobs/job-N.h5    each job's design file (store/design_file.h), written from worker reports
// It stores and streams; it never simulates. An iteration is acknowledged to its worker after it is
// in the HDF5 file (flushed, SWMR) and then in SQLite (committed), in that order, so a server killed
// at any moment restarts with every acknowledged iteration; on start it trims any HDF5 iteration
// SQLite never acknowledged and queues the jobs whose workers it lost.
//
// Leases: a worker holds a job while its RunJob stream is open and its heartbeats arrive within
// lease_duration_s; a lost worker's job is queued again (and resumes from its last acknowledged
// iteration) until it has had max_attempts attempts.
#pragma once

#include <memory>
#include <string>

#include "core/util/status.h"

namespace kgd::server {

struct ServerOptions {
  std::string data_dir;                    // created if missing
  std::string address = "127.0.0.1:7447";  // host:port; port 0 picks a free one
  double lease_duration_s = 30;
  int max_attempts = 5;
  int max_message_bytes = 64 << 20;        // larger requests get RESOURCE_EXHAUSTED
  double drain_timeout_s = 120;            // how long Drain waits for workers to checkpoint
  bool quiet = false;                      // no log lines on stderr
};

class DesignServer {
 public:
  // Opens the data folder, repairs it after a crash, and starts serving.
  static Result<std::unique_ptr<DesignServer>> Start(const ServerOptions& options);
  ~DesignServer();  // Shutdown()

  int port() const;
  std::string address() const;  // 127.0.0.1:PORT for clients
  const std::string& data_dir() const;

  // Stops leasing, asks running workers to stop after their current iteration (their jobs are queued
  // again, to resume later), and waits for them up to drain_timeout_s.
  void Drain();
  // Stops serving (open streams end); idempotent.
  void Shutdown();
  // Blocks until Shutdown.
  void Wait();

 private:
  DesignServer() = default;
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace kgd::server
