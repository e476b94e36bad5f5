#include "client/study_command.h"

#include "core/util/pinned_kernels.h"

#include <cstdio>
#include <memory>
#include <string>

#include "study/accuracy_study.h"
#include "study/machine.h"

namespace kgd::cli {
namespace {

struct StudyFlags {
  study::AccuracyStudyOptions options;
  std::string out, image_prefix;
};

// Exit codes: 2 the study could not start or its report not be written, 3 no design run finished.
int RunStudy(const StudyFlags& f) {
  study::AccuracyStudyOptions o = f.options;
  o.work_dir = f.out;
  const Result<study::AccuracyStudy> st = study::RunAccuracyStudy(o);
  if (!st.ok()) {
    std::fprintf(stderr, "kgd study accuracy: %s\n", st.message().c_str());
    return 2;
  }
  if (!st->finished) {
    std::fprintf(stderr, "kgd study accuracy: no design run finished\n");
    return 3;
  }
  if (Status s = study::WriteAccuracyReport(*st, f.out, f.image_prefix); !s.ok()) {
    std::fprintf(stderr, "kgd study accuracy: %s\n", s.message().c_str());
    return 2;
  }
  std::printf("wrote %s (ACCURACY.md, runs.csv, traces.csv, pull_test.csv, frames.csv, accuracy_time.svg, newton_lbfgs.svg)\n", f.out.c_str());
  return 0;
}

}  // namespace

void AddStudyCommand(CLI::App& app, int* exit_code) {
  CLI::App* study = app.add_subcommand("study", "Studies that write generated documents");
  study->require_subcommand(1);
  auto f = std::make_shared<StudyFlags>();
  study::AccuracyStudyOptions& o = f->options;
  CLI::App* acc = study->add_subcommand("accuracy", "What accuracy costs in time: tolerance, method, relaxation, fold barrier, resolutions, frames evaluated");
  acc->add_option("scene", o.scene, "Built-in scene")->capture_default_str();
  acc->add_option("--out", f->out, "Output folder (CSV, SVG plots, ACCURACY.md)")->required();
  acc->add_option("--image-prefix", f->image_prefix, "Path prefix of the plots in ACCURACY.md (e.g. images/accuracy/)");
  acc->add_option("--method-iterations", o.method_iterations, "BESO iterations the methods are compared over")
      ->check(CLI::PositiveNumber)
      ->capture_default_str();
  acc->add_option("--lbfgs-trace-iterations", o.lbfgs_trace_iterations, "L-BFGS iteration limit of the energy traces")
      ->check(CLI::PositiveNumber)
      ->capture_default_str();
  acc->add_flag("--quick", o.quick, "Three tolerances, no resolutions and no repeat of precise (minutes, for trying the command)");
  acc->callback([f, exit_code] { *exit_code = RunStudy(*f); });

  app.add_subcommand("machine", "The date (UTC), CPU model, cores, memory and the kernel level kgd runs here, as every generated "
                                 "table's header gives them")
      ->callback([] { std::printf("%s, kernels %s\n", study::MachineLine().c_str(), RunningKernels().c_str()); });
}

}  // namespace kgd::cli
