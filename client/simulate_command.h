// `kgd simulate`, `kgd scenes`, `kgd scene export`: the CLI over core/scene.
#pragma once

#include <CLI/CLI.hpp>
#include <string>
#include <vector>

#include "core/scene/scene.h"

namespace kgd::cli {

// Registers the commands on `app`; each sets *exit_code when it runs.
void AddSimulateCommands(CLI::App& app, int* exit_code);

}  // namespace kgd::cli
