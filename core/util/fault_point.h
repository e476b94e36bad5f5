// Fault points: named places where a test can have the process killed at once (SIGKILL, as a crash or
// `kill -9` would), to check that what the process stored up to there is enough to go on from.
//
// KGD_FAULT_POINT (read once, at the first fault point the process passes) names the point to kill at:
//   NAME               the first time the process passes NAME
//   NAME@N             the N-th time (N >= 1)
//   NAME@iteration=K   the first time it passes NAME for BESO iteration K (the caller's `iteration`)
//   NAME@sleep=S       not a kill: the process waits S seconds (0 < S <= 60) every time it passes NAME,
//                      as a slow machine would (a test's job then outlasts what it observes)
// Unset or empty, FaultPoint does nothing but one load of a flag. Before killing it writes
// "kgd: fault point NAME (...): killed" to stderr, so a test can tell its kill from another death.
//
// The points (FaultPointNames() lists them; each is at one place in the code):
//   design_file.append.begin            DesignFileWriter::Append before any dataset is written
//   design_file.append.after_arrays     ... metrics and arrays written, not yet flushed
//   design_file.append.after_flush      ... flushed, before the commit marker /iterations/iteration
//   design_file.append.after_marker     ... the marker written, not yet flushed
//   design_file.append.end              ... the marker flushed (the row is stored)
//   job_store.append.before_commit      JobStore::AppendIteration: rows inserted, before COMMIT
//   commit.before_hdf5                  JobService Commit: checked, before the design file's append
//   commit.after_hdf5                   ... the design file appended, before the job store's
//   commit.after_sqlite                 ... both stored, before the worker is answered
//   open_job_file.after_open            JobService OpenJobFile: the design file created or reopened
//   repair.after_reopen                 JobService Repair: a design file reopened (rebuilt), before trimming
//   worker.before_report                DesignWorker: an iteration computed, before it is sent
//   worker.after_report                 ... sent, before waiting for the server's acknowledgement
//   worker.after_acknowledged           ... the server's acknowledgement of the previous iteration in
#pragma once

#include <atomic>
#include <string>
#include <vector>

namespace kgd {

namespace fault_point_detail {
// 1: KGD_FAULT_POINT names a point; 0: it does not; -1: not read yet.
extern std::atomic<int> armed;
void Check(const char* name, int iteration);
}  // namespace fault_point_detail

// Kills the process (SIGKILL) when KGD_FAULT_POINT names this point, hit and iteration, or waits when it
// names this point with a sleep (see above);
// `iteration` is the BESO iteration being stored or reported, -1 where none is.
inline void FaultPoint(const char* name, int iteration = -1) {
  if (fault_point_detail::armed.load(std::memory_order_relaxed) != 0) fault_point_detail::Check(name, iteration);
}

// Every fault point in the code, in the order an iteration passes them.
const std::vector<std::string>& FaultPointNames();

}  // namespace kgd
