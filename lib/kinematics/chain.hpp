// Forward kinematics and the geometric Jacobian of an ArmModel. Everything is
// expressed in the robot base frame.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <vector>

#include "kinematics/arm_model.hpp"

namespace harvest::kinematics {

using Jacobian = Eigen::Matrix<double, 6, Eigen::Dynamic>;
using Twist = Eigen::Matrix<double, 6, 1>;  // (linear [m/s], angular [rad/s])

// DH link transform T_{i-1,i} for joint angle q.
Eigen::Isometry3d dh_transform(const Joint& joint, double q);

// Frames 0..n of the chain (base mounting applied): frames[0] = DH frame 0,
// frames[n] = flange.
std::vector<Eigen::Isometry3d> joint_frames(const ArmModel& model, const Eigen::VectorXd& q);

Eigen::Isometry3d flange_pose(const ArmModel& model, const Eigen::VectorXd& q);
Eigen::Isometry3d tool_pose(const ArmModel& model, const Eigen::VectorXd& q);
Eigen::Isometry3d camera_pose(const ArmModel& model, const Eigen::VectorXd& q);

// Geometric Jacobian of the tool centre point: twist = J qdot, with the linear
// part the TCP velocity and the angular part the tool angular velocity.
Jacobian tool_jacobian(const ArmModel& model, const Eigen::VectorXd& q);

// Orientation error as a rotation vector taking `current` to `desired` (base frame).
Eigen::Vector3d orientation_error(const Eigen::Matrix3d& desired, const Eigen::Matrix3d& current);

}  // namespace harvest::kinematics
