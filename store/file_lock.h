// One writer per file: an advisory lock (flock) on a file for as long as a writer holds it open, so
// that a second writer (another `kgd design --out` on the same file, another server on the same data
// folder) is refused instead of interleaving its iterations with the first's. Readers take no lock.
//
// The lock belongs to the open file (the inode), not the name: a file renamed into place keeps the
// lock its creator took. It is released when the FileLock is destroyed or the process ends (kill -9
// too: the kernel drops it), and is not inherited across exec.
#pragma once

#include <functional>
#include <string>

#include "core/util/status.h"

namespace kgd {

class FileLock {
 public:
  FileLock() = default;
  FileLock(FileLock&& other) noexcept;
  FileLock& operator=(FileLock&& other) noexcept;
  FileLock(const FileLock&) = delete;
  FileLock& operator=(const FileLock&) = delete;
  ~FileLock();

  // Takes the exclusive lock on the file `path` without waiting (`create`: an empty file is made when
  // there is none; an existing one is left as it is). Held by another writer: an error naming the file
  // and the holder ("process 1234: kgd design knee_flexion --out same.h5"), where the system tells it;
  // `when_held`, if given, words that error from the holder ("a process this one cannot see" when the
  // system does not tell).
  static Result<FileLock> Acquire(const std::string& path, bool create = false,
                                  const std::function<std::string(const std::string& holder)>& when_held = {});

  bool held() const { return fd_ >= 0; }
  void Release();

 private:
  explicit FileLock(int fd) : fd_(fd) {}
  int fd_ = -1;
};

// Who holds a lock on `path` ("process 1234: kgd design ..."), or empty when no holder can be found.
std::string FileLockHolder(const std::string& path);

}  // namespace kgd
