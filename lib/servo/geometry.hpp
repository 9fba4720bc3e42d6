// Geometry used by the controller: message poses <-> Eigen, the gripper
// orientation goal of the rotation controller (thesis eq. 6-17..6-22) and
// undistortion of a hand-camera pixel (eq. 6-6 with OpenCV's distortion).
#pragma once

#include <Eigen/Geometry>
#include <optional>
#include <vector>

#include "geometry/pose_msg.hpp"
#include "harvest/pose_t.hpp"
#include "harvest/twist_t.hpp"
#include "servo/servo_config.hpp"

namespace harvest::servo {

using geometry::to_isometry;
using geometry::to_pose;
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

// How far `point` lies ahead of the tool point along the tool's (gripper's) axis [m].
inline double ahead_along_axis(const Eigen::Isometry3d& tool, const Eigen::Vector3d& point) {
  return (point - tool.translation()).dot(tool.rotation().col(2));
}

// Normalised image coordinates (x/z, y/z) of a distorted pixel: invert the
// intrinsic matrix, then remove the distortion by fixed-point iteration.
Eigen::Vector2d undistort_pixel(const geometry::CameraModel& cam, double u, double v);

// Pixel of a point in the camera frame (z forward), distortion applied.
// Returns false if the point is not in front of the camera.
bool project_point(const geometry::CameraModel& cam, const Eigen::Vector3d& p_camera, Eigen::Vector2d& pixel);

// Image of the 3D segment a..b (base frame) in a camera at `camera` (optical
// frame in the base frame), as a polyline: the segment is sampled because
// distortion bends its image. Parts behind the camera or far outside its
// field of view are left out; empty if nothing of it is in view.
std::vector<Eigen::Vector2d> project_segment(const geometry::CameraModel& cam, const Eigen::Isometry3d& camera,
                                             const Eigen::Vector3d& a, const Eigen::Vector3d& b);
// Where two rays o + s d (unit d, s > 0) come closest: the midpoint of the
// two closest points, their distance (`gap`) and the angle between the rays.
// nullopt for (nearly) parallel rays or a closest point behind an origin.
struct RayCrossing {
  Eigen::Vector3d point = Eigen::Vector3d::Zero();
  double gap = 0.0;    // [m]
  double angle = 0.0;  // [rad]
};
std::optional<RayCrossing> cross_rays(const Eigen::Vector3d& o1, const Eigen::Vector3d& d1, const Eigen::Vector3d& o2,
                                      const Eigen::Vector3d& d2);

// Distance [px] from a pixel to a polyline (infinity if it is empty).
double distance_to_polyline(const std::vector<Eigen::Vector2d>& polyline, const Eigen::Vector2d& pixel);

}  // namespace harvest::servo
