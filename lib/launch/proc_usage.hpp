// CPU time and resident memory of one process, from /proc (a deputy's
// status). Only the process itself: a child it forked is not counted.
#pragma once

#include <sys/types.h>

#include <cstdint>
#include <filesystem>

namespace harvest::launch {

struct ProcUsage {
  int64_t cpu_ticks = -1;  // utime + stime, clock ticks; -1: no such process
  int64_t rss_bytes = -1;
};

ProcUsage read_proc_usage(pid_t pid, const std::filesystem::path& proc = "/proc");
// Clock ticks per second (sysconf(_SC_CLK_TCK)).
double ticks_per_second();
// Share of one core used between two readings taken `seconds` apart, in %;
// -1 when either reading is missing or the interval is empty.
double cpu_percent(const ProcUsage& before, const ProcUsage& after, double seconds);

}  // namespace harvest::launch
