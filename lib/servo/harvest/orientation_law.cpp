#include "servo/harvest/orientation_law.hpp"

#include <cmath>

namespace harvest::servo {

OrientationError orientation_error(const Eigen::Isometry3d& tool, const Eigen::Vector3d& target,
                                   const Eigen::Vector3d& reference_x) {
  const Eigen::Matrix3d rf = tool.rotation();
  const Eigen::Vector3d m = rf.transpose() * (target - tool.translation());  // eq. 6-17
  OrientationError e;
  e.alpha = std::atan2(m.y(), m.z());  // eq. 6-19
  e.beta = -std::atan2(m.x(), m.z());  // eq. 6-20
  // gamma: the reference x axis in the tool frame, projected across the tool axis.
  const Eigen::Vector3d r = rf.transpose() * reference_x;
  if (std::hypot(r.x(), r.y()) > 1e-9) e.gamma = std::atan2(r.y(), r.x());
  return e;
}

Eigen::Matrix3d aimed_with_roll(const Eigen::Isometry3d& tool, const Eigen::Vector3d& target,
                                const Eigen::Vector3d& reference_x) {
  const Eigen::Vector3d z = (target - tool.translation()).normalized();
  Eigen::Vector3d x = reference_x - reference_x.dot(z) * z;
  if (x.norm() < 1e-9) x = tool.rotation().col(0) - tool.rotation().col(0).dot(z) * z;  // the reference along the axis
  x.normalize();
  Eigen::Matrix3d r;
  r.col(0) = x;
  r.col(1) = z.cross(x);
  r.col(2) = z;
  return r;
}

Twist OrientationLaw::update(const Eigen::Isometry3d& tool, const Eigen::Vector3d& target,
                             const Eigen::Vector3d& reference_x, double dt) {
  const Eigen::Vector3d e = orientation_error(tool, target, reference_x).turn();
  if (have_last_ && dt > 0.0)
    rate_ = gains_.derivative_filter * (e - last_) / dt + (1.0 - gains_.derivative_filter) * rate_;
  else
    rate_.setZero();
  last_ = e;
  have_last_ = true;
  Twist t;
  t.angular = tool.rotation() * (gains_.kp * e + gains_.kd * rate_);
  return t;
}

}  // namespace harvest::servo
