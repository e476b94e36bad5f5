// Running out of memory in the middle of a design job: a reserve of memory is set aside at start, and the
// first allocation that fails releases it and is tried again (so that what was being computed completes,
// and the libraries in the middle of it never see a failed allocation) while the command is told to stop
// at the next safe point (`kgd design`: after storing the iteration in progress, exit 4). Allocations
// that fail again once the reserve is gone are retried a bounded number of times (a transient failure)
// and then throw std::bad_alloc as usual.
#pragma once

namespace kgd::cli {

// Sets the reserve aside and installs the handler; once per process, before the command runs.
void InstallOutOfMemoryReserve();

// True once an allocation has failed in this process.
bool OutOfMemory();

}  // namespace kgd::cli
