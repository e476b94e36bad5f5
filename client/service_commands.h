// The CLI over the design service (gRPC, proto/kgd/v1/kgd.proto): `kgd serve` (server with in-process
// workers on a data folder: the embedded default), `kgd submit`, `kgd watch`, `kgd jobs`, `kgd job`,
// `kgd cancel`, `kgd get`. Every client command takes --server HOST:PORT (default: $KGD_SERVER, else
// 127.0.0.1:7447), --token (a server with --auth-tokens; default $KGD_TOKEN) and --tls-ca (TLS; default
// $KGD_TLS_CA).
//
// Exit codes: 0 done; 1 the server cannot be reached or refused; 2 bad arguments or unknown job;
// 3 the watched job FAILED; 4 it was CANCELLED; 130 interrupted.
#pragma once

#include <CLI/CLI.hpp>
#include <cstdint>
#include <string>

namespace kgd::cli {

void AddServiceCommands(CLI::App& app, int* exit_code);

// `kgd export JOB`: the cut files of a stored job's iteration from the design server (ExportDesign, by
// geometry alone), written into `out` all at once. Returns the exit code.
struct ExportJobRequest {
  std::string server, out;
  int64_t job = 0;
  int iteration = -1;
  double min_feature_mm = 3, seam_allowance_mm = 10, sheet_width_mm = 305;
  bool no_mirror = false, json = false;
};
int RunExportJob(const ExportJobRequest& request);

// One line on stderr as an export's stage starts: "export:  50% cutting and flattening the pattern".
void PrintExportProgress(const std::string& stage, double fraction);
std::string DefaultServer();
// --server, --token and --tls-ca of a command that talks to the design server.
void AddServerOptions(CLI::App* command, std::string* server, const std::string& what);

}  // namespace kgd::cli
