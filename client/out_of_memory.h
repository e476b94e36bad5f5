// Running out of memory in the middle of a design job: a reserve of memory is set aside at start, and the
// first allocation that fails releases it and is tried again (so that what was being computed completes,
// and the libraries in the middle of it never see a failed allocation) while the command is told to stop
// at the next safe point (`kgd design`: after storing the iteration in progress, exit 4). Allocations
// that fail again once the reserve is gone are retried a bounded number of times (a transient failure)
// and then throw std::bad_alloc as usual.
#pragma once

#include <string>

namespace kgd::cli {

// Sets the reserve aside and installs the handler; once per process, before the command runs.
void InstallOutOfMemoryReserve();

// True once an allocation has failed in this process.
bool OutOfMemory();

// A library that ends the process itself (HDF5 1.10 calls exit(-1) when an allocation fails inside
// it) is reported instead of ending it in silence: once this is called, an exit that main did not make
// prints "kgd: `what` stopped inside a library (out of memory?); `note`" and exits with 4. `note` says
// what is kept and how to go on.
void ReportUnexpectedExit(const std::string& what, const std::string& note);
// Called by main just before it returns: its exit is the command's own.
void ExitingNormally();

}  // namespace kgd::cli
