// The one description of the machine a figure was measured on, for every generated table: the date
// (UTC), the CPU's model name and its core count, as `kgd machine` prints it and the study's report
// and the scripts of `make bench` and `make study` write it.
#pragma once

#include <string>

namespace kgd::study {

// "2026-11-26, AMD EPYC 7B13, 2 cores": today's date (UTC), /proc/cpuinfo's first "model name"
// ("unknown CPU" without one) and the threads the hardware runs at once.
std::string MachineLine();

}  // namespace kgd::study
