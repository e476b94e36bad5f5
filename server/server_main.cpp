// kgd-server: the design service on a data folder (see server/design_server.h). SIGTERM or SIGINT
// drains (running jobs checkpoint and are queued again) and exits.
#include <sys/stat.h>
#include <CLI/CLI.hpp>
#include <cstdio>

#include "core/util/termination.h"
#include "server/design_server.h"
#include "server/http_gateway.h"
#include "server/security_flags.h"

int main(int argc, char** argv) {
  kgd::server::ServerOptions o;
  double max_message_mb = o.max_message_bytes / double(1 << 20);
  CLI::App app("kgd-server: the kinesthetic garment design service (gRPC)");
  app.add_option("--data", o.data_dir, "Data folder: kgd.sqlite and jobs/job-N.h5 (created if missing)")->required();
  app.add_option("--listen", o.address, "host:port to listen on (port 0: any free port)")->capture_default_str();
  app.add_option("--lease-s", o.lease_duration_s, "Seconds without a heartbeat after which a worker's job is queued again")
      ->check(CLI::PositiveNumber)->capture_default_str();
  app.add_option("--max-attempts", o.max_attempts, "Leases a job gets before it fails")->check(CLI::PositiveNumber)->capture_default_str();
  // gRPC takes the limit as an int of bytes: below 2 GiB.
  app.add_option("--max-message-mb", max_message_mb, "Largest request accepted (MiB)")
      ->check(CLI::Range(0.001, 2047.0))
      ->capture_default_str();
  app.add_option("--drain-s", o.drain_timeout_s, "On SIGTERM, seconds to wait for workers to checkpoint")->capture_default_str();
  app.add_flag("--quiet", o.quiet, "No log lines");
  app.add_option("--internal-listen", o.internal_address,
                 "Also a plaintext gRPC port on loopback (host:port), for health probes and local workers of a TLS server");
  kgd::server::HttpOptions http{.address = "", .web_dir = KGD_WEB_DIR};
  double max_upload_mb = 64;
  app.add_option("--http", http.address, "host:port of the web page and the HTTP/JSON API (default: none; port 0: any free port)");
  app.add_option("--web", http.web_dir, "Folder of the web page's files")->capture_default_str();
  app.add_option("--max-upload-mb", max_upload_mb, "Largest HTTP request body accepted (MiB)")->check(CLI::PositiveNumber)->capture_default_str();
  app.add_option("--max-watchers", http.max_watchers, "Open HTTP watch streams (Server-Sent Events) served at once")
      ->check(CLI::PositiveNumber)->capture_default_str();
  kgd::server::SecurityFlags security;
  kgd::server::AddSecurityFlags(&app, &security);
  CLI11_PARSE(app, argc, argv);
  if (kgd::Status st = kgd::server::ApplySecurityFlags(security, &o, &http); !st.ok()) {
    std::fprintf(stderr, "kgd-server: %s\n", st.message().c_str());
    return 1;
  }
  http.max_upload_bytes = static_cast<size_t>(max_upload_mb * (1 << 20));
  o.max_message_bytes = static_cast<int>(max_message_mb * (1 << 20));

  umask(077);  // the data folder's files (SQLite, HDF5) are the owner's alone: 0600
  kgd::BlockTerminationSignals();
  auto server = kgd::server::DesignServer::Start(o);
  if (!server.ok()) {
    std::fprintf(stderr, "kgd-server: %s\n", server.message().c_str());
    return 1;
  }
  // The port line is for scripts and tests that listen on port 0.
  std::printf("listening on %s\n", (*server)->address().c_str());
  std::unique_ptr<kgd::server::HttpGateway> gateway;
  if (!http.address.empty()) {
    auto g = kgd::server::HttpGateway::Start(&(*server)->service(), http);
    if (!g.ok()) {
      std::fprintf(stderr, "kgd-server: %s\n", g.message().c_str());
      return 1;
    }
    gateway = std::move(g).value();
    std::printf("http on %s\n", gateway->url().c_str());
  }
  std::fflush(stdout);
  kgd::WaitForTerminationSignal();
  if (gateway) gateway->Stop();
  (*server)->Drain();
  (*server)->Shutdown();
  return 0;
}
