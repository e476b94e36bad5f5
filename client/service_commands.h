// The CLI over the design service (gRPC, proto/kgd/v1/kgd.proto): `kgd serve` (server with in-process
// workers on a data folder: the embedded default), `kgd submit`, `kgd watch`, `kgd jobs`, `kgd job`,
// `kgd cancel`, `kgd get`. Every client command takes --server HOST:PORT (default: $KGD_SERVER, else
// 127.0.0.1:7447).
//
// Exit codes: 0 done; 1 the server cannot be reached or refused; 2 bad arguments or unknown job;
// 3 the watched job FAILED; 4 it was CANCELLED; 130 interrupted.
#pragma once

#include <CLI/CLI.hpp>

namespace kgd::cli {

void AddServiceCommands(CLI::App& app, int* exit_code);

}  // namespace kgd::cli
