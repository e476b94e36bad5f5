// Child processes for the tests and benchmarks that run the real programs (kgd-server, kgd-worker, kgd),
// and a free loopback port for them to listen on.
#pragma once

#include <arpa/inet.h>
#include <fcntl.h>
#include <netinet/in.h>
#include <signal.h>
#include <sys/socket.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <fstream>
#include <functional>
#include <iterator>
#include <string>
#include <thread>
#include <utility>
#include <vector>

namespace kgd::test_support {

// A child process with its output in a log file.
struct Process {  // killed (SIGKILL) and reaped when destroyed if still running
  pid_t pid = -1;
  std::string log;
  static Process Spawn(const std::vector<std::string>& args, const std::string& log_path) {
    Process p;
    p.log = log_path;
    p.pid = fork();
    if (p.pid == 0) {
      const int fd = open(log_path.c_str(), O_WRONLY | O_CREAT | O_APPEND, 0644);
      dup2(fd, 1);
      dup2(fd, 2);
      std::vector<char*> argv;
      for (const std::string& a : args) argv.push_back(const_cast<char*>(a.c_str()));
      argv.push_back(nullptr);
      execv(argv[0], argv.data());
      _exit(127);
    }
    return p;
  }
  void Signal(int sig) const {
    if (pid > 0) kill(pid, sig);
  }
  int Wait() {
    int status = 0;
    if (pid > 0) waitpid(pid, &status, 0);
    pid = -1;
    return status;
  }
  ~Process() {
    if (pid > 0) {
      kill(pid, SIGKILL);
      Wait();
    }
  }
  Process() = default;
  Process(Process&& o) noexcept : pid(o.pid), log(std::move(o.log)) { o.pid = -1; }
  Process& operator=(Process&& o) noexcept {
    std::swap(pid, o.pid);
    std::swap(log, o.log);
    return *this;
  }
};

inline int FreePort() {
  const int s = socket(AF_INET, SOCK_STREAM, 0);
  sockaddr_in a{};
  a.sin_family = AF_INET;
  a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  bind(s, reinterpret_cast<sockaddr*>(&a), sizeof a);
  socklen_t len = sizeof a;
  getsockname(s, reinterpret_cast<sockaddr*>(&a), &len);
  close(s);
  return ntohs(a.sin_port);
}

// Polls `done` every 20 ms until it holds or `timeout_s` has passed; its last answer.
inline bool WaitFor(const std::function<bool()>& done, double timeout_s) {
  const auto end = std::chrono::steady_clock::now() + std::chrono::duration<double>(timeout_s);
  while (std::chrono::steady_clock::now() < end) {
    if (done()) return true;
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  return done();
}

// A text file's contents (a log), empty when it cannot be read.
inline std::string ReadText(const std::string& path) {
  std::ifstream in(path);
  return std::string(std::istreambuf_iterator<char>(in), {});
}

}  // namespace kgd::test_support
