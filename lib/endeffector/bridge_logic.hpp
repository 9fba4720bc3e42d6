// The pure parts of the bridge: gripper commands -> board frames (limits and
// the emergency-stop latch), board telemetry -> bus messages, and the
// reconnect back-off. No I/O, no clock: the node passes time in.
#pragma once

#include <optional>
#include <string>

#include "endeffector/ir_calibration.hpp"
#include "endeffector/protocol.hpp"
#include "harvest/emergency_stop_t.hpp"
#include "harvest/gripper_command_t.hpp"
#include "harvest/gripper_state_t.hpp"
#include "harvest/ir_range_t.hpp"
#include "runtime/clock.hpp"

namespace harvest::endeffector {

// Validates gripper commands and holds the emergency-stop latch.
class CommandGate {
 public:
  explicit CommandGate(double max_force_n) : max_force_n_(max_force_n) {}

  struct Decision {
    std::optional<Message> frame;  // what to send, if accepted
    std::string rejection;         // why not, if rejected
  };
  Decision on_command(const gripper_command_t& cmd) const;
  // Returns the frame to send at once (Stop) when the stop engages.
  std::optional<Message> on_emergency_stop(const emergency_stop_t& msg);
  bool stopped() const { return stopped_; }

 private:
  double max_force_n_;
  bool stopped_ = false;
};

// Telemetry -> messages (header.utime = receipt time; the board has no clock of ours).
ir_range_t make_ir_range(int32_t raw, const IrCurve& curve, rt::Micros now);
ir_range_t make_ir_no_data(rt::Micros now);
gripper_state_t make_gripper_state(const Grip& grip, int32_t fault_code, const std::string& fault_text, rt::Micros now);
gripper_state_t make_gripper_disconnected(double last_position, const std::string& why, rt::Micros now);

// Exponential back-off: initial, 2x per failure, capped; reset after a good link.
class Backoff {
 public:
  Backoff(rt::Micros initial, rt::Micros max) : initial_(initial), max_(max), next_(initial) {}
  rt::Micros next() {
    const rt::Micros d = next_;
    next_ = std::min(max_, next_ * 2);
    return d;
  }
  void reset() { next_ = initial_; }

 private:
  rt::Micros initial_, max_, next_;
};

}  // namespace harvest::endeffector
