// The gRPC door of the design service: the job service (server/job_service.h) as DesignService for
// clients and WorkerService for workers (proto/kgd/v1/kgd.proto), with health checking and reflection.
// The handlers only translate: what the service does, and how it keeps a data folder crash-safe, is
// documented in job_service.h; server/service_host.h opens the service and attaches this door.
#pragma once

#include <memory>
#include <string>

#include "core/util/status.h"
#include "server/job_service.h"

namespace kgd::server {

// The gRPC door's own settings; what the service does (data folder, leases, tokens, limits) is the
// JobService's (JobServiceOptions).
struct GrpcOptions {
  std::string address = "127.0.0.1:7447";  // host:port; port 0 picks a free one
  int max_message_bytes = 64 << 20;        // larger requests get RESOURCE_EXHAUSTED
  std::string tls_cert, tls_key;           // PEM files: serve gRPC over TLS; empty: plaintext
  // A second, plaintext port on loopback (host:port, port 0: any) for in-process workers of a server
  // whose main port takes TLS; empty: none.
  std::string internal_address;
  bool insecure = false;                   // allow a non-loopback address without TLS and tokens
  bool quiet = false;                      // no log line on stderr
};

class DesignServer {
 public:
  // What Start would refuse before binding: half a TLS pair, a non-loopback address without both TLS
  // and tokens (unless options.insecure), an internal port off loopback.
  static Status CheckOptions(const GrpcOptions& options, bool tokens);
  // Starts serving `service` (which must outlive the server).
  static Result<std::unique_ptr<DesignServer>> Start(JobService& service, const GrpcOptions& options);
  ~DesignServer();  // Shutdown()

  int port() const;
  std::string address() const;  // 127.0.0.1:PORT for clients
  // Where in-process workers connect: the internal port when there is one, else address().
  std::string internal_address() const;

  // Stops serving (open streams end within 2 s; stop the service first so that they do); idempotent.
  void Shutdown();
  // Blocks until Shutdown.
  void Wait();

 private:
  DesignServer() = default;
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace kgd::server
