#include "core/util/fault_point.h"

#include <signal.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <cstdlib>
#include <cstring>
#include <mutex>
#include <string>
#include <thread>

namespace kgd {
namespace fault_point_detail {

std::atomic<int> armed{-1};

namespace {

struct Spec {
  std::string name;
  long hit = 1;         // kill at this hit (1-based) ...
  int iteration = -1;   // ... or at the first hit for this iteration (>= 0)
  double sleep_s = 0;   // > 0: wait this long at every hit instead of killing
  std::atomic<long> hits{0};
};

// The parsed KGD_FAULT_POINT; null when unset, empty or malformed (a malformed one is reported once).
Spec* ReadSpec() {
  const char* env = std::getenv("KGD_FAULT_POINT");
  if (!env || !*env) return nullptr;
  auto* s = new Spec;
  const std::string text = env;
  const size_t at = text.find('@');
  s->name = text.substr(0, at);
  if (at != std::string::npos) {
    const std::string arg = text.substr(at + 1);
    const std::string kIteration = "iteration=", kSleep = "sleep=";
    char* end = nullptr;
    if (arg.rfind(kSleep, 0) == 0) {
      const std::string number = arg.substr(kSleep.size());
      const double v = std::strtod(number.c_str(), &end);
      if (!number.empty() && !*end && v > 0 && v <= 60) {
        s->sleep_s = v;
        return s;
      }
    }
    const bool by_iteration = arg.rfind(kIteration, 0) == 0;
    const std::string number = by_iteration ? arg.substr(kIteration.size()) : arg;
    const long v = std::strtol(number.c_str(), &end, 10);
    if (number.empty() || *end || v < (by_iteration ? 0 : 1)) {
      const std::string msg = "kgd: KGD_FAULT_POINT=" + text + " is not NAME, NAME@N (N >= 1), NAME@iteration=K or NAME@sleep=S (0 < S <= 60): ignored\n";
      (void)!write(2, msg.data(), msg.size());
      delete s;
      return nullptr;
    }
    if (by_iteration) s->iteration = static_cast<int>(v);
    else s->hit = v;
  }
  return s;
}

Spec* spec = nullptr;
std::once_flag once;

}  // namespace

void Check(const char* name, int iteration) {
  std::call_once(once, [] {
    spec = ReadSpec();
    armed = spec ? 1 : 0;
  });
  if (!spec || spec->name != name) return;
  if (spec->sleep_s > 0) {
    std::this_thread::sleep_for(std::chrono::duration<double>(spec->sleep_s));
    return;
  }
  if (spec->iteration >= 0 ? iteration != spec->iteration : ++spec->hits != spec->hit) return;
  const std::string msg = std::string("kgd: fault point ") + name + " (KGD_FAULT_POINT, iteration " + std::to_string(iteration) + "): killed\n";
  (void)!write(2, msg.data(), msg.size());
  kill(getpid(), SIGKILL);
  for (;;) pause();
}

}  // namespace fault_point_detail

const std::vector<std::string>& FaultPointNames() {
  static const std::vector<std::string> names = {
      "worker.before_report",        "worker.after_report",         "commit.before_hdf5",
      "design_file.append.begin",    "design_file.append.after_arrays", "design_file.append.after_flush",
      "design_file.append.after_marker", "design_file.append.end",   "commit.after_hdf5",
      "job_store.append.before_commit",  "commit.after_sqlite",     "worker.after_acknowledged",
      "open_job_file.after_open",    "repair.after_reopen",
  };
  return names;
}

}  // namespace kgd
