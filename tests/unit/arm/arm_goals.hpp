// Pose goals the arm tests share.
#pragma once

#include <Eigen/Geometry>
#include <cmath>

#include "arm/robot_link_config.hpp"
#include "arm/trajectory.hpp"

namespace harvest::arm {

// The servo controller's ORIENT goal (servo::aim_rotation, thesis eq.
// 6-19..6-22, restated here so the arm tests need not link the servo
// library): the tool kept where it is, its z axis (the gripper's approach
// axis) turned toward `target`, first about tool x, then about the new y.
inline Eigen::Isometry3d aim_goal(const Eigen::Isometry3d& tool, const Eigen::Vector3d& target) {
  const auto rx = [](double a) {
    Eigen::Matrix3d r;
    r << 1, 0, 0, 0, std::cos(a), std::sin(a), 0, -std::sin(a), std::cos(a);
    return r;
  };
  const auto ry = [](double b) {
    Eigen::Matrix3d r;
    r << std::cos(b), 0, -std::sin(b), 0, 1, 0, std::sin(b), 0, std::cos(b);
    return r;
  };
  const Eigen::Matrix3d rf = tool.rotation();
  const Eigen::Vector3d m = rf.transpose() * (target - tool.translation());
  const double alpha = std::atan2(m.y(), m.z());
  const Eigen::Vector3d m1 = rx(alpha).transpose() * m;
  const double beta = -std::atan2(m1.x(), m1.z());
  Eigen::Isometry3d goal = tool;
  goal.linear() = rf * rx(alpha) * ry(beta);
  return goal;
}

// A pose goal's path limits when the command asks for none: the envelope's.
inline CartesianTrajectory::Limits goal_limits(const RobotLinkConfig& c) {
  return {c.limits.linear_speed, c.limits.angular_speed, c.limits.linear_acceleration, c.limits.angular_acceleration};
}

}  // namespace harvest::arm
