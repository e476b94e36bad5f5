// kgd: the kinesthetic garment designer's command-line interface.
#include <CLI/CLI.hpp>
#include <cstdio>
#include <iostream>
#include <new>

#include "client/body_command.h"
#include "client/design_command.h"
#include "client/out_of_memory.h"
#include "client/region_command.h"
#include "client/service_commands.h"
#include "client/simulate_command.h"
#include "client/study_command.h"
#include "core/util/pinned_kernels.h"

namespace {

int Run(int argc, char** argv) {
  kgd::PinNumericKernels(argv);  // the same designs on every machine (may execute the program again)
  CLI::App app{"kgd: kinesthetic garment designer"};
  app.require_subcommand(1);
  int exit_code = 0;
  kgd::cli::AddSimulateCommands(app, &exit_code);
  kgd::cli::AddBodyCommand(app, &exit_code);
  kgd::cli::AddRegionCommand(app, &exit_code);
  kgd::cli::AddDesignCommands(app, &exit_code);
  kgd::cli::AddServiceCommands(app, &exit_code);
  kgd::cli::AddStudyCommand(app, &exit_code);
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    // CLI11 prints the message (or the help) and has its own codes (105, 106, ...); ours for misuse is 1.
    return app.exit(e) == 0 ? 0 : 1;
  }
  return exit_code;
}

}  // namespace

int main(int argc, char** argv) {
  try {
    const int code = Run(argc, argv);
    kgd::cli::ExitingNormally();
    return code;
  } catch (const std::bad_alloc&) {
    kgd::cli::ExitingNormally();
    // Out of memory: the command's files were closed on the way here (a design file keeps every
    // iteration it stored, and `kgd design --resume` continues it). Exit 4, as for a failed write.
    std::fputs("kgd: out of memory: the command stopped (a design job's file keeps the iterations it stored; "
               "kgd design --resume FILE continues it)\n", stderr);
    return 4;
  }
}
