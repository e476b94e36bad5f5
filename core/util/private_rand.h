// libc's rand() and srand() of one thread's own, for a library that draws from them.
//
// METIS as Debian builds it (GKlib without GKRAND) seeds libc's srand() at the start of every
// ordering and bisection and then draws from rand(): one process-wide state, which other libraries
// in the same process draw from on their own threads (gRPC and c-ares do). A draw of theirs in the
// middle of an analysis changes the ordering, and so the rounding of every factorization after it: a
// served job would then part from the same job run locally, and a resumed one from the uninterrupted.
//
// While a PrivateRand lives on a thread, rand() and srand() called on that thread (by any library)
// use a state of that thread's own, with glibc's algorithm: the numbers rand() gives after srand()
// in a process where nothing else draws. Elsewhere, and on other threads, they are libc's own.
//
// This works by interposition: this module defines rand and srand, and every executable that links
// kgd_core exports them (core/CMakeLists.txt), so the dynamic linker binds the libraries' calls to
// them. PrivateRandIsBound() says whether that took (false in a program linked otherwise).
#pragma once

namespace kgd {

class PrivateRand {
 public:
  PrivateRand();
  ~PrivateRand();
  PrivateRand(const PrivateRand&) = delete;
  PrivateRand& operator=(const PrivateRand&) = delete;

 private:
  void* previous_;  // the thread's state before this one (nested scopes)
  void* own_;
};

// True when rand() and srand() as the dynamic linker binds them for shared libraries are this
// module's.
bool PrivateRandIsBound();

}  // namespace kgd
