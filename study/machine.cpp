#include "study/machine.h"

#include <cmath>
#include <ctime>
#include <fstream>
#include <sstream>
#include <thread>

namespace kgd::study {
namespace {

// The value of /proc/cpuinfo's first line starting with `key` ("" without one).
std::string CpuInfoValue(const std::string& text, const std::string& key) {
  std::istringstream in(text);
  for (std::string line; std::getline(in, line);) {
    const std::size_t colon = line.find(':');
    if (colon == std::string::npos || line.rfind(key, 0) != 0) continue;
    std::string name = line.substr(0, colon);
    name.erase(name.find_last_not_of(" \t") + 1);
    if (name != key) continue;
    std::string value = line.substr(colon + 1);
    value.erase(0, value.find_first_not_of(" \t"));
    return value;
  }
  return "";
}

}  // namespace

std::string MachineLine() {
  std::ifstream info("/proc/cpuinfo");
  const std::string text((std::istreambuf_iterator<char>(info)), std::istreambuf_iterator<char>());
  std::string cpu = CpuInfoValue(text, "model name");
  if (cpu.empty()) cpu = "unknown CPU";
  const std::string family = CpuInfoValue(text, "cpu family"), model = CpuInfoValue(text, "model");
  const std::string flags = " " + CpuInfoValue(text, "flags") + " ";
  const char* level = flags.find(" avx512f ") != std::string::npos ? "AVX-512"
                      : flags.find(" avx2 ") != std::string::npos  ? "AVX2"
                      : flags.find(" avx ") != std::string::npos   ? "AVX"
                                                                   : "SSE";
  std::string detail;
  if (!family.empty() && !model.empty()) detail = "family " + family + " model " + model + ", ";
  detail += level;
  std::ifstream meminfo("/proc/meminfo");
  std::string memory;
  for (std::string key; meminfo >> key;) {
    if (key == "MemTotal:") {
      double kib = 0;
      if (meminfo >> kib) memory = ", " + std::to_string(std::lround(kib / (1024.0 * 1024.0))) + " GiB";
      break;
    }
    meminfo.ignore(1 << 10, '\n');
  }
  char date[32];
  const std::time_t now = std::time(nullptr);
  std::strftime(date, sizeof date, "%Y-%m-%d", std::gmtime(&now));
  return std::string(date) + ", " + cpu + " (" + detail + "), " + std::to_string(std::thread::hardware_concurrency()) +
         " cores" + memory;
}

}  // namespace kgd::study
