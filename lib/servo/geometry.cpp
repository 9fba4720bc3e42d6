#include "servo/geometry.hpp"

#include <cmath>

namespace harvest::servo {

Eigen::Isometry3d to_isometry(const pose_t& p) {
  Eigen::Quaterniond q(p.orientation[0], p.orientation[1], p.orientation[2], p.orientation[3]);
  if (q.norm() < 1e-9) q = Eigen::Quaterniond::Identity();  // an all-zero quaternion means "no orientation"
  Eigen::Isometry3d t = Eigen::Isometry3d::Identity();
  t.linear() = q.normalized().toRotationMatrix();
  t.translation() = Eigen::Vector3d(p.position[0], p.position[1], p.position[2]);
  return t;
}

pose_t to_pose(const Eigen::Isometry3d& t) {
  pose_t p{};
  const Eigen::Quaterniond q(t.rotation());
  for (int i = 0; i < 3; ++i) p.position[i] = t.translation()[i];
  p.orientation[0] = q.w();
  p.orientation[1] = q.x();
  p.orientation[2] = q.y();
  p.orientation[3] = q.z();
  return p;
}

twist_t to_twist(const Eigen::Vector3d& linear, const Eigen::Vector3d& angular) {
  twist_t t{};
  for (int i = 0; i < 3; ++i) {
    t.linear[i] = linear[i];
    t.angular[i] = angular[i];
  }
  return t;
}

namespace {
// Eq. 6-21 exactly as written (these are the transposes of the right-handed
// rotations by alpha and beta; with alpha = atan(Y/Z) they turn z toward the target).
Eigen::Matrix3d thesis_rx(double a) {
  Eigen::Matrix3d r;
  r << 1, 0, 0, 0, std::cos(a), std::sin(a), 0, -std::sin(a), std::cos(a);
  return r;
}
Eigen::Matrix3d thesis_ry(double b) {
  Eigen::Matrix3d r;
  r << std::cos(b), 0, -std::sin(b), 0, 1, 0, std::sin(b), 0, std::cos(b);
  return r;
}
}  // namespace

Eigen::Matrix3d aim_rotation(const Eigen::Isometry3d& tool, const Eigen::Vector3d& target_base, AimAngles* angles) {
  const Eigen::Matrix3d rf = tool.rotation();
  // Eq. 6-17: the target in the tool frame.
  const Eigen::Vector3d m = rf.transpose() * (target_base - tool.translation());
  const double alpha = std::atan2(m.y(), m.z());  // eq. 6-19
  const Eigen::Matrix3d rx = thesis_rx(alpha);
  const Eigen::Vector3d m1 = rx.transpose() * m;  // target after the x rotation
  const double beta = -std::atan2(m1.x(), m1.z());  // eq. 6-20
  if (angles != nullptr) *angles = {alpha, beta};
  return rf * rx * thesis_ry(beta);  // eq. 6-22 applied in sequence
}

double rotation_distance(const Eigen::Matrix3d& a, const Eigen::Matrix3d& b) {
  return Eigen::AngleAxisd(a.transpose() * b).angle();
}

Eigen::Vector2d undistort_pixel(const CameraIntrinsics& cam, double u, double v) {
  // Inverse of the upper-triangular intrinsic matrix (eq. 6-6, 6-9).
  const double yd = (v - cam.v0) / cam.fy;
  const double xd = (u - cam.u0 - cam.skew * yd) / cam.fx;
  const auto& d = cam.distortion;
  double x = xd, y = yd;
  for (int i = 0; i < 20; ++i) {
    const double r2 = x * x + y * y;
    const double radial = 1 + d[0] * r2 + d[1] * r2 * r2 + d[4] * r2 * r2 * r2;
    const double dx = 2 * d[2] * x * y + d[3] * (r2 + 2 * x * x);
    const double dy = d[2] * (r2 + 2 * y * y) + 2 * d[3] * x * y;
    x = (xd - dx) / radial;
    y = (yd - dy) / radial;
  }
  return {x, y};
}

bool project_point(const CameraIntrinsics& cam, const Eigen::Vector3d& p, Eigen::Vector2d& pixel) {
  if (p.z() <= 1e-6) return false;
  const double x = p.x() / p.z(), y = p.y() / p.z();
  const auto& d = cam.distortion;
  const double r2 = x * x + y * y;
  const double radial = 1 + d[0] * r2 + d[1] * r2 * r2 + d[4] * r2 * r2 * r2;
  const double xd = x * radial + 2 * d[2] * x * y + d[3] * (r2 + 2 * x * x);
  const double yd = y * radial + d[2] * (r2 + 2 * y * y) + 2 * d[3] * x * y;
  pixel = {cam.fx * xd + cam.skew * yd + cam.u0, cam.fy * yd + cam.v0};
  return true;
}

}  // namespace harvest::servo
