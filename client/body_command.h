// `kgd body`: the parametric body made to measure and posed, written as meshes a scene file can name;
// and the parsing of `--body name=value` measurements shared with `kgd simulate` and `kgd scene export`.
#pragma once

#include <CLI/CLI.hpp>
#include <optional>
#include <string>
#include <vector>

#include "core/body/parametric_body.h"
#include "core/util/status.h"

namespace kgd::cli {

// `name=value` items (SI) into measurements; none given: no value.
Result<std::optional<BodyMeasurements>> ParseBodyMeasurements(const std::vector<std::string>& items);

// Registers `kgd body`; it sets *exit_code when it runs.
void AddBodyCommand(CLI::App& app, int* exit_code);

}  // namespace kgd::cli
