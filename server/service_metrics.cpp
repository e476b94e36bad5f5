#include "server/service_metrics.h"

#include <prometheus/counter.h>
#include <prometheus/gauge.h>
#include <prometheus/histogram.h>
#include <prometheus/registry.h>
#include <prometheus/text_serializer.h>

#include <chrono>
#include <mutex>
#include <sstream>

namespace kgd::server {

namespace pm = prometheus;

struct ServiceMetrics::Impl {
  pm::Registry registry;
  pm::Family<pm::Gauge>& jobs = pm::BuildGauge().Name("kgd_jobs").Help("Jobs in each state").Register(registry);
  pm::Gauge& queue_depth = pm::BuildGauge().Name("kgd_queue_depth").Help("Queued jobs waiting for a worker").Register(registry).Add({});
  pm::Counter& iterations =
      pm::BuildCounter().Name("kgd_iterations_total").Help("Design iterations stored").Register(registry).Add({});
  pm::Counter& created = pm::BuildCounter().Name("kgd_jobs_created_total").Help("Jobs accepted").Register(registry).Add({});
  pm::Counter& expiries =
      pm::BuildCounter().Name("kgd_lease_expiries_total").Help("Worker leases that ran out").Register(registry).Add({});
  pm::Family<pm::Counter>& exports = pm::BuildCounter().Name("kgd_exports_total").Help("Cut-file exports served, computed or from the cache").Register(registry);
  pm::Counter& exports_computed = exports.Add({{"source", "computed"}});
  pm::Counter& exports_cached = exports.Add({{"source", "cache"}});
  pm::Gauge& watchers = pm::BuildGauge().Name("kgd_watchers").Help("Open WatchJob streams (gRPC and HTTP)").Register(registry).Add({});
  // Buckets: design iterations run from ~10 ms (small garments) to seconds (whole-body, precise).
  pm::Histogram& iteration_s = pm::BuildHistogram()
                                   .Name("kgd_iteration_seconds")
                                   .Help("A worker's time per design iteration")
                                   .Register(registry)
                                   .Add({}, pm::Histogram::BucketBoundaries{0.01, 0.025, 0.05, 0.1, 0.25, 0.5, 1, 2.5, 5, 10});
  pm::Histogram& report_to_store_s = pm::BuildHistogram()
                                         .Name("kgd_report_to_store_seconds")
                                         .Help("From a worker's report to the iteration committed")
                                         .Register(registry)
                                         .Add({}, pm::Histogram::BucketBoundaries{0.001, 0.0025, 0.005, 0.01, 0.025, 0.05, 0.1, 0.25, 1});
  pm::Histogram& hdf5_s = pm::BuildHistogram()
                              .Name("kgd_hdf5_write_seconds")
                              .Help("Appending one iteration to its design file (HDF5)")
                              .Register(registry)
                              .Add({}, pm::Histogram::BucketBoundaries{0.0005, 0.001, 0.0025, 0.005, 0.01, 0.025, 0.05, 0.1, 0.5});
  pm::Histogram& sqlite_s = pm::BuildHistogram()
                                .Name("kgd_sqlite_commit_seconds")
                                .Help("Committing one iteration to the job store (SQLite)")
                                .Register(registry)
                                .Add({}, pm::Histogram::BucketBoundaries{0.0005, 0.001, 0.0025, 0.005, 0.01, 0.025, 0.05, 0.1, 0.5});
  std::mutex jobs_mu;  // the per-state gauges are set and read together
};

ServiceMetrics::ServiceMetrics() : impl_(std::make_unique<Impl>()) {}
ServiceMetrics::~ServiceMetrics() = default;

void ServiceMetrics::JobCreated() { impl_->created.Increment(); }

void ServiceMetrics::IterationStored(double iteration_s, double report_time_s, double hdf5_s, double sqlite_s) {
  impl_->iterations.Increment();
  if (iteration_s > 0) impl_->iteration_s.Observe(iteration_s);
  if (report_time_s > 0) {
    const double now = std::chrono::duration<double>(std::chrono::system_clock::now().time_since_epoch()).count();
    // Worker clocks may run ahead of the server's; a negative lag is a clock skew, not a latency.
    if (now >= report_time_s) impl_->report_to_store_s.Observe(now - report_time_s);
  }
  impl_->hdf5_s.Observe(hdf5_s);
  impl_->sqlite_s.Observe(sqlite_s);
}

void ServiceMetrics::LeasesExpired(int count) { impl_->expiries.Increment(count); }
void ServiceMetrics::WatcherOpened() { impl_->watchers.Increment(); }
void ServiceMetrics::WatcherClosed() { impl_->watchers.Decrement(); }
void ServiceMetrics::ExportServed(bool from_cache) { (from_cache ? impl_->exports_cached : impl_->exports_computed).Increment(); }

std::string ServiceMetrics::Text(const std::map<std::string, double>& jobs_by_state, double queue_depth) {
  std::lock_guard lock(impl_->jobs_mu);
  for (const auto& [state, count] : jobs_by_state) impl_->jobs.Add({{"state", state}}).Set(count);
  impl_->queue_depth.Set(queue_depth);
  std::ostringstream out;
  pm::TextSerializer().Serialize(out, impl_->registry.Collect());
  return out.str();
}

}  // namespace kgd::server
