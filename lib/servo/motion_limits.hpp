// Limits applied to every commanded tool twist: speed, acceleration, and the
// workspace (a commanded motion never leaves it). Pure functions plus a small
// stateful limiter that remembers the previous command for the acceleration limit.
#pragma once

#include <Eigen/Core>

#include "servo/servo_config.hpp"

namespace harvest::servo {

struct Twist {
  Eigen::Vector3d linear = Eigen::Vector3d::Zero();   // [m/s], base frame
  Eigen::Vector3d angular = Eigen::Vector3d::Zero();  // [rad/s], base frame
};

// Scales v down to norm `limit` keeping its direction.
Eigen::Vector3d clamp_norm(const Eigen::Vector3d& v, double limit);

// Clips the linear velocity so that p + v * horizon stays inside the
// workspace box and reach shell (the robot link may execute a command for
// its whole validity window, so `horizon` is that window). From outside the
// workspace only motion back toward it is allowed. Never increases |v|.
Eigen::Vector3d clip_to_workspace(const Workspace& ws, const Eigen::Vector3d& p, const Eigen::Vector3d& v,
                                  double horizon);

struct LimitsConfig {
  double max_linear_speed = 0.381, max_angular_speed = 0.8;
  double max_linear_accel = 1.0, max_angular_accel = 3.0;
  double horizon = 0.1;  // [s]
};

class TwistLimiter {
 public:
  TwistLimiter(LimitsConfig limits, Workspace workspace) : limits_(limits), workspace_(std::move(workspace)) {}

  // Speed limit, then acceleration limit against the previous output (dt
  // since it), then the workspace clip. Counts clipped commands.
  Twist apply(const Twist& desired, const Eigen::Vector3d& tool_position, double dt);
  // After a stop or a pose goal the next twist ramps up from rest.
  void reset() { previous_ = Twist{}; }
  int64_t workspace_clips() const { return workspace_clips_; }

 private:
  LimitsConfig limits_;
  Workspace workspace_;
  Twist previous_;
  int64_t workspace_clips_ = 0;
};

}  // namespace harvest::servo
