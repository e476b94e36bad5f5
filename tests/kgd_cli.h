// Runs the real `kgd` binary as a user would, for the integration tests that go through the CLI.
#pragma once

#include <sys/wait.h>

#include <array>
#include <cstdio>
#include <string>

namespace kgd::cli_test {

struct CommandRun {
  int exit_code;       // the process's exit status; 128 + signal if it was killed
  std::string output;  // stdout and stderr, interleaved
};

inline CommandRun Kgd(const std::string& args) {
  const std::string cmd = std::string(KGD_BINARY) + " " + args + " 2>&1";
  FILE* p = popen(cmd.c_str(), "r");
  std::string out;
  std::array<char, 4096> buf;
  while (size_t n = fread(buf.data(), 1, buf.size(), p)) out.append(buf.data(), n);
  const int status = pclose(p);
  return {WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status), out};
}

}  // namespace kgd::cli_test
