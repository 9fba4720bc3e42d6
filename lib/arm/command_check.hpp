// What the robot link checks in a ROBOT_COMMAND before it obeys it (after
// the command authority has admitted it): well-formed, inside the joint
// limits and the workspace, physical, and not so slow that planning it would
// take forever. docs/robot-link.md lists the refusals.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <harvest/robot_command_t.hpp>
#include <string>

#include "arm/robot_link_config.hpp"
#include "kinematics/chain.hpp"

namespace harvest::arm {

// Why `cmd` is refused (the refusal's text), or empty if it may be obeyed.
// TYPE_STOP is always obeyed.
std::string command_problem(const RobotLinkConfig& config, const harvest::robot_command_t& cmd);

// The command's motion, once command_problem found nothing wrong.
kinematics::Twist twist_of(const harvest::robot_command_t& cmd);
Eigen::Isometry3d pose_goal_of(const harvest::robot_command_t& cmd);  // quaternion normalised
Eigen::VectorXd joint_goal_of(const harvest::robot_command_t& cmd);

}  // namespace harvest::arm
