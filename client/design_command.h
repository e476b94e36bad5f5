// `kgd design` (a BESO job run locally, written to a design file), `kgd designs` (its history as a
// table), `kgd evaluate` (a design over the scene's motion frames) and `kgd baselines` (Line and X of
// the same area, simulated the same way).
#pragma once

#include <CLI/CLI.hpp>

namespace kgd::cli {

// Registers the commands on `app`; each sets *exit_code when it runs.
void AddDesignCommands(CLI::App& app, int* exit_code);

}  // namespace kgd::cli
