#include "servo/harvest/safety.hpp"

#include <algorithm>
#include <cmath>
#include <iterator>

#include "harvest/operator_command_t.hpp"

namespace harvest::servo {

std::optional<std::string> robot_fault(const robot_state_t& msg) {
  switch (msg.mode) {
    case robot_state_t::MODE_FAULT:
      return "robot fault: " + (msg.fault_text.empty() ? std::string("(no text)") : msg.fault_text);
    case robot_state_t::MODE_ESTOP:
      return "robot reports emergency stop";
    case robot_state_t::MODE_DISABLED:
      return "robot drives disabled";
    default:
      return std::nullopt;
  }
}

std::optional<std::string> gripper_fault(const gripper_state_t& msg) {
  if (msg.state == gripper_state_t::STATE_FAULT)
    return "gripper fault " + std::to_string(msg.fault_code) + ": " + msg.fault_text;
  if (msg.state == gripper_state_t::STATE_DISCONNECTED || !msg.connected) return "gripper disconnected";
  return std::nullopt;
}

std::optional<std::string> refusal(int8_t command, const CommandContext& c) {
  using C = operator_command_t;
  const bool running = spec(c.state).running;
  switch (command) {
    case C::START:
    case C::HOME:
      if (c.estop) return "emergency stop latched";
      if (c.state == State::kFault) return "fault latched, send RESET_FAULT";
      if (command == C::START && running) return "already running";
      if (!c.robot_fresh) return "no robot state";
      return std::nullopt;
    case C::PAUSE:
      if (!running || c.paused) return "nothing to pause";
      return std::nullopt;
    case C::RESUME:
      if (!c.paused) return "not paused";
      return std::nullopt;
    case C::ABORT:
      return std::nullopt;  // accepted in every state (it never releases a latched e-stop or fault)
    case C::RESET_FAULT:
      if (c.state != State::kFault) return "no fault to reset";
      return std::nullopt;
    default:
      return "unknown command " + std::to_string(command);
  }
}

std::optional<std::string> invalid_targets(const targets_t& msg) {
  auto finite = [](const auto& values) {
    return std::all_of(std::begin(values), std::end(values), [](double v) { return std::isfinite(v); });
  };
  if (msg.camera_known && !finite(msg.camera_position_base)) return "camera_position_base is not finite";
  for (std::size_t i = 0; i < msg.targets.size(); ++i) {
    const target_t& t = msg.targets[i];
    const std::string which = "target " + std::to_string(i) + " (fruit " + std::to_string(t.fruit_id) + ")";
    if (!finite(t.position_base)) return which + ": position_base is not finite";
    if (!finite(t.position_camera)) return which + ": position_camera is not finite";
    if (!finite(t.covariance_base)) return which + ": covariance_base is not finite";
    const double scalars[] = {t.depth_m, t.diameter_m, t.u_px, t.v_px, t.diameter_px, t.confidence, t.cost};
    if (!finite(scalars)) return which + ": depth, diameter, pixel position, confidence or cost is not finite";
  }
  return std::nullopt;
}

std::optional<std::string> invalid_detections(const fruit_detections_t& msg) {
  if (msg.image_width <= 0 || msg.image_height <= 0)
    return "image size " + std::to_string(msg.image_width) + " x " + std::to_string(msg.image_height);
  for (std::size_t i = 0; i < msg.fruits.size(); ++i) {
    const fruit_t& f = msg.fruits[i];
    const float values[] = {f.u_px, f.v_px, f.diameter_px, f.area_px};
    if (!std::all_of(std::begin(values), std::end(values), [](float v) { return std::isfinite(v); }))
      return "fruit " + std::to_string(i) + ": pixel position, diameter or area is not finite";
  }
  return std::nullopt;
}

}  // namespace harvest::servo
