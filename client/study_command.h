// `kgd study accuracy SCENE --out DIR`: the accuracy study of study/accuracy_study.h, its report
// (CSV, SVG plots, a generated ACCURACY.md) written into DIR. `kgd machine`: the date, CPU model and
// cores, the one line every generated table's header gives (study/machine.h).
#pragma once

#include <CLI/CLI.hpp>

namespace kgd::cli {

void AddStudyCommand(CLI::App& app, int* exit_code);

}  // namespace kgd::cli
