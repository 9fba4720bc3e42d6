// The thesis's rotation controller (section 6.3.2, eq. 6-19..6-24) as a
// velocity law: the gripper axis turned toward the fruit by a PD law on the
// angles alpha and beta of eq. 6-19, 6-20, and the rotation about the axis
// (gamma, eq. 6-23) held at a reference roll. The alternative to ORIENT's
// pose goal (orient_law: thesis_pd); docs/servo-controller.md compares them.
#pragma once

#include <Eigen/Geometry>

#include "servo/motion_limits.hpp"

namespace harvest::servo {

// e_omega of eq. 6-23 for a target at `target` (base frame) seen from `tool`:
// alpha = atan(Y/Z), beta = -atan(X/Z) (eq. 6-19, 6-20, the target in the
// tool frame) and gamma, the right-handed turn about the tool axis that
// brings the tool's x axis onto `reference_x` projected across the axis.
// The thesis's Rx, Ry (eq. 6-21) are the transposes of right-handed
// rotations, so the right-handed turn toward the target is (-alpha, -beta).
struct OrientationError {
  double alpha = 0.0, beta = 0.0, gamma = 0.0;  // [rad]
  // The right-handed rotation vector in the tool frame that removes the error (small angles).
  Eigen::Vector3d turn() const { return {-alpha, -beta, gamma}; }
};
OrientationError orientation_error(const Eigen::Isometry3d& tool, const Eigen::Vector3d& target,
                                   const Eigen::Vector3d& reference_x);

// Where the law converges: the tool axis at `target` from the tool's
// position, its x axis `reference_x` projected across the axis.
Eigen::Matrix3d aimed_with_roll(const Eigen::Isometry3d& tool, const Eigen::Vector3d& target,
                                const Eigen::Vector3d& reference_x);

struct OrientationGains {
  double kp = 2.0;                 // [1/s] kp_omega of eq. 6-24
  double kd = 0.05;                // [s] kv_omega of eq. 6-24
  double derivative_filter = 0.5;  // low-pass weight of the newest error derivative, 0..1
};

// omega = kp_omega e + kv_omega de/dt in the tool frame (eq. 6-24; the thesis
// writes -kv with its error sign: here kd > 0 always damps), rotated into the
// base frame; the tool's position is held (zero linear velocity).
class OrientationLaw {
 public:
  explicit OrientationLaw(OrientationGains gains) : gains_(gains) {}
  void reset() { have_last_ = false; }
  // One control step `dt` seconds after the previous one.
  Twist update(const Eigen::Isometry3d& tool, const Eigen::Vector3d& target, const Eigen::Vector3d& reference_x,
               double dt);

 private:
  OrientationGains gains_;
  bool have_last_ = false;
  Eigen::Vector3d last_ = Eigen::Vector3d::Zero();
  Eigen::Vector3d rate_ = Eigen::Vector3d::Zero();
};

}  // namespace harvest::servo
