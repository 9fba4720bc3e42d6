// Geometry used by the controller: message poses <-> Eigen, the gripper
// orientation goal of the rotation controller (thesis eq. 6-17..6-22) and
// undistortion of a hand-camera pixel (eq. 6-6 with OpenCV's distortion).
#pragma once

#include <Eigen/Geometry>

#include "harvest/pose_t.hpp"
#include "harvest/twist_t.hpp"
#include "servo/servo_config.hpp"

namespace harvest::servo {

Eigen::Isometry3d to_isometry(const pose_t& p);
pose_t to_pose(const Eigen::Isometry3d& t);
twist_t to_twist(const Eigen::Vector3d& linear, const Eigen::Vector3d& angular);

// Rotation angles of eq. 6-19 and 6-20 for a target at `target_tool` in the
// tool frame: alpha about x, then beta about the rotated y axis.
struct AimAngles {
  double alpha = 0.0;
  double beta = 0.0;
};

// Desired tool rotation in the base frame that points the tool z axis (the
// gripper approach axis, also the camera's optical axis) at `target_base`
// from `tool`: R_d = R_f Rx(alpha) Ry(beta) with Rx, Ry as written in eq.
// 6-21 (beta is taken after the alpha rotation, as the thesis's sequence of
// two set-point moves does). `angles` receives alpha and beta if not null.
Eigen::Matrix3d aim_rotation(const Eigen::Isometry3d& tool, const Eigen::Vector3d& target_base,
                             AimAngles* angles = nullptr);

// Angle of the rotation between two orientations [rad].
double rotation_distance(const Eigen::Matrix3d& a, const Eigen::Matrix3d& b);

// Normalised image coordinates (x/z, y/z) of a distorted pixel: invert the
// intrinsic matrix, then remove the distortion by fixed-point iteration.
Eigen::Vector2d undistort_pixel(const CameraIntrinsics& cam, double u, double v);

// Pixel of a point in the camera frame (z forward), distortion applied.
// Returns false if the point is not in front of the camera.
bool project_point(const CameraIntrinsics& cam, const Eigen::Vector3d& p_camera, Eigen::Vector2d& pixel);

}  // namespace harvest::servo
