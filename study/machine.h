// The one description of the machine a figure was measured on, for every generated table: the date
// (UTC), the CPU's model name and its core count, as `kgd machine` prints it and the study's report
// and the scripts of `make bench` and `make study` write it.
#pragma once

#include <string>

namespace kgd::study {

// "2026-11-27, AMD EPYC (family 25 model 17, AVX-512), 2 cores, 24 GiB": today's date (UTC),
// /proc/cpuinfo's first "model name" ("unknown CPU" without one), its family and model (which tell apart
// machines of one model name) and widest vector instruction set, the threads the hardware runs at once
// and the memory (/proc/meminfo).
std::string MachineLine();

}  // namespace kgd::study
