#include "servo/harvest/goal_monitor.hpp"

#include <limits>

#include "servo/geometry.hpp"

namespace harvest::servo {

bool pose_reached(const Eigen::Isometry3d& tool, const Eigen::Isometry3d& goal, const GoalTolerances& tol) {
  return (tool.translation() - goal.translation()).norm() <= tol.position &&
         rotation_distance(tool.rotation(), goal.rotation()) <= tol.rotation;
}

void GoalMonitor::start(const Eigen::Isometry3d& goal, rt::Micros now) {
  goal_ = goal;
  ++id_;
  best_position_ = std::numeric_limits<double>::infinity();
  best_rotation_ = std::numeric_limits<double>::infinity();
  progress_at_ = now;
}

bool GoalMonitor::stalled(const Eigen::Isometry3d& tool, rt::Micros now, bool joints_moving) {
  // The steps are well above encoder noise and well below what the slowest
  // goal motion covers in a stall period.
  const double position = (tool.translation() - goal_.translation()).norm();
  const double rotation = rotation_distance(tool.rotation(), goal_.rotation());
  bool progress = joints_moving;
  if (position < best_position_ - progress_.position_step) {  // always true against the initial infinity
    best_position_ = position;
    progress = true;
  }
  if (rotation < best_rotation_ - progress_.rotation_step) {
    best_rotation_ = rotation;
    progress = true;
  }
  if (progress) progress_at_ = now;
  return now - progress_at_ > rt::from_seconds(progress_.stall_s);
}

}  // namespace harvest::servo
