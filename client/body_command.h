// `kgd body`: the parametric body made to measure and posed, written as meshes a scene file can name.
#pragma once

#include <CLI/CLI.hpp>
#include <optional>
#include <string>
#include <vector>

#include "core/body/parametric_body.h"
#include "core/util/status.h"

namespace kgd::cli {

// Registers `kgd body`; it sets *exit_code when it runs.
void AddBodyCommand(CLI::App& app, int* exit_code);

}  // namespace kgd::cli
