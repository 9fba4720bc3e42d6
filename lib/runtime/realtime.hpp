// Real-time scheduling for a process whose loop has a hard deadline (the
// robot link: the drives quick-stop when its RPDOs stop for 25 ms).
#pragma once

#include <string>

namespace harvest::rt {

// Puts the calling process under SCHED_FIFO at `priority` (1..99; 0 leaves
// normal scheduling). Needs root or CAP_SYS_NICE; refused, it logs a warning
// naming `consequence` and the process goes on at normal priority.
void request_realtime_priority(int priority, const std::string& consequence);

}  // namespace harvest::rt
