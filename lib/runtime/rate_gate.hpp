// Keeps a stream at most `max_hz` messages a second (the recorder's reduced
// camera rate, the console's image feed). Slots are one period apart, so a
// 30 Hz stream kept at 5 Hz averages 5 Hz, not the 4.3 Hz that "at least
// one period since the last kept" would give; after a gap (or the first
// message) the slots start again from that message.
#pragma once

#include <cstdint>
#include <stdexcept>

namespace harvest::rt {

class RateGate {
 public:
  // max_hz <= 0: every message passes.
  explicit RateGate(double max_hz = 0) {
    if (max_hz < 0) throw std::invalid_argument("a rate limit must not be negative");
    period_us_ = max_hz > 0 ? static_cast<int64_t>(1e6 / max_hz) : 0;
  }

  // Whether the message at `utime` [us] is kept.
  bool admit(int64_t utime) {
    if (period_us_ == 0) return true;
    if (started_ && utime < next_due_) return false;
    next_due_ = !started_ || utime - next_due_ >= period_us_ ? utime + period_us_ : next_due_ + period_us_;
    started_ = true;
    return true;
  }

 private:
  int64_t period_us_ = 0;
  int64_t next_due_ = 0;
  bool started_ = false;
};

}  // namespace harvest::rt
