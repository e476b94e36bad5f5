// Orderly stop on SIGINT / SIGTERM for the long-running programs (kgd-server, kgd-worker, kgd serve).
// BlockTerminationSignals() must run before any thread starts (threads inherit the mask); then
// WaitForTerminationSignal() returns the signal once one arrives, and the program drains and exits.
#pragma once

#include <pthread.h>
#include <signal.h>

namespace kgd {

inline sigset_t TerminationSignals() {
  sigset_t set;
  sigemptyset(&set);
  sigaddset(&set, SIGINT);
  sigaddset(&set, SIGTERM);
  return set;
}

inline void BlockTerminationSignals() {
  const sigset_t set = TerminationSignals();
  pthread_sigmask(SIG_BLOCK, &set, nullptr);
}

inline int WaitForTerminationSignal() {
  const sigset_t set = TerminationSignals();
  int sig = 0;
  sigwait(&set, &sig);
  return sig;
}

}  // namespace kgd
