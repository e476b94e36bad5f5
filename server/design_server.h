// The design server: the job service (server/job_service.h) behind gRPC, as DesignService for clients
// and WorkerService for workers (proto/kgd/v1/kgd.proto), with health checking and reflection. The
// handlers only translate: what the service does, and how it keeps a data folder crash-safe, is
// documented in job_service.h.
#pragma once

#include <memory>
#include <string>

#include "core/util/status.h"
#include "server/job_service.h"

namespace kgd::server {

struct ServerOptions {
  std::string data_dir;                    // created if missing
  std::string address = "127.0.0.1:7447";  // host:port; port 0 picks a free one
  double lease_duration_s = 30;
  int max_attempts = 5;
  int max_message_bytes = 64 << 20;        // larger requests get RESOURCE_EXHAUSTED
  double drain_timeout_s = 120;            // how long Drain waits for workers to checkpoint
  bool quiet = false;                      // no log lines on stderr
  TokenTable tokens;                       // bearer tokens (server/auth.h); none: anyone who reaches the port
  std::string tls_cert, tls_key;           // PEM files: serve gRPC over TLS; empty: plaintext
  // A second, plaintext port on loopback (host:port, port 0: any) for in-process workers of a server
  // whose main port takes TLS; empty: none.
  std::string internal_address;
  bool insecure = false;                   // allow a non-loopback address without TLS and tokens
  ServiceLimits limits;                    // what a request or user may ask (server/job_service.h)
};

class DesignServer {
 public:
  // Opens the data folder, repairs it after a crash, and starts serving.
  // A non-loopback address without both TLS and tokens is refused unless options.insecure.
  static Result<std::unique_ptr<DesignServer>> Start(const ServerOptions& options);
  ~DesignServer();  // Shutdown()

  int port() const;
  std::string address() const;  // 127.0.0.1:PORT for clients
  const std::string& data_dir() const;
  // Where in-process workers connect: the internal port when there is one, else address().
  std::string internal_address() const;
  // The transport-free service behind the gRPC handlers, for other doors in the same process.
  JobService& service();

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
