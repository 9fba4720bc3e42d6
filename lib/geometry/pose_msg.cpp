#include "geometry/pose_msg.hpp"

namespace harvest::geometry {

bool has_orientation(const pose_t& p) {
  return Eigen::Vector4d(p.orientation[0], p.orientation[1], p.orientation[2], p.orientation[3]).norm() > 1e-9;
}

Eigen::Isometry3d to_isometry(const pose_t& p) {
  Eigen::Quaterniond q(p.orientation[0], p.orientation[1], p.orientation[2], p.orientation[3]);
  if (!has_orientation(p)) q = Eigen::Quaterniond::Identity();
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

}  // namespace harvest::geometry
