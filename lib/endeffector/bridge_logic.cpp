#include "endeffector/bridge_logic.hpp"

#include <cmath>

namespace harvest::endeffector {

CommandGate::Decision CommandGate::on_command(const gripper_command_t& cmd) const {
  if (stopped_) return {std::nullopt, "emergency stop engaged"};
  if (!std::isfinite(cmd.force_n) || cmd.force_n < 0 || cmd.force_n > max_force_n_)
    return {std::nullopt, "force_n " + std::to_string(cmd.force_n) + " outside [0, " + std::to_string(max_force_n_) + "]"};
  const auto force_mn = static_cast<int32_t>(std::lround(cmd.force_n * 1000.0));
  switch (cmd.action) {
    case gripper_command_t::ACTION_OPEN: return {Open{}, {}};
    case gripper_command_t::ACTION_CLOSE: return {Close{force_mn}, {}};
    case gripper_command_t::ACTION_STOP: return {Stop{}, {}};
    case gripper_command_t::ACTION_MOVE:
      if (!std::isfinite(cmd.position) || cmd.position < 0 || cmd.position > 1)
        return {std::nullopt, "position " + std::to_string(cmd.position) + " outside [0, 1]"};
      return {Move{static_cast<int32_t>(std::lround(cmd.position * 1000.0)), force_mn}, {}};
    default: return {std::nullopt, "unknown action " + std::to_string(cmd.action)};
  }
}

std::optional<Message> CommandGate::on_emergency_stop(const emergency_stop_t& msg) {
  if (msg.engaged) {
    stopped_ = true;
    return Stop{};  // sent on every engaged message: repeating a stop is harmless
  }
  if (msg.clear) stopped_ = false;
  return std::nullopt;
}

namespace {
header_t header_at(rt::Micros now) {
  header_t h;
  h.utime = now;
  h.frame_id = "gripper";
  h.source_seq = -1;
  return h;
}
}  // namespace

ir_range_t make_ir_range(int32_t raw, const IrCurve& curve, rt::Micros now) {
  ir_range_t m;
  m.header = header_at(now);
  const IrRange r = curve.evaluate(raw);
  m.raw = raw;
  m.range_m = static_cast<float>(r.distance_m);
  m.validity = static_cast<int8_t>(r.validity);
  return m;
}

ir_range_t make_ir_no_data(rt::Micros now) {
  ir_range_t m;
  m.header = header_at(now);
  m.raw = -1;
  m.range_m = 0;
  m.validity = ir_range_t::NO_DATA;
  return m;
}

gripper_state_t make_gripper_state(const Grip& grip, int32_t fault_code, const std::string& fault_text,
                                   rt::Micros now) {
  gripper_state_t m;
  m.header = header_at(now);
  switch (grip.state) {
    case GripState::kOpen: m.state = gripper_state_t::STATE_OPEN; break;
    case GripState::kClosing: m.state = gripper_state_t::STATE_CLOSING; break;
    case GripState::kClosed: m.state = gripper_state_t::STATE_CLOSED; break;
    case GripState::kHolding: m.state = gripper_state_t::STATE_HOLDING; break;
    case GripState::kOpening: m.state = gripper_state_t::STATE_OPENING; break;
    case GripState::kStopped: m.state = gripper_state_t::STATE_UNKNOWN; break;  // part-way; no closer bus state
    case GripState::kFault: m.state = gripper_state_t::STATE_FAULT; break;
  }
  m.position = static_cast<float>(grip.position_permille * 1e-3);
  m.force_n = static_cast<float>(grip.force_mn * 1e-3);
  m.connected = true;
  m.fault_code = fault_code;
  m.fault_text = fault_text;
  return m;
}

gripper_state_t make_gripper_disconnected(double last_position, const std::string& why, rt::Micros now) {
  gripper_state_t m;
  m.header = header_at(now);
  m.state = gripper_state_t::STATE_DISCONNECTED;
  m.position = static_cast<float>(last_position);
  m.force_n = 0;
  m.connected = false;
  m.fault_code = 0;
  m.fault_text = why;
  return m;
}

}  // namespace harvest::endeffector
