// The design service's figures for Prometheus (text exposition format, served by the HTTP door at
// GET /metrics): what an operator watches and what an autoscaler scales workers on.
//
//   kgd_jobs{state}                      gauge     jobs in each state (read from the job store at scrape)
//   kgd_queue_depth                      gauge     queued jobs: the workers' autoscaling signal
//   kgd_iterations_total                 counter   iterations stored (rate(): iterations per second)
//   kgd_iteration_seconds                histogram a worker's time per design iteration (its report)
//   kgd_report_to_store_seconds          histogram from a worker's report time to the iteration committed
//   kgd_hdf5_write_seconds               histogram appending one iteration to its design file
//   kgd_sqlite_commit_seconds            histogram committing one iteration to the job store
//   kgd_lease_expiries_total             counter   leases that ran out (a worker vanished or stalled)
//   kgd_watchers                         gauge     open WatchJob streams, gRPC and HTTP together
//   kgd_jobs_created_total               counter   jobs accepted
//   kgd_exports_total{source}            counter   cut-file exports served: "computed", or "cache" (the
//                                                  same job, iteration and options as a recent one)
//
// Thread-safe: every method may be called from any thread.
#pragma once

#include <map>
#include <memory>
#include <string>

namespace kgd::server {

class ServiceMetrics {
 public:
  ServiceMetrics();
  ~ServiceMetrics();

  void JobCreated();
  // One stored iteration: the worker's time for it, its report time (Unix s) and the write times (s).
  void IterationStored(double iteration_s, double report_time_s, double hdf5_s, double sqlite_s);
  void LeasesExpired(int count);
  void WatcherOpened();
  void WatcherClosed();
  void ExportServed(bool from_cache);
  // The text exposition of every figure, with the jobs per state given (state name -> count).
  std::string Text(const std::map<std::string, double>& jobs_by_state, double queue_depth);

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace kgd::server
