#include "servo/servo_config.hpp"

#include <fmt/format.h>

#include <cmath>

#include "geometry/envelope.hpp"

namespace harvest::servo {

using config::Range;

bool Workspace::contains(const Eigen::Vector3d& p, double margin) const {
  const double r = p.norm();
  return (p.array() >= min.array() + margin).all() && (p.array() <= max.array() - margin).all() &&
         r >= min_reach + margin && r <= max_reach - margin;
}

namespace {

Eigen::Vector3d vec3(const config::Node& n, const std::string& key, const Eigen::Vector3d& fallback) {
  const auto v = n.numbers(key, {fallback.x(), fallback.y(), fallback.z()}, 3);
  return {v[0], v[1], v[2]};
}

Eigen::Isometry3d pose(const config::Node& n, const Eigen::Isometry3d& fallback) {
  const Eigen::Quaterniond q0(fallback.rotation());
  const Eigen::Vector3d p = vec3(n, "position", fallback.translation());
  const auto q = n.numbers("orientation_wxyz", {q0.w(), q0.x(), q0.y(), q0.z()}, 4);
  const Eigen::Quaterniond quat(q[0], q[1], q[2], q[3]);
  if (std::abs(quat.norm() - 1.0) > 1e-3) n.fail("orientation_wxyz", "a unit quaternion (w, x, y, z)");
  Eigen::Isometry3d t = Eigen::Isometry3d::Identity();
  t.linear() = quat.normalized().toRotationMatrix();
  t.translation() = p;
  return t;
}

Eigen::Isometry3d make_pose(double x, double y, double z, double qw, double qx, double qy, double qz) {
  Eigen::Isometry3d t = Eigen::Isometry3d::Identity();
  t.linear() = Eigen::Quaterniond(qw, qx, qy, qz).normalized().toRotationMatrix();
  t.translation() = Eigen::Vector3d(x, y, z);
  return t;
}

}  // namespace

ServoConfig ServoConfig::from_yaml(const config::Node& n) {
  ServoConfig c;
  const Range<double> pos{1e-6, 1e6};
  const Range<double> nonneg{0.0, 1e6};
  c.tick_period_s = n.get("tick_period_s", c.tick_period_s, {0.001, 0.5});
  c.status_period_s = n.get("status_period_s", c.status_period_s, {0.05, 60.0});
  c.validity_s = n.get("validity_s", c.validity_s, {0.01, 2.0});
  // The robot link's own limits (one file, config/arm/envelope.yaml): the
  // controller commands at most what the link will carry out.
  const auto envelope = geometry::Envelope::from_config(n, "envelope", "config/arm/envelope.yaml");
  c.max_linear_speed = envelope.max_linear_speed;
  c.max_angular_speed = envelope.max_angular_speed;
  c.max_linear_accel = envelope.max_linear_acceleration;
  c.max_angular_accel = envelope.max_angular_acceleration;
  c.ir_switch_distance = n.get("ir_switch_distance", c.ir_switch_distance, pos);
  c.ir_approach_speed = n.get("ir_approach_speed", c.ir_approach_speed, pos);
  c.ir_braking_decel = n.get("ir_braking_decel", c.ir_braking_decel, pos);
  c.ir_min_speed = n.get("ir_min_speed", c.ir_min_speed, pos);
  c.ir_grasp_range = n.get("ir_grasp_range", c.ir_grasp_range, pos);
  c.ir_max_travel = n.get("ir_max_travel", c.ir_max_travel, pos);
  c.ir_overshoot = n.get("ir_overshoot", c.ir_overshoot, nonneg);
  c.ir_vision_agreement = n.get("ir_vision_agreement", c.ir_vision_agreement, nonneg);
  c.front_fruit_tolerance = n.get("front_fruit_tolerance", c.front_fruit_tolerance, nonneg);
  c.grasp_advance = n.get("grasp_advance", c.grasp_advance, {0.0, 0.05});
  c.ir_fold_near = n.get("ir_fold_near", c.ir_fold_near, {0.0, 0.5});
  c.ir_fold_jump = n.get("ir_fold_jump", c.ir_fold_jump, {1e-3, 1.0});
  c.ir_progress_step = n.get("ir_progress_step", c.ir_progress_step, {1e-4, 0.1});
  c.ir_attempts = n.get("ir_attempts", c.ir_attempts, {1, 10});
  c.orient_tolerance = n.get("orient_tolerance", c.orient_tolerance, pos);
  c.position_tolerance = n.get("position_tolerance", c.position_tolerance, pos);
  c.retreat_distance = n.get("retreat_distance", c.retreat_distance, nonneg);
  c.pull_distance = n.get("pull_distance", c.pull_distance, nonneg);
  c.twist_angle = n.get("twist_angle", c.twist_angle, {-6.3, 6.3});
  c.release_at_detach = n.get("release_at_detach", c.release_at_detach);
  c.max_attempts_per_fruit = n.get("max_attempts_per_fruit", c.max_attempts_per_fruit, {1, 10});
  c.association_gate_px = n.get("association_gate_px", c.association_gate_px, pos);
  c.min_ahead_of_home = n.get("min_ahead_of_home", c.min_ahead_of_home, {-10.0, 10.0});
  c.max_aim_angle = n.get("max_aim_angle", c.max_aim_angle, {0.0, 1.6});
  c.view_angle = n.get("view_angle", c.view_angle, {0.0, 1.5});
  c.view_distance = n.get("view_distance", c.view_distance, {0.1, 1.5});
  c.triangulation_gap = n.get("triangulation_gap", c.triangulation_gap, {0.0, 0.5});
  c.min_triangulation_angle = n.get("min_triangulation_angle", c.min_triangulation_angle, {0.01, 1.5});
  c.same_fruit_distance = n.get("same_fruit_distance", c.same_fruit_distance, nonneg);
  c.same_sight_angle = n.get("same_sight_angle", c.same_sight_angle, {0.0, 0.5});
  c.reused_id_distance = n.get("reused_id_distance", c.reused_id_distance, nonneg);
  c.size_agreement = n.get("size_agreement", c.size_agreement, {0.0, 10.0});
  c.size_agreement_min = n.get("size_agreement_min", c.size_agreement_min, {0.0, 10.0});
  c.fills_view = n.get("fills_view", c.fills_view, {0.1, 1.0});
  c.front_fruit_size_ratio = n.get("front_fruit_size_ratio", c.front_fruit_size_ratio, {1.0, 10.0});
  c.whole_fruit_border_px = n.get("whole_fruit_border_px", c.whole_fruit_border_px, {0, 100});
  c.goal_progress_step = n.get("goal_progress_step", c.goal_progress_step, {1e-5, 0.1});
  c.goal_progress_angle = n.get("goal_progress_angle", c.goal_progress_angle, {1e-5, 0.5});
  c.in_view_margin = n.get("in_view_margin", c.in_view_margin, {0.0, 0.49});
  c.sight_aim_margin = n.get("sight_aim_margin", c.sight_aim_margin, {0.0, 0.5});
  c.approach_mode = n.choice("approach_mode", c.approach_mode, {"reconstruction", "tbz"});
  c.orient_law = n.choice("orient_law", c.orient_law, {"pose_goal", "thesis_pd"});
  if (c.ir_approach_speed > c.max_linear_speed) n.fail("ir_approach_speed", "a speed no greater than max_linear_speed");
  if (c.ir_min_speed > c.ir_approach_speed) n.fail("ir_min_speed", "a speed no greater than ir_approach_speed");
  if (c.ir_braking_decel > c.max_linear_accel)
    n.fail("ir_braking_decel", "a deceleration no greater than max_linear_accel");

  const config::Node ws = n.child("workspace");
  c.workspace.min = vec3(ws, "min", c.workspace.min);
  c.workspace.max = vec3(ws, "max", c.workspace.max);
  c.workspace.min_reach = ws.get("min_reach", c.workspace.min_reach, nonneg);
  c.workspace.max_reach = ws.get("max_reach", c.workspace.max_reach, pos);
  if (!(c.workspace.min.array() < c.workspace.max.array()).all()) ws.fail("max", "every element greater than min");
  if (c.workspace.min_reach >= c.workspace.max_reach) ws.fail("max_reach", "a value greater than min_reach");
  // Goals outside the link's box would be clipped or refused there: the
  // controller would aim at fruit it can never reach. Refused at start.
  if (!envelope.contains_box(c.workspace.min, c.workspace.max))
    ws.fail("", fmt::format("a box inside the robot envelope's [{:g}, {:g}, {:g}]..[{:g}, {:g}, {:g}] ({}), got "
                            "[{:g}, {:g}, {:g}]..[{:g}, {:g}, {:g}]",
                            envelope.min.x(), envelope.min.y(), envelope.min.z(), envelope.max.x(), envelope.max.y(),
                            envelope.max.z(), n.file_path("envelope", "config/arm/envelope.yaml").string(),
                            c.workspace.min.x(), c.workspace.min.y(), c.workspace.min.z(), c.workspace.max.x(),
                            c.workspace.max.y(), c.workspace.max.z()));

  // Home: the thesis experiment I start pose (table 6-5), gripper axis along base +y.
  c.home_pose = pose(n.child("home_pose"), make_pose(-0.655, 0.785, -0.251, 0.5, -0.5, -0.5, -0.5));
  c.drop_pose = pose(n.child("drop_pose"), make_pose(-0.5, 0.72, -0.25, 0.5, -0.5, -0.5, -0.5));
  if (!c.workspace.contains(c.home_pose.translation())) n.fail("home_pose", "a position inside the workspace");
  if (!c.workspace.contains(c.drop_pose.translation())) n.fail("drop_pose", "a position inside the workspace");

  const config::Node tz = n.child("tbz");
  c.tbz.lambda_w = tz.get("lambda_w", c.tbz.lambda_w, {0.0, 100.0});
  c.tbz.lambda_v = tz.get("lambda_v", c.tbz.lambda_v, {0.0, 1000.0});
  c.tbz.desired_depth_estimate = tz.get("desired_depth_estimate", c.tbz.desired_depth_estimate, {0.01, 10.0});
  c.tbz.max_match_age_s = tz.get("max_match_age_s", c.tbz.max_match_age_s, {0.01, 10.0});
  c.tbz.fallback_after_s = tz.get("fallback_after_s", c.tbz.fallback_after_s, {0.0, 60.0});
  c.tbz.arrived_rotation = tz.get("arrived_rotation", c.tbz.arrived_rotation, {0.0, 1.0});
  c.tbz.arrived_translation = tz.get("arrived_translation", c.tbz.arrived_translation, {0.0, 1.0});

  const config::Node g = n.child("gains");
  c.gains.kp_lateral = g.get("kp_lateral", c.gains.kp_lateral, nonneg);
  c.gains.kd_lateral = g.get("kd_lateral", c.gains.kd_lateral, nonneg);
  c.gains.kp_depth = g.get("kp_depth", c.gains.kp_depth, nonneg);
  c.gains.kd_depth = g.get("kd_depth", c.gains.kd_depth, nonneg);
  c.gains.derivative_filter = g.get("derivative_filter", c.gains.derivative_filter, {0.0, 1.0});
  c.gains.centring_tolerance = g.get("centring_tolerance", c.gains.centring_tolerance, nonneg);
  c.gains.sway_window = g.get("sway_window", c.gains.sway_window, nonneg);
  c.gains.kp_orient = g.get("kp_orient", c.gains.kp_orient, {0.01, 100.0});
  c.gains.kd_orient = g.get("kd_orient", c.gains.kd_orient, nonneg);

  const config::Node t = n.child("timeouts_s");
  Timeouts& to = c.timeouts;
  for (auto [key, value] : {std::pair{"select", &to.select},
                            {"motion", &to.motion},
                            {"stall", &to.stall},
                            {"acquire", &to.acquire},
                            {"lost", &to.lost},
                            {"reacquire", &to.reacquire},
                            {"approach", &to.approach},
                            {"ir_approach", &to.ir_approach},
                            {"grasp", &to.grasp},
                            {"release", &to.release},
                            {"robot_state", &to.robot_state},
                            {"ir_stale", &to.ir_stale}})
    *value = t.get(key, *value, {0.01, 600.0});

  c.hand_camera = geometry::CameraModel::from_config(n, "hand_camera_calibration", "config/cameras/hand.yaml");
  return c;
}

}  // namespace harvest::servo
