#include "client/out_of_memory.h"

#include <unistd.h>

#include <atomic>
#include <cstdio>
#include <cstdlib>
#include <mutex>
#include <new>
#include <string>

namespace kgd::cli {
namespace {

constexpr size_t kReserveBytes = size_t{64} << 20;  // about an iteration's working memory on a 20k-face garment
constexpr int kRetries = 1000;                       // failed allocations retried after the reserve is gone

std::atomic<void*> reserve{nullptr};
std::atomic<bool> out_of_memory{false};
std::atomic<int> retries{0};

void OnAllocationFailure() {
  out_of_memory = true;
  if (void* r = reserve.exchange(nullptr)) {
    std::free(r);
    return;  // tried again, with the reserve free
  }
  if (retries.fetch_add(1) < kRetries) return;
  throw std::bad_alloc();
}

std::atomic<bool> exiting_normally{false};
std::mutex note_mu;
std::string unexpected_what, unexpected_note;

void OnExit() {
  if (exiting_normally) return;
  std::string what, note;
  {
    std::lock_guard lock(note_mu);
    what = unexpected_what;
    note = unexpected_note;
  }
  std::fflush(stdout);
  std::fprintf(stderr, "kgd: %s stopped inside a library%s; %s\n", what.c_str(), OutOfMemory() ? " (out of memory)" : "", note.c_str());
  std::fflush(stderr);
  _exit(4);
}

}  // namespace

void ReportUnexpectedExit(const std::string& what, const std::string& note) {
  static const bool registered = [] { return std::atexit(OnExit) == 0; }();
  (void)registered;
  std::lock_guard lock(note_mu);
  unexpected_what = what;
  unexpected_note = note;
}

void ExitingNormally() { exiting_normally = true; }

void InstallOutOfMemoryReserve() {
  static const bool installed = [] {
    void* r = std::malloc(kReserveBytes);
    if (r) {
      // Touched, so that the pages are the process's and freeing them gives memory back for real.
      for (size_t i = 0; i < kReserveBytes; i += 4096) static_cast<volatile char*>(r)[i] = 0;
    }
    reserve = r;
    std::set_new_handler(OnAllocationFailure);
    return true;
  }();
  (void)installed;
}

bool OutOfMemory() { return out_of_memory; }

}  // namespace kgd::cli
