// A pose-goal motion watched to its end: reached within the tolerances,
// or stalled (no measurable step toward the goal for a while: the arm is
// blocked at a joint limit, or the robot link refused the goal).
#pragma once

#include <Eigen/Geometry>
#include <cstdint>

#include "runtime/clock.hpp"

namespace harvest::servo {

struct GoalTolerances {
  double position = 0.005;  // [m] the goal's position is reached
  double rotation = 0.02;   // [rad] ... and its orientation
};

// Whether `tool` is at `goal` within the tolerances.
bool pose_reached(const Eigen::Isometry3d& tool, const Eigen::Isometry3d& goal, const GoalTolerances& tol);

struct GoalProgress {
  double position_step = 0.002;  // [m] a step toward the goal that counts as progress ...
  double rotation_step = 0.01;   // [rad] ... or a turn toward it
  double stall_s = 2.0;          // [s] no progress this long: stalled
};

class GoalMonitor {
 public:
  GoalMonitor(GoalTolerances tolerances, GoalProgress progress) : tol_(tolerances), progress_(progress) {}

  // A new goal: a new id (goal ids start at 1; 0 means none yet), progress counted from now.
  void start(const Eigen::Isometry3d& goal, rt::Micros now);
  const Eigen::Isometry3d& goal() const { return goal_; }
  int64_t id() const { return id_; }
  bool reached(const Eigen::Isometry3d& tool) const { return pose_reached(tool, goal_, tol_); }
  // Records progress toward the goal and says whether there has been none for stall_s. `joints_moving`: the arm
  // is moving although the tool may not come nearer (its self-motion on a joint-space way): progress too.
  bool stalled(const Eigen::Isometry3d& tool, rt::Micros now, bool joints_moving = false);
  // Time that does not count (a pause).
  void shift(rt::Micros by) { progress_at_ += by; }

 private:
  GoalTolerances tol_;
  GoalProgress progress_;
  Eigen::Isometry3d goal_ = Eigen::Isometry3d::Identity();
  int64_t id_ = 0;
  double best_position_ = 0.0;  // closest the tool has come to the goal [m] ...
  double best_rotation_ = 0.0;  // ... and to its orientation [rad]
  rt::Micros progress_at_ = 0;  // when it last got measurably closer
};

}  // namespace harvest::servo
