// `kgd study accuracy SCENE --out DIR`: what accuracy costs in time. Sweeps the knobs that trade one
// for the other (solver tolerance per BESO iteration, method, relaxation, fold barrier, mesh
// resolution) on a built-in scene and writes CSV, SVG plots and a generated ACCURACY.md.
#pragma once

#include <CLI/CLI.hpp>

namespace kgd::cli {

void AddStudyCommand(CLI::App& app, int* exit_code);

}  // namespace kgd::cli
