#include "runtime/clock.hpp"

#include <chrono>

namespace harvest::rt {

Micros wall_time_now() {
  return std::chrono::duration_cast<std::chrono::microseconds>(
             std::chrono::system_clock::now().time_since_epoch())
      .count();
}

Micros SystemClock::now() const { return wall_time_now(); }

}  // namespace harvest::rt
