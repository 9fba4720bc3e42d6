#include "runtime/realtime.hpp"

#include <sched.h>
#include <spdlog/spdlog.h>

#include <cerrno>
#include <cstring>

namespace harvest::rt {

void request_realtime_priority(int priority, const std::string& consequence) {
  if (priority <= 0) return;
  sched_param p{};
  p.sched_priority = priority;
  if (::sched_setscheduler(0, SCHED_FIFO, &p) == 0)
    spdlog::info("control loop at SCHED_FIFO priority {}", priority);
  else
    spdlog::warn("control loop at normal priority: SCHED_FIFO {} refused ({}); {}", priority, std::strerror(errno),
                 consequence);
}

}  // namespace harvest::rt
