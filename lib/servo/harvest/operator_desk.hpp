// The operator's and the emergency stop's say over the harvest: an operator command accepted or refused (the
// state's rules in safety.hpp, with the sender named for harvest-operator), the pause (the timeouts stand still
// while it lasts), the e-stop latched until its own clear, and the words HARVEST_STATUS gives each. The machine
// does what they ask (start, stop the arm, abort the fruit, go home, the state entered).
#pragma once

#include <string>

#include "harvest/emergency_stop_t.hpp"
#include "harvest/operator_command_t.hpp"
#include "runtime/clock.hpp"
#include "servo/harvest/states.hpp"

namespace harvest::servo {

class OperatorDesk {
 public:
  bool paused() const { return paused_; }
  bool estop() const { return estop_; }
  // A fault ends a pause (a fault is left only by RESET_FAULT, never by RESUME).
  void unpause() { paused_ = false; }

  struct Order {
    enum class Do { kRefused, kStart, kPause, kResume, kAbort, kHome, kResetFault } what = Do::kRefused;
    std::string note;           // for HARVEST_STATUS (kRefused: why, and from whom; worth logging)
    rt::Micros paused_for = 0;  // kResume: how long the timeouts stood still
  };
  // OPERATOR_COMMAND `msg` in `state`; `robot_fresh`: a robot state within timeouts.robot_state.
  Order command(const operator_command_t& msg, State state, bool robot_fresh, rt::Micros now);

  struct Stop {
    enum class Do {
      kNothing,  // a clear with nothing latched
      kHold,     // engaged again while latched: STOP again, nothing else
      kEngage,   // latched now: STOP at once, the fruit aborted, ESTOP
      kClear,    // released: IDLE
    } what = Do::kNothing;
    std::string note;  // kEngage, kClear: for HARVEST_STATUS and the log
  };
  Stop on_estop(const emergency_stop_t& msg);

 private:
  bool paused_ = false;
  bool estop_ = false;
  rt::Micros paused_at_ = 0;
};

}  // namespace harvest::servo
