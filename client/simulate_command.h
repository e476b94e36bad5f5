// `kgd simulate`, `kgd scenes`, `kgd scene export`: the CLI over core/scene.
#pragma once

#include <CLI/CLI.hpp>
#include <string>
#include <vector>

#include "core/scene/scene.h"

namespace kgd::cli {

// A scene argument: a scene file if it exists, else the name of a built-in scene (on a parametric body
// made to the `name=value` measurements `body_items`, when given).
Result<SceneSpec> ResolveScene(const std::string& arg, const std::vector<std::string>& body_items = {});

// Registers the commands on `app`; each sets *exit_code when it runs.
void AddSimulateCommands(CLI::App& app, int* exit_code);

}  // namespace kgd::cli
