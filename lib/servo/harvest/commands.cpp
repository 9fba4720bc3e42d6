#include "servo/harvest/commands.hpp"

#include "runtime/clock.hpp"
#include "servo/geometry.hpp"

namespace harvest::servo {

namespace {
LimitsConfig limits_of(const ServoConfig& c) {
  return {c.max_linear_speed, c.max_angular_speed, c.max_linear_accel, c.max_angular_accel, c.validity_s};
}
}  // namespace

CommandBuilder::CommandBuilder(const ServoConfig& c)
    : validity_s_(c.validity_s),
      max_linear_speed_(c.max_linear_speed),
      max_angular_speed_(c.max_angular_speed),
      tick_period_s_(c.tick_period_s),
      limiter_(limits_of(c), c.workspace) {}

robot_command_t CommandBuilder::command(const CommandStamp& stamp, int8_t type) const {
  robot_command_t c{};
  c.header.utime = stamp.utime;
  c.header.source_seq = stamp.seq;
  c.header.frame_id = "base";
  c.type = type;
  c.validity_us = rt::from_seconds(validity_s_);
  c.pose_goal.orientation[0] = 1.0;
  c.num_joints = 0;
  c.max_linear_speed = max_linear_speed_;
  c.max_angular_speed = max_angular_speed_;
  c.goal_id = stamp.goal_id;
  return c;
}

robot_command_t CommandBuilder::pose_goal(const CommandStamp& stamp, const Eigen::Isometry3d& goal) const {
  robot_command_t c = command(stamp, robot_command_t::TYPE_POSE_GOAL);
  c.pose_goal = to_pose(goal);
  return c;
}

robot_command_t CommandBuilder::twist(const CommandStamp& stamp, const Twist& desired,
                                      const Eigen::Vector3d& tool_position) {
  const Twist t = limiter_.apply(desired, tool_position, tick_period_s_);
  robot_command_t c = command(stamp, robot_command_t::TYPE_TWIST);
  c.twist = to_twist(t.linear, t.angular);
  return c;
}

gripper_command_t CommandBuilder::gripper(int64_t utime, int8_t action) {
  gripper_command_t g{};
  g.header.utime = utime;
  g.header.source_seq = -1;
  g.header.frame_id = "gripper";
  g.action = action;
  g.position = action == gripper_command_t::ACTION_OPEN ? 1.0f : 0.0f;
  g.force_n = 0.0f;
  return g;
}

}  // namespace harvest::servo
