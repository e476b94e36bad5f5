// kgd-server: the design service on a data folder (server/service_host.h, flags in
// server/service_flags.h). SIGTERM or SIGINT drains (running jobs checkpoint and are queued again) and
// exits.
#include <sys/stat.h>
#include <CLI/CLI.hpp>
#include <cstdio>

#include "core/util/termination.h"
#include "server/service_flags.h"

int main(int argc, char** argv) {
  kgd::server::ServiceFlags flags;
  flags.host.http.address = "";  // no HTTP door unless --http
  flags.host.http.web_dir = KGD_WEB_DIR;
  CLI::App app("kgd-server: the kinesthetic garment design service (gRPC)");
  kgd::server::AddServiceFlags(&app, &flags);
  CLI11_PARSE(app, argc, argv);
  kgd::Result<kgd::server::HostOptions> options = kgd::server::HostOptionsOf(flags);
  if (!options.ok()) {
    std::fprintf(stderr, "kgd-server: %s\n", options.message().c_str());
    return 1;
  }
  umask(077);  // the data folder's files (SQLite, HDF5) are the owner's alone: 0600
  kgd::BlockTerminationSignals();
  auto host = kgd::server::ServiceHost::Start(*options);
  if (!host.ok()) {
    std::fprintf(stderr, "kgd-server: %s\n", host.message().c_str());
    return 1;
  }
  // The port lines are for scripts and tests that listen on port 0.
  std::printf("listening on %s\n", (*host)->grpc_address().c_str());
  if (!(*host)->http_url().empty()) std::printf("http on %s\n", (*host)->http_url().c_str());
  std::fflush(stdout);
  kgd::WaitForTerminationSignal();
  (*host)->Shutdown();
  return 0;
}
