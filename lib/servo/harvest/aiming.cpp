#include "servo/harvest/aiming.hpp"

#include <algorithm>
#include <cmath>

#include "servo/geometry.hpp"

namespace harvest::servo {

namespace {
Eigen::Vector3d vec(const double* p) { return {p[0], p[1], p[2]}; }
}  // namespace

bool pickable(const ServoConfig& cfg, const Eigen::Vector3d& p) {
  // Every fruit is aimed at from home (eq. 6-19..6-22): a target beside or
  // behind the gripper there cannot be turned to and seen.
  const Eigen::Vector3d axis = cfg.home_pose.linear().col(2);
  return cfg.workspace.contains(p) && (p - cfg.home_pose.translation()).dot(axis) >= cfg.min_ahead_of_home;
}

std::optional<SightLine> sight_line(const ServoConfig& cfg, const targets_t& view, const target_t& t) {
  if (!view.camera_known) return std::nullopt;  // a view from before the field existed
  SightLine line;
  line.origin = vec(view.camera_position_base);
  const Eigen::Vector3d d = vec(t.position_base) - line.origin;
  if (d.norm() < 1e-6) return std::nullopt;
  line.direction = d.normalized();
  // Scan in 5 mm steps out to 3 m (beyond any workspace): the pickable set
  // is a box cut by a shell and a half-space, so the first and the last
  // pickable step bound it along a straight line.
  constexpr double kStep = 0.005, kFar = 3.0;
  bool found = false;
  for (double s = 0.0; s <= kFar; s += kStep) {
    if (!pickable(cfg, line.at(s))) continue;
    if (!found) line.near = s;
    line.far = s;
    found = true;
  }
  if (!found) return std::nullopt;
  return line;
}

Eigen::Vector3d sight_aim(const ServoConfig& cfg, const SightLine& line, double s_start, const Eigen::Vector3d& from) {
  // The hand camera's narrower half field of view, less a margin for the
  // fruit's own size: the whole stretch stays in the image.
  const geometry::CameraModel& k = cfg.hand_camera;
  const double half = std::min(std::atan2(k.cx, k.fx), std::atan2(k.cy, k.fy));
  constexpr double kMinHalfSpan = 0.05;  // [rad] a camera narrower than the margin still looks along a stretch
  const double span = 2.0 * std::max(kMinHalfSpan, half - cfg.sight_aim_margin);
  const double s_end = std::abs(s_start - line.near) < std::abs(s_start - line.far) ? line.far : line.near;
  auto dir = [&](double s) { return (line.at(s) - from).normalized(); };
  const Eigen::Vector3d u0 = dir(s_start);
  // Seen from a point, the direction to a point moving along a line turns
  // monotonically away from where it started: walk until the span is used up.
  constexpr int kSteps = 200;
  double s_last = s_start;
  for (int i = 1; i <= kSteps; ++i) {
    const double s = s_start + (s_end - s_start) * i / kSteps;
    if (std::acos(std::clamp(u0.dot(dir(s)), -1.0, 1.0)) > span) break;
    s_last = s;
  }
  const Eigen::Vector3d middle = (u0 + dir(s_last)).normalized();
  double best_s = s_start, best = -2.0;
  for (int i = 0; i <= kSteps; ++i) {
    const double s = s_start + (s_last - s_start) * i / kSteps;
    if (const double c = middle.dot(dir(s)); c > best) {
      best = c;
      best_s = s;
    }
  }
  return line.at(best_s);
}

Eigen::Isometry3d aim_in_place(const Eigen::Isometry3d& tool, const Eigen::Vector3d& target) {
  Eigen::Isometry3d goal = tool;
  goal.linear() = aim_rotation(tool, target);
  return goal;
}

std::optional<Eigen::Isometry3d> aim_from_viewpoint(const ServoConfig& cfg, const Eigen::Vector3d& target) {
  // Seen from the side, along the home axis turned a little toward it, so
  // the arm's posture stays near the home one and the approach still comes
  // from outside the canopy.
  if (cfg.view_angle <= 0.0) return std::nullopt;
  const Eigen::Vector3d axis = cfg.home_pose.linear().col(2);
  const Eigen::Vector3d to = (target - cfg.home_pose.translation()).normalized();
  const Eigen::Vector3d normal = axis.cross(to);
  if (normal.norm() < 1e-6) return std::nullopt;  // straight ahead: nothing to gain
  const double turn = std::min(cfg.view_angle, std::acos(std::clamp(axis.dot(to), -1.0, 1.0)));
  const Eigen::Vector3d view_axis = Eigen::AngleAxisd(turn, normal.normalized()) * axis;
  Eigen::Isometry3d from = cfg.home_pose;
  from.translation() = target - cfg.view_distance * view_axis;
  if (!cfg.workspace.contains(from.translation())) return std::nullopt;
  from.linear() = aim_rotation(from, target);
  return from;
}

OrientGoal orient_goal(const ServoConfig& cfg, const Eigen::Isometry3d& tool, const Eigen::Vector3d& target,
                       bool from_viewpoint) {
  const Eigen::Vector3d to = (target - tool.translation()).normalized();
  if (std::acos(std::clamp(tool.linear().col(2).dot(to), -1.0, 1.0)) > cfg.max_aim_angle) from_viewpoint = true;
  if (const auto view = from_viewpoint ? aim_from_viewpoint(cfg, target) : std::nullopt) return {*view, true};
  return {aim_in_place(tool, target), false};
}

Eigen::Isometry3d back_along_axis(const Eigen::Isometry3d& tool, const std::optional<Eigen::Vector3d>& abreast_of,
                                  double at_least) {
  Eigen::Isometry3d g = tool;
  const Eigen::Vector3d axis = g.rotation().col(2);
  double back = at_least;
  if (abreast_of) back = std::max(back, (g.translation() - *abreast_of).dot(axis));
  g.translation() -= back * axis;
  return g;
}

Eigen::Isometry3d back_toward(const Eigen::Isometry3d& tool, const std::optional<Eigen::Vector3d>& began,
                              double at_least) {
  if (!began) return back_along_axis(tool, std::nullopt, at_least);
  const Eigen::Vector3d way = *began - tool.translation();
  const double length = way.norm();
  // Behind the tool (within 60 deg of straight back along its axis), and not where it is.
  if (length < 1e-3 || -way.dot(tool.rotation().col(2)) < 0.5 * length) return back_along_axis(tool, began, at_least);
  Eigen::Isometry3d g = tool;
  g.translation() += std::max(length, at_least) / length * way;
  return g;
}

namespace {
double segment_distance(const Eigen::Vector3d& a, const Eigen::Vector3d& b, const Eigen::Vector3d& p) {
  const Eigen::Vector3d ab = b - a;
  const double len2 = ab.squaredNorm();
  const double s = len2 > 0.0 ? std::clamp((p - a).dot(ab) / len2, 0.0, 1.0) : 0.0;
  return (a + s * ab - p).norm();
}
}  // namespace

Eigen::Isometry3d clear_retreat(const Eigen::Isometry3d& tool, const Eigen::Isometry3d& farthest, double at_least,
                                const Eigen::Isometry3d& to, const std::vector<Eigen::Vector3d>& fruit,
                                double clearance, double palm, double step) {
  const Eigen::Vector3d way = farthest.translation() - tool.translation();
  const double back_max = way.norm();
  if (back_max <= 0.0) return farthest;
  const Eigen::Vector3d dir = way / back_max;
  const Eigen::Vector3d axis = tool.rotation().col(2);
  const Eigen::Vector3d to_palm = to.translation() - palm * to.rotation().col(2);
  for (double back = at_least; back < back_max; back += std::max(step, 1e-3)) {
    const Eigen::Vector3d from = tool.translation() + back * dir;
    const Eigen::Vector3d from_palm = from - palm * axis;
    const bool clear = std::all_of(fruit.begin(), fruit.end(), [&](const Eigen::Vector3d& f) {
      return segment_distance(from, to.translation(), f) >= clearance &&
             segment_distance(from_palm, to_palm, f) >= clearance;
    });
    if (clear) {
      Eigen::Isometry3d g = tool;
      g.translation() = from;
      return g;
    }
  }
  return farthest;
}

Eigen::Isometry3d detach_goal(const Eigen::Isometry3d& tool, double pull, double twist) {
  Eigen::Isometry3d g = back_along_axis(tool, std::nullopt, pull);
  g.linear() = g.linear() * Eigen::AngleAxisd(twist, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  return g;
}

Eigen::Isometry3d inside_workspace(const Workspace& ws, const Eigen::Vector3d& from, const Eigen::Isometry3d& goal) {
  if (ws.contains(goal.translation())) return goal;
  const Eigen::Vector3d to = goal.translation();
  double lo = 0.0, hi = 1.0;
  for (int i = 0; i < 30; ++i) {  // bisection to ~1 nm on a metre
    const double mid = 0.5 * (lo + hi);
    (ws.contains(from + mid * (to - from)) ? lo : hi) = mid;
  }
  Eigen::Isometry3d g = goal;
  g.translation() = from + lo * (to - from);
  return g;
}

bool in_hand_view(const geometry::CameraModel& k, const Eigen::Isometry3d& camera, const Eigen::Vector3d& point,
                  double margin) {
  Eigen::Vector2d px;
  return project_point(k, camera.inverse() * point, px) && px.x() >= margin * k.width &&
         px.x() <= (1.0 - margin) * k.width && px.y() >= margin * k.height && px.y() <= (1.0 - margin) * k.height;
}

}  // namespace harvest::servo
