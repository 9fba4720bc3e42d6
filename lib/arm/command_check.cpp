#include "arm/command_check.hpp"

#include <fmt/format.h>

#include <cmath>

#include "kinematics/diff_ik.hpp"

namespace harvest::arm {
namespace {

using harvest::robot_command_t;

Eigen::Vector3d goal_position(const robot_command_t& cmd) {
  const auto& p = cmd.pose_goal.position;
  return {p[0], p[1], p[2]};
}

Eigen::Quaterniond goal_orientation(const robot_command_t& cmd) {
  const auto& o = cmd.pose_goal.orientation;
  return {o[0], o[1], o[2], o[3]};
}

// A twist beyond non_physical_factor x the limits is garbage: refused rather
// than clipped and obeyed at full speed.
std::string twist_problem(const RobotLinkConfig& config, const robot_command_t& cmd) {
  const CommandLimits& c = config.command_limits;
  const Eigen::Vector3d v(cmd.twist.linear[0], cmd.twist.linear[1], cmd.twist.linear[2]);
  const Eigen::Vector3d w(cmd.twist.angular[0], cmd.twist.angular[1], cmd.twist.angular[2]);
  if (!v.allFinite() || !w.allFinite()) return "twist is not finite";
  if (v.norm() > c.non_physical_factor * config.limits.linear_speed ||
      w.norm() > c.non_physical_factor * config.limits.angular_speed)
    return fmt::format(
        "twist of {:.4g} m/s, {:.4g} rad/s is not physical: more than {:g}x the limits ({:g} m/s, {:g} rad/s; "
        "limits.non_physical_factor)",
        v.norm(), w.norm(), c.non_physical_factor, config.limits.linear_speed, config.limits.angular_speed);
  return {};
}

// Below the minimum goal speeds a goal would take forever (and its dry run with it).
std::string pose_goal_problem(const RobotLinkConfig& config, const robot_command_t& cmd) {
  const Eigen::Vector3d pos = goal_position(cmd);
  const Eigen::Quaterniond q = goal_orientation(cmd);
  if (!pos.allFinite() || !q.coeffs().allFinite() || std::abs(q.norm() - 1.0) > 1e-3)
    return "pose goal is not a position and a unit quaternion";
  if (!config.workspace.contains(pos)) return "pose goal outside the workspace";
  const CommandLimits& c = config.command_limits;
  const double vmax = cmd.max_linear_speed, wmax = cmd.max_angular_speed;
  if (!std::isfinite(vmax) || vmax < 0.0 || !std::isfinite(wmax) || wmax < 0.0)
    return "max_linear_speed and max_angular_speed must be 0 (the link's limits) or a positive speed";
  if (vmax > 0.0 && vmax < c.min_goal_linear_speed)
    return fmt::format("max_linear_speed {:g} m/s is below the minimum {:g} m/s (limits.min_goal_linear_speed)", vmax,
                       c.min_goal_linear_speed);
  if (wmax > 0.0 && wmax < c.min_goal_angular_speed)
    return fmt::format("max_angular_speed {:g} rad/s is below the minimum {:g} rad/s (limits.min_goal_angular_speed)",
                       wmax, c.min_goal_angular_speed);
  return {};
}

std::string joint_goal_problem(const RobotLinkConfig& config, const robot_command_t& cmd) {
  if (cmd.num_joints != config.model.dof()) return "joint goal has " + std::to_string(cmd.num_joints) + " joints";
  const Eigen::VectorXd goal = joint_goal_of(cmd);
  if (!goal.allFinite() || !config.model.within_limits(goal)) return "joint goal outside joint limits";
  if (!config.workspace.contains(kinematics::tool_pose(config.model, goal).translation()))
    return "joint goal puts the tool outside the workspace";
  return {};
}

}  // namespace

std::string command_problem(const RobotLinkConfig& config, const robot_command_t& cmd) {
  switch (cmd.type) {
    case robot_command_t::TYPE_STOP:
      return {};
    case robot_command_t::TYPE_TWIST:
      return twist_problem(config, cmd);
    case robot_command_t::TYPE_POSE_GOAL:
      return pose_goal_problem(config, cmd);
    case robot_command_t::TYPE_JOINT_GOAL:
      return joint_goal_problem(config, cmd);
    default:
      return "unknown command type " + std::to_string(cmd.type);
  }
}

kinematics::Twist twist_of(const robot_command_t& cmd) {
  kinematics::Twist v;
  v << cmd.twist.linear[0], cmd.twist.linear[1], cmd.twist.linear[2], cmd.twist.angular[0], cmd.twist.angular[1],
      cmd.twist.angular[2];
  return v;
}

Eigen::Isometry3d pose_goal_of(const robot_command_t& cmd) {
  Eigen::Isometry3d goal = Eigen::Isometry3d::Identity();
  goal.translation() = goal_position(cmd);
  goal.linear() = goal_orientation(cmd).normalized().toRotationMatrix();
  return goal;
}

Eigen::VectorXd joint_goal_of(const robot_command_t& cmd) {
  return Eigen::Map<const Eigen::VectorXd>(cmd.joint_goal.data(), static_cast<Eigen::Index>(cmd.joint_goal.size()));
}

}  // namespace harvest::arm
