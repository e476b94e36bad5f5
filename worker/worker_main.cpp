// kgd-worker: runs design jobs leased from a kgd-server (see worker/design_worker.h). SIGTERM or
// SIGINT: running jobs stop after their current iteration and go back to the queue.
#include <CLI/CLI.hpp>
#include <cstdio>

#include "core/util/termination.h"
#include "core/util/pinned_kernels.h"
#include "worker/design_worker.h"

int main(int argc, char** argv) {
  kgd::PinNumericKernels(argv);  // the same designs on every machine (may execute the program again)
  kgd::worker::WorkerOptions o;
  o.connection = kgd::ConnectionFromEnvironment();
  CLI::App app("kgd-worker: runs kinesthetic garment design jobs for a kgd-server");
  app.add_option("--server", o.connection.server, "The server, host:port (default: $KGD_SERVER or 127.0.0.1:7447)")->capture_default_str();
  app.add_option("--token", o.connection.token, "The worker's token, for a server with --auth-tokens (default: $KGD_TOKEN)");
  app.add_option("--tls-ca", o.connection.tls_ca, "PEM file of the CA that signed the server's certificate: connect over TLS (default: $KGD_TLS_CA)");
  app.add_option("--jobs", o.jobs, "Jobs run at once")->check(CLI::PositiveNumber)->capture_default_str();
  app.add_option("--name", o.name, "Name shown by the server (default host:pid)");
  app.add_flag("--quiet", o.quiet, "No log lines");
  CLI11_PARSE(app, argc, argv);
  kgd::BlockTerminationSignals();
  auto worker = kgd::worker::DesignWorker::Start(o);
  if (!worker.ok()) {
    std::fprintf(stderr, "kgd-worker: %s\n", worker.message().c_str());
    return 2;
  }
  kgd::WaitForTerminationSignal();
  (*worker)->Stop();
  (*worker)->Wait();
  return 0;
}
