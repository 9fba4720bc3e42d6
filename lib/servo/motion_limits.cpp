#include "servo/motion_limits.hpp"

#include <algorithm>

namespace harvest::servo {

Eigen::Vector3d clamp_norm(const Eigen::Vector3d& v, double limit) {
  const double n = v.norm();
  return n > limit && n > 0 ? Eigen::Vector3d(v * (limit / n)) : v;
}

namespace {

Eigen::Vector3d clip_box(const Workspace& ws, const Eigen::Vector3d& p, Eigen::Vector3d v, double horizon) {
  // Axis by axis: the largest velocity that reaches at most the face.
  for (int i = 0; i < 3; ++i) {
    const double hi = std::max(0.0, (ws.max[i] - p[i]) / horizon);
    const double lo = std::min(0.0, (ws.min[i] - p[i]) / horizon);
    v[i] = std::clamp(v[i], lo, hi);
  }
  return v;
}

Eigen::Vector3d clip_reach(const Workspace& ws, const Eigen::Vector3d& p, Eigen::Vector3d v, double horizon) {
  // Limit the radial component so the radius stays in [min_reach, max_reach] to first order.
  const double r = p.norm();
  if (r < 1e-9) return v;
  const Eigen::Vector3d radial = p / r;
  const double vr = v.dot(radial);
  const double vr_max = std::max(0.0, (ws.max_reach - r) / horizon);
  const double vr_min = std::min(0.0, (ws.min_reach - r) / horizon);
  return v + (std::clamp(vr, vr_min, vr_max) - vr) * radial;
}

}  // namespace

Eigen::Vector3d clip_to_workspace(const Workspace& ws, const Eigen::Vector3d& p, const Eigen::Vector3d& v,
                                  double horizon) {
  Eigen::Vector3d out = clip_box(ws, p, clip_reach(ws, p, clip_box(ws, p, v, horizon), horizon), horizon);
  // The first-order radial clip can leave the predicted point just outside
  // the curved shell; shrink along the same direction until it is inside.
  if (ws.contains(p) && !ws.contains(p + out * horizon)) {
    double lo = 0.0, hi = 1.0;
    for (int i = 0; i < 30; ++i) {
      const double mid = 0.5 * (lo + hi);
      (ws.contains(p + out * (mid * horizon)) ? lo : hi) = mid;
    }
    out *= lo;
  }
  return out;
}

Twist TwistLimiter::apply(const Twist& desired, const Eigen::Vector3d& tool_position, double dt) {
  Twist t;
  t.linear = clamp_norm(desired.linear, limits_.max_linear_speed);
  t.angular = clamp_norm(desired.angular, limits_.max_angular_speed);
  t.linear = previous_.linear + clamp_norm(t.linear - previous_.linear, limits_.max_linear_accel * dt);
  t.angular = previous_.angular + clamp_norm(t.angular - previous_.angular, limits_.max_angular_accel * dt);
  const Eigen::Vector3d clipped = clip_to_workspace(workspace_, tool_position, t.linear, limits_.horizon);
  if ((clipped - t.linear).norm() > 1e-12) ++workspace_clips_;
  t.linear = clipped;
  previous_ = t;
  return t;
}

}  // namespace harvest::servo
