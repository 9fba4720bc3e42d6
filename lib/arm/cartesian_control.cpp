#include "arm/cartesian_control.hpp"

namespace harvest::arm {

CartesianStep cartesian_step(const RobotLinkConfig& config, const Eigen::VectorXd& q, const Eigen::Isometry3d& tool,
                             const kinematics::Twist& v, const Eigen::VectorXd& previous, double dt) {
  CartesianStep out;
  out.clip = clip_twist(v, tool.translation(), config.workspace, config.limits, dt);
  int held = 0;  // joints braking for a position limit, the others making up the twist
  const Eigen::VectorXd want =
      kinematics::joint_velocity_within_limits(config.model, q, out.clip.twist, dt, {}, &held, &previous);
  const auto lim = kinematics::limit_joint_velocity(config.model, q, previous, want, dt);
  out.qdot = lim.qdot;
  out.position_clipped = lim.position_clipped || held > 0;
  return out;
}

CartesianStep pose_goal_step(const RobotLinkConfig& config, const CartesianTrajectory& trajectory, double t,
                             const Eigen::VectorXd& q, const Eigen::VectorXd& previous, double dt) {
  const Eigen::Isometry3d tool = kinematics::tool_pose(config.model, q);
  const kinematics::Twist e = kinematics::pose_error(trajectory.pose(t), tool);
  kinematics::Twist v = trajectory.twist(t);
  v.head<3>() += config.position_gain * e.head<3>();
  v.tail<3>() += config.orientation_gain * e.tail<3>();
  return cartesian_step(config, q, tool, v, previous, dt);
}

}  // namespace harvest::arm
