// Time that counts against a peer's silence: the wall clock with this
// process's own stalls taken out. A watchdog (no PDO from a drive, no RPDO
// from the master) must not blame the peer for time this process itself
// spent not running: a host that froze the whole machine for 100 ms (a
// virtual machine's CPU quota, seen on the 2-core test machine) stops both
// ends, and on waking each would find the other silent. A step between two
// readings longer than `longest_step` is such a stall; only `longest_step`
// of it counts. A peer that is silent while this process runs is still seen
// after the same awake time; a run of stalls stretches the wall time to it
// by at most step / longest_step (docs/can.md "Own stalls").
#pragma once

#include <algorithm>
#include <cstdint>

namespace harvest::rt {

class AwakeClock {
 public:
  // longest_step <= 0: off, awake time is wall time.
  explicit AwakeClock(int64_t longest_step_us = 0) : longest_step_(longest_step_us) {}

  // Awake time at wall time `now` [us]; same epoch as `now`, never decreasing.
  int64_t at(int64_t now) {
    if (have_last_ && longest_step_ > 0 && now - last_ > longest_step_) {
      const int64_t lost = now - last_ - longest_step_;
      lost_ += lost;
      longest_lost_ = std::max(longest_lost_, lost);
      ++stalls_;
    }
    if (!have_last_ || now > last_) last_ = now;
    have_last_ = true;
    awake_ = std::max(awake_, now - lost_);
    return awake_;
  }

  int64_t longest_step() const { return longest_step_; }
  int64_t stalls() const { return stalls_; }              // steps longer than longest_step
  int64_t lost_us() const { return lost_; }               // wall time not counted, in all
  int64_t longest_lost_us() const { return longest_lost_; }

 private:
  int64_t longest_step_;
  int64_t last_ = 0;
  bool have_last_ = false;
  int64_t awake_ = INT64_MIN;
  int64_t lost_ = 0;
  int64_t longest_lost_ = 0;
  int64_t stalls_ = 0;
};

}  // namespace harvest::rt
