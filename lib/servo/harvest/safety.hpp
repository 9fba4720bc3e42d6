// What stops the harvest or is refused: faults reported by the robot link
// and the end-effector board, and operator commands that the controller's
// state does not allow (a latched e-stop or fault is left only by its own
// clear, never by START, HOME or RESUME).
#pragma once

#include <optional>
#include <string>

#include "harvest/fruit_detections_t.hpp"
#include "harvest/gripper_state_t.hpp"
#include "harvest/robot_state_t.hpp"
#include "harvest/targets_t.hpp"
#include "servo/harvest/states.hpp"

namespace harvest::servo {

// The fault a robot state reports while harvesting (fault, e-stop, drives disabled), if any.
std::optional<std::string> robot_fault(const robot_state_t& msg);
// The fault a gripper state reports (fault with its code and text, disconnected), if any.
std::optional<std::string> gripper_fault(const gripper_state_t& msg);

// Why a TARGETS message is not usable input (a NaN or infinite number where
// the controller computes with it), if it is not. Such a message is refused
// whole and counted, never taken for a fruit out of reach.
std::optional<std::string> invalid_targets(const targets_t& msg);
// ... and why a FRUIT_HAND message the detector calls OK is not: an image size of zero or less (the hand tracker
// measures shares of the image and its border by it) or a NaN or infinite pixel position, size or area.
std::optional<std::string> invalid_detections(const fruit_detections_t& msg);

struct CommandContext {
  State state = State::kIdle;
  bool paused = false;
  bool estop = false;        // an emergency stop is latched
  bool robot_fresh = false;  // a robot state within timeouts.robot_state
};
// Why operator command `command` (operator_command_t) is refused, if it is.
std::optional<std::string> refusal(int8_t command, const CommandContext& c);

}  // namespace harvest::servo
