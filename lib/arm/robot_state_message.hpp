// ROBOT_STATE as the robot link publishes it each SYNC period: the arm's
// mode (one word for lcm-spy and the controller), joints, tool pose and
// twist, the drives' states and the fault flags and text.
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <harvest/robot_state_t.hpp>
#include <string>
#include <vector>

#include "arm/motion_safety.hpp"
#include "canopen/master.hpp"
#include "kinematics/arm_model.hpp"

namespace harvest::arm {

// What the link knows in a period besides the drives.
struct LinkSnapshot {
  Micros sampled = 0;  // the SYNC the drives' TPDOs answer
  int64_t last_command_seq = -1;
  Eigen::VectorXd q, qd, cmd;  // joints, their velocities, this period's command
  bool drives_enabled = false;
  bool shutting_down = false;
  bool has_motion = false;     // a motion is active (not NoMotion)
  bool limited = false;        // this period's command was limited
  bool joint_limited = false;  // ... a joint braking for (or held at) its position limit among the reasons
  bool refused = false;        // the last command was refused
  bool enable_timed_out = false;
  int32_t limit_events = 0;
  std::string limit_text;
  int32_t hardware_flags = 0;  // ArmHardware::fault_flags()
};

// The mode robot_state_t.mode reports: e-stop and fault first, then
// disabled (at shutdown), enabling, moving (a fresh command's motion),
// stopping (moving without one), idle.
int8_t robot_mode(const MotionSupervisor& supervisor, const LinkSnapshot& link, bool fresh);

harvest::robot_state_t robot_state_message(const kinematics::ArmModel& model, const MotionSupervisor& supervisor,
                                           const std::vector<canopen::DriveStatus>& drives, const LinkSnapshot& link,
                                           Micros now);

}  // namespace harvest::arm
