// The design service in one process: opens the JobService (server/job_service.h) on a data folder
// and attaches its doors, gRPC (server/design_server.h) and optionally HTTP (server/http_gateway.h).
// kgd-server and `kgd serve` are both this host, with the flags of server/service_flags.h; `kgd serve`
// also runs workers in the process, which connect where worker_connection() says.
//
//   Start      checks both doors' options and that their addresses are free (nothing is created
//              when one is refused: a second server on a taken port exits naming it), opens the
//              service (repairing the data folder), starts the gRPC door, then the HTTP door
//   Shutdown   stops the HTTP door, drains (running workers checkpoint and release their jobs, up
//              to drain_timeout_s), calls `after_drain` (in-process workers stop there), stops the
//              service and the gRPC door, closes the service
#pragma once

#include <functional>
#include <memory>
#include <string>

#include "core/util/status.h"
#include "proto/connection.h"
#include "server/design_server.h"
#include "server/http_gateway.h"
#include "server/job_service.h"

namespace kgd::server {

struct HostOptions {
  JobServiceOptions service;  // data folder, leases, tokens, limits
  GrpcOptions grpc;
  HttpOptions http;           // http.address empty: no HTTP door
  double drain_timeout_s = 120;  // how long Shutdown waits for workers to checkpoint
  // Workers will run in this process: with tokens they get a worker token of their own, and with TLS
  // a plaintext port on loopback (unless grpc.internal_address names one).
  bool in_process_workers = false;
};

class ServiceHost {
 public:
  static Result<std::unique_ptr<ServiceHost>> Start(HostOptions options);
  ~ServiceHost();  // Shutdown()

  JobService& service();
  std::string grpc_address() const;  // 127.0.0.1:PORT for clients
  std::string http_url() const;      // http://127.0.0.1:PORT/; empty without the HTTP door
  // Where and as whom workers in this process connect (the internal port when there is one).
  Connection worker_connection() const;

  // See the top of this file; idempotent (`after_drain` is called by the first call only).
  void Shutdown(const std::function<void()>& after_drain = nullptr);

 private:
  ServiceHost() = default;
  HostOptions options_;
  std::string worker_token_;
  std::unique_ptr<JobService> service_;
  std::unique_ptr<DesignServer> grpc_;
  std::unique_ptr<HttpGateway> http_;
  bool shut_ = false;
};

}  // namespace kgd::server
