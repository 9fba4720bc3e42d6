#include "servo/harvest/operator_desk.hpp"

#include "servo/harvest/safety.hpp"

namespace harvest::servo {

OperatorDesk::Order OperatorDesk::command(const operator_command_t& msg, State state, bool robot_fresh,
                                          rt::Micros now) {
  using Do = Order::Do;
  const std::string who = msg.source.empty() ? "operator" : msg.source;
  if (const auto refused = refusal(msg.command, {state, paused_, estop_, robot_fresh}))
    return {Do::kRefused, "command refused: " + *refused + " (from " + who + ")"};  // harvest-operator reads the sender
  switch (msg.command) {
    case operator_command_t::START:
      return {Do::kStart, "started by " + who};
    case operator_command_t::PAUSE:
      paused_ = true;
      paused_at_ = now;
      return {Do::kPause, "paused by " + who};
    case operator_command_t::RESUME:
      paused_ = false;
      return {Do::kResume, "resumed by " + who, now - paused_at_};
    case operator_command_t::ABORT:
      paused_ = false;
      return {Do::kAbort, "aborted by " + who};
    case operator_command_t::HOME:
      paused_ = false;
      return {Do::kHome, "homing (" + who + ")"};
    default:  // RESET_FAULT (refusal() refuses unknown commands)
      return {Do::kResetFault, "fault reset by " + who};
  }
}

OperatorDesk::Stop OperatorDesk::on_estop(const emergency_stop_t& msg) {
  if (msg.engaged) {
    if (estop_) return {Stop::Do::kHold, ""};
    estop_ = true;
    paused_ = false;
    return {Stop::Do::kEngage, "EMERGENCY STOP from " + msg.source + (msg.reason.empty() ? "" : ": " + msg.reason)};
  }
  if (msg.clear && estop_) {
    estop_ = false;
    return {Stop::Do::kClear, "emergency stop cleared by " + msg.source};
  }
  return {};
}

}  // namespace harvest::servo
