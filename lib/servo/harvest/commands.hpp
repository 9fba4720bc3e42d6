// The controller's command messages: ROBOT_COMMAND (STOP, pose goal, twist
// through the limits) and GRIPPER_COMMAND. Every robot command carries the
// validity window, the speed limits for the robot link and the current
// goal id, and is stamped with the input it names (HarvestMachine::stamp: the
// newest TARGETS, before any the robot state).
#pragma once

#include <Eigen/Geometry>
#include <cstdint>

#include "harvest/gripper_command_t.hpp"
#include "harvest/robot_command_t.hpp"
#include "servo/motion_limits.hpp"
#include "servo/servo_config.hpp"

namespace harvest::servo {

// Where a command comes from: the input it names (header utime and
// source_seq; 0 and -1 before any) and the goal id in force.
struct CommandStamp {
  int64_t utime = 0;
  int64_t seq = -1;
  int64_t goal_id = 0;
};

class CommandBuilder {
 public:
  explicit CommandBuilder(const ServoConfig& config);

  robot_command_t stop(const CommandStamp& stamp) const { return command(stamp, robot_command_t::TYPE_STOP); }
  robot_command_t pose_goal(const CommandStamp& stamp, const Eigen::Isometry3d& goal) const;
  // `desired` limited in speed, in acceleration against the previous twist
  // (dt = tick period) and to the workspace around `tool_position`.
  robot_command_t twist(const CommandStamp& stamp, const Twist& desired, const Eigen::Vector3d& tool_position);
  // The next twist ramps up from rest (after a pose goal, a stop or a pause).
  void ramp_from_rest() { limiter_.reset(); }
  int64_t workspace_clips() const { return limiter_.workspace_clips(); }

  // OPEN (position 1) or CLOSE (position 0) at the gripper's own force.
  static gripper_command_t gripper(int64_t utime, int8_t action);

 private:
  robot_command_t command(const CommandStamp& stamp, int8_t type) const;
  double validity_s_, max_linear_speed_, max_angular_speed_, tick_period_s_;
  TwistLimiter limiter_;
};

}  // namespace harvest::servo
