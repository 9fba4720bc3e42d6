// At most one log line per interval for an event that can repeat at message
// rate (refused commands from a stray publisher, limits that come and go each
// control period): the caller counts every event and logs only those admit()
// lets through; the admitted line after a quiet spell says how many were not
// logged. Time comes from the node's clock, so replays log the same lines.
#pragma once

#include <cstdint>

#include "runtime/clock.hpp"

namespace harvest::rt {

class LogLimiter {
 public:
  explicit LogLimiter(Micros interval = kSecond) : interval_(interval) {}

  // True when this event should be logged. Then `suppressed` is the number of
  // events not logged since the last admitted one, and `since` the time since
  // it (0 for the first line).
  bool admit(Micros now, int64_t& suppressed, Micros& since) {
    if (logged_ && now - last_ < interval_) {
      ++suppressed_;
      return false;
    }
    suppressed = suppressed_;
    since = logged_ ? now - last_ : 0;
    suppressed_ = 0;
    last_ = now;
    logged_ = true;
    return true;
  }

 private:
  Micros interval_;
  Micros last_ = 0;
  bool logged_ = false;
  int64_t suppressed_ = 0;
};

}  // namespace harvest::rt
