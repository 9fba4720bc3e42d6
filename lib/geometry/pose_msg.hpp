// Message poses (pose_t: position, unit quaternion w x y z) <-> Eigen.
#pragma once

#include <Eigen/Geometry>

#include "harvest/pose_t.hpp"

namespace harvest::geometry {

// An all-zero quaternion means "no orientation" and reads as the identity.
Eigen::Isometry3d to_isometry(const pose_t& p);
pose_t to_pose(const Eigen::Isometry3d& t);
// True if the pose carries an orientation (a message from before a pose
// field existed decodes it as all zeros).
bool has_orientation(const pose_t& p);

}  // namespace harvest::geometry
