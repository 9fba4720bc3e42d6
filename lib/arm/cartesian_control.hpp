// The robot link's Cartesian control law, one SYNC period at a time: what the
// live loop runs for twists and pose goals and what the pose-goal dry run
// simulates (so the dry run predicts the loop exactly).
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "arm/motion_safety.hpp"
#include "arm/robot_link_config.hpp"
#include "arm/trajectory.hpp"
#include "kinematics/diff_ik.hpp"

namespace harvest::arm {

// One SYNC period of the Cartesian control law: the requested tool twist `v`
// clipped to the speed limits and the workspace (clip_twist), mapped to joint
// velocities by the DLS IK with joint-limit locking
// (joint_velocity_within_limits), then limited per joint from the previous
// command (limit_joint_velocity: speed, acceleration, stopping distance).
struct CartesianStep {
  Eigen::VectorXd qdot;           // the joint velocity command [rad/s]
  ClippedTwist clip;              // the twist after clipping, and why it was clipped
  bool position_clipped = false;  // a joint was slowed at its position limit
};
CartesianStep cartesian_step(const RobotLinkConfig& config, const Eigen::VectorXd& q, const Eigen::Isometry3d& tool,
                             const kinematics::Twist& v, const Eigen::VectorXd& previous, double dt);

// The pose-goal law at time `t` of its trajectory: the feed-forward twist plus
// the position and orientation gains on the error from `q`'s tool pose to the
// reference pose, through cartesian_step.
CartesianStep pose_goal_step(const RobotLinkConfig& config, const CartesianTrajectory& trajectory, double t,
                             const Eigen::VectorXd& q, const Eigen::VectorXd& previous, double dt);

}  // namespace harvest::arm
