#include "store/file_lock.h"

#include <fcntl.h>
#include <sys/file.h>
#include <sys/stat.h>
#include <sys/sysmacros.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <fstream>
#include <sstream>

namespace kgd {

FileLock::FileLock(FileLock&& other) noexcept : fd_(other.fd_) { other.fd_ = -1; }

FileLock& FileLock::operator=(FileLock&& other) noexcept {
  if (this != &other) {
    Release();
    fd_ = other.fd_;
    other.fd_ = -1;
  }
  return *this;
}

FileLock::~FileLock() { Release(); }

void FileLock::Release() {
  if (fd_ >= 0) ::close(fd_);  // closing the only descriptor of the open file drops its flock
  fd_ = -1;
}

Result<FileLock> FileLock::Acquire(const std::string& path, bool create, const std::function<std::string(const std::string& holder)>& when_held) {
  const int fd = create ? ::open(path.c_str(), O_WRONLY | O_CREAT | O_CLOEXEC, 0666) : ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd < 0) return Status::Error(path + ": cannot open to lock it: " + std::strerror(errno));
  if (::flock(fd, LOCK_EX | LOCK_NB) == 0) return FileLock(fd);
  const int error = errno;
  ::close(fd);
  if (error != EWOULDBLOCK) return Status::Error(path + ": cannot lock it: " + std::strerror(error));
  std::string holder = FileLockHolder(path);
  if (holder.empty()) holder = "a process this one cannot see";
  if (when_held) return Status::Error(when_held(holder));
  return Status::Error(path + ": another writer has it open (" + holder + "); one writer per design file");
}

std::string FileLockHolder(const std::string& path) {
  struct stat st;
  if (::stat(path.c_str(), &st) != 0) return "";
  // /proc/locks: "1: FLOCK  ADVISORY  WRITE 1234 08:01:5678 0 EOF" (pid, major:minor:inode in hex:hex:dec).
  std::ifstream locks("/proc/locks");
  std::string line;
  long pid = -1;
  while (std::getline(locks, line)) {
    std::istringstream in(line);
    std::string number, kind, mode, access, device;
    long p = 0;
    if (!(in >> number >> kind)) continue;
    if (kind == "->") in >> kind;  // a waiter, listed under the lock it waits for
    if (!(in >> mode >> access >> p >> device) || kind != "FLOCK" || p <= 0) continue;
    unsigned major_id = 0, minor_id = 0;
    unsigned long inode = 0;
    if (std::sscanf(device.c_str(), "%x:%x:%lu", &major_id, &minor_id, &inode) != 3 || inode != st.st_ino) continue;
    pid = p;
    if (major_id == major(st.st_dev) && minor_id == minor(st.st_dev)) break;  // an exact match beats an inode match elsewhere
  }
  if (pid <= 0) return "";
  std::ifstream cmdline("/proc/" + std::to_string(pid) + "/cmdline", std::ios::binary);
  std::string args((std::istreambuf_iterator<char>(cmdline)), std::istreambuf_iterator<char>());
  for (char& c : args)
    if (c == '\0') c = ' ';
  while (!args.empty() && args.back() == ' ') args.pop_back();
  return "process " + std::to_string(pid) + (args.empty() ? "" : ": " + args);
}

}  // namespace kgd
