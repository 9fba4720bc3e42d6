#include "servo/servo_config.hpp"

#include <fmt/format.h>

#include <cmath>

#include "geometry/envelope.hpp"
#include "security/authority.hpp"

namespace harvest::servo {

bool Workspace::contains(const Eigen::Vector3d& p, double margin) const {
  const double r = p.norm();
  return (p.array() >= min.array() + margin).all() && (p.array() <= max.array() - margin).all() &&
         r >= min_reach + margin && r <= max_reach - margin;
}

namespace {

Eigen::Vector3d vec3(const config::Node& n, const config::Numbers& key) {
  const auto v = n.get(key);
  return {v[0], v[1], v[2]};
}

Eigen::Isometry3d pose(const config::Node& n, const config::Numbers& position, const config::Numbers& orientation) {
  const Eigen::Vector3d p = vec3(n, position);
  const auto q = n.get(orientation);
  const Eigen::Quaterniond quat(q[0], q[1], q[2], q[3]);
  if (std::abs(quat.norm() - 1.0) > 1e-3) n.fail("orientation_wxyz", "a unit quaternion (w, x, y, z)");
  Eigen::Isometry3d t = Eigen::Isometry3d::Identity();
  t.linear() = quat.normalized().toRotationMatrix();
  t.translation() = p;
  return t;
}

}  // namespace

ServoConfig ServoConfig::from_yaml(const config::Node& n) {
  namespace k = servo_keys;
  ServoConfig c;
  c.tick_period_s = n.get(k::tick_period_s);
  c.status_period_s = n.get(k::status_period_s);
  c.validity_s = n.get(k::validity_s);
  // The robot link's own limits (one file, config/arm/envelope.yaml): the
  // controller commands at most what the link will carry out.
  const auto envelope = geometry::Envelope::from_config(n, k::envelope);
  c.max_linear_speed = envelope.max_linear_speed;
  c.max_angular_speed = envelope.max_angular_speed;
  c.max_linear_accel = envelope.max_linear_acceleration;
  c.max_angular_accel = envelope.max_angular_acceleration;
  c.ir_switch_distance = n.get(k::ir_switch_distance);
  c.ir_approach_speed = n.get(k::ir_approach_speed);
  c.ir_braking_decel = n.get(k::ir_braking_decel);
  c.ir_min_speed = n.get(k::ir_min_speed);
  c.ir_grasp_range = n.get(k::ir_grasp_range);
  c.ir_max_travel = n.get(k::ir_max_travel);
  c.ir_overshoot = n.get(k::ir_overshoot);
  c.ir_surface_reach = n.get(k::ir_surface_reach);
  c.ir_surface_travel = n.get(k::ir_surface_travel);
  c.ir_surface_tolerance = n.get(k::ir_surface_tolerance);
  c.ir_vision_agreement = n.get(k::ir_vision_agreement);
  c.ir_split_close = n.get(k::ir_split_close);
  c.ir_split_max = n.get(k::ir_split_max);
  c.front_fruit_tolerance = n.get(k::front_fruit_tolerance);
  c.grasp_advance = n.get(k::grasp_advance);
  c.grasp_stop_at_joint_limit = n.get(k::grasp_stop_at_joint_limit);
  c.ir_fold_near = n.get(k::ir_fold_near);
  c.ir_fold_jump = n.get(k::ir_fold_jump);
  c.ir_progress_step = n.get(k::ir_progress_step);
  c.ir_attempts = n.get(k::ir_attempts);
  c.orient_tolerance = n.get(k::orient_tolerance);
  c.position_tolerance = n.get(k::position_tolerance);
  c.retreat_distance = n.get(k::retreat_distance);
  c.gone_in_distance = n.get(k::gone_in_distance);
  c.retreat_clearance = n.get(k::retreat_clearance);
  c.retrace_way_in = n.get(k::retrace_way_in);
  c.palm_offset = n.get(k::palm_offset);
  c.pull_distance = n.get(k::pull_distance);
  c.twist_angle = n.get(k::twist_angle);
  c.release_at_detach = n.get(k::release_at_detach);
  c.release_while_retreating = n.get(k::release_while_retreating);
  c.pull_through = n.get(k::pull_through);
  c.turn_while_retreating = n.get(k::turn_while_retreating);
  c.turn_in_wind = n.get(k::turn_in_wind);
  c.turn_ahead_home_within = n.get(k::turn_ahead_home_within);
  c.straight_to_next = n.get(k::straight_to_next);
  c.home_after_joint_limit = n.get(k::home_after_joint_limit);
  c.release_opening = n.get(k::release_opening);
  c.fruit_order = n.get(k::fruit_order);
  c.max_attempts_per_fruit = n.get(k::max_attempts_per_fruit);
  c.association_gate_px = n.get(k::association_gate_px);
  c.association_tie_weight = n.get(k::association_tie_weight);
  c.association_tie_weight_doubtful = n.get(k::association_tie_weight_doubtful);
  c.association_size_ratio = n.get(k::association_size_ratio);
  c.min_ahead_of_home = n.get(k::min_ahead_of_home);
  c.max_aim_angle = n.get(k::max_aim_angle);
  c.view_angle = n.get(k::view_angle);
  c.view_distance = n.get(k::view_distance);
  c.triangulation_gap = n.get(k::triangulation_gap);
  c.min_triangulation_angle = n.get(k::min_triangulation_angle);
  c.image_pose_gap = n.get(k::image_pose_gap);
  c.same_fruit_distance = n.get(k::same_fruit_distance);
  c.same_sight_angle = n.get(k::same_sight_angle);
  c.reused_id_distance = n.get(k::reused_id_distance);
  c.size_agreement = n.get(k::size_agreement);
  c.size_agreement_min = n.get(k::size_agreement_min);
  c.crossing_beyond = n.get(k::crossing_beyond);
  c.fixed_depth_gap = n.get(k::fixed_depth_gap);
  c.fills_view = n.get(k::fills_view);
  c.front_fruit_size_ratio = n.get(k::front_fruit_size_ratio);
  c.far_view_ahead = n.get(k::far_view_ahead);
  c.far_view_age = n.get(k::far_view_age);
  c.axis_fruit_area = n.get(k::axis_fruit_area);
  c.whole_fruit_border_px = n.get(k::whole_fruit_border_px);
  c.whole_min_visible = n.get(k::whole_min_visible);
  c.goal_progress_step = n.get(k::goal_progress_step);
  c.goal_progress_angle = n.get(k::goal_progress_angle);
  c.goal_progress_joint_speed = n.get(k::goal_progress_joint_speed);
  c.in_view_margin = n.get(k::in_view_margin);
  c.sight_aim_margin = n.get(k::sight_aim_margin);
  c.approach_mode = n.get(k::approach_mode);
  c.orient_law = n.get(k::orient_law);
  if (c.ir_approach_speed > c.max_linear_speed) n.fail("ir_approach_speed", "a speed no greater than max_linear_speed");
  if (c.ir_min_speed > c.ir_approach_speed) n.fail("ir_min_speed", "a speed no greater than ir_approach_speed");
  if (c.ir_braking_decel > c.max_linear_accel)
    n.fail("ir_braking_decel", "a deceleration no greater than max_linear_accel");

  const config::Node ws = n.child("workspace");
  c.workspace.min = vec3(ws, k::workspace::min);
  c.workspace.max = vec3(ws, k::workspace::max);
  c.workspace.min_reach = ws.get(k::workspace::min_reach);
  c.workspace.max_reach = ws.get(k::workspace::max_reach);
  if (!(c.workspace.min.array() < c.workspace.max.array()).all()) ws.fail("max", "every element greater than min");
  if (c.workspace.min_reach >= c.workspace.max_reach) ws.fail("max_reach", "a value greater than min_reach");
  // Goals outside the link's box would be clipped or refused there: the
  // controller would aim at fruit it can never reach. Refused at start.
  if (!envelope.contains_box(c.workspace.min, c.workspace.max))
    ws.fail("", fmt::format("a box inside the robot envelope's [{:g}, {:g}, {:g}]..[{:g}, {:g}, {:g}] ({}), got "
                            "[{:g}, {:g}, {:g}]..[{:g}, {:g}, {:g}]",
                            envelope.min.x(), envelope.min.y(), envelope.min.z(), envelope.max.x(), envelope.max.y(),
                            envelope.max.z(), n.get(k::envelope).string(), c.workspace.min.x(), c.workspace.min.y(),
                            c.workspace.min.z(), c.workspace.max.x(), c.workspace.max.y(), c.workspace.max.z()));

  // Home: the thesis experiment I start pose (table 6-5), gripper axis along base +y.
  c.home_pose = pose(n.child("home_pose"), k::pose::home_position, k::pose::home_orientation);
  c.drop_pose = pose(n.child("drop_pose"), k::pose::drop_position, k::pose::drop_orientation);
  if (!c.workspace.contains(c.home_pose.translation())) n.fail("home_pose", "a position inside the workspace");
  if (!c.workspace.contains(c.drop_pose.translation())) n.fail("drop_pose", "a position inside the workspace");

  const config::Node tz = n.child("tbz");
  c.tbz.lambda_w = tz.get(k::tbz::lambda_w);
  c.tbz.lambda_v = tz.get(k::tbz::lambda_v);
  c.tbz.desired_depth_estimate = tz.get(k::tbz::desired_depth_estimate);
  c.tbz.max_match_age_s = tz.get(k::tbz::max_match_age_s);
  c.tbz.fallback_after_s = tz.get(k::tbz::fallback_after_s);
  c.tbz.min_verified_share = tz.get(k::tbz::min_verified_share);
  c.tbz.desired_wait_s = tz.get(k::tbz::desired_wait_s);
  c.tbz.arrived_rotation = tz.get(k::tbz::arrived_rotation);
  c.tbz.arrived_translation = tz.get(k::tbz::arrived_translation);

  const config::Node sw = n.child("sway");
  namespace ks = k::sway;
  c.sway.window = sw.get(ks::window);
  c.sway.min_samples = sw.get(ks::min_samples);
  c.sway.min_span = sw.get(ks::min_span);
  c.sway.min_periods_seen = sw.get(ks::min_periods_seen);
  c.sway.min_frequency_hz = sw.get(ks::min_frequency_hz);
  c.sway.max_frequency_hz = sw.get(ks::max_frequency_hz);
  c.sway.frequency_step_hz = sw.get(ks::frequency_step_hz);
  c.sway.min_amplitude = sw.get(ks::min_amplitude);
  c.sway.max_amplitude = sw.get(ks::max_amplitude);
  c.sway.min_confidence = sw.get(ks::min_confidence);
  c.sway.learn_fruit = sw.get(ks::learn_fruit);
  c.sway.max_centre_offset = sw.get(ks::max_centre_offset);
  c.sway.close_delay = sw.get(ks::close_delay);
  c.sway.close_tolerance = sw.get(ks::close_tolerance);
  c.sway.hold_spread = sw.get(ks::hold_spread);
  c.sway.hold_standoff = sw.get(ks::hold_standoff);
  c.sway.at_standoff = sw.get(ks::at_standoff);
  c.sway.hold_time = sw.get(ks::hold_time);
  c.sway.hold_check = sw.get(ks::hold_check);
  c.sway.still_spread = sw.get(ks::still_spread);
  c.sway.max_wait = sw.get(ks::max_wait);
  c.sway.tree_window = sw.get(ks::tree_window);
  c.sway.tree_min_span = sw.get(ks::tree_min_span);
  c.sway.tree_min_fruit = sw.get(ks::tree_min_fruit);
  c.sway.tree_quantile = sw.get(ks::tree_quantile);
  c.sway.tree_still_rms = sw.get(ks::tree_still_rms);
  c.sway.tree_still_skips_hold = sw.get(ks::tree_still_skips_hold);
  if (c.sway.tree_min_span > c.sway.tree_window) sw.fail("tree_min_span", "a span no longer than tree_window");
  if (c.sway.max_frequency_hz < c.sway.min_frequency_hz)
    sw.fail("max_frequency_hz", "a frequency no lower than min_frequency_hz");

  const config::Node g = n.child("gains");
  c.gains.kp_lateral = g.get(k::gains::kp_lateral);
  c.gains.kd_lateral = g.get(k::gains::kd_lateral);
  c.gains.kp_depth = g.get(k::gains::kp_depth);
  c.gains.kd_depth = g.get(k::gains::kd_depth);
  c.gains.derivative_filter = g.get(k::gains::derivative_filter);
  c.gains.centring_tolerance = g.get(k::gains::centring_tolerance);
  c.gains.sway_window = g.get(k::gains::sway_window);
  c.gains.still_window = g.get(k::gains::still_window);
  c.gains.whole_views = g.get(k::gains::whole_views);
  c.gains.kp_orient = g.get(k::gains::kp_orient);
  c.gains.kd_orient = g.get(k::gains::kd_orient);

  const config::Node t = n.child("timeouts_s");
  namespace kt = k::timeouts_s;
  Timeouts& to = c.timeouts;
  for (auto [key, value] : {std::pair{&kt::select, &to.select},
                            {&kt::motion, &to.motion},
                            {&kt::stall, &to.stall},
                            {&kt::acquire, &to.acquire},
                            {&kt::lost, &to.lost},
                            {&kt::reacquire, &to.reacquire},
                            {&kt::approach, &to.approach},
                            {&kt::ir_approach, &to.ir_approach},
                            {&kt::grasp, &to.grasp},
                            {&kt::release, &to.release},
                            {&kt::robot_state, &to.robot_state},
                            {&kt::ir_stale, &to.ir_stale}})
    *value = t.get(*key);

  c.hand_camera = geometry::CameraModel::from_config(n, k::hand_camera_calibration);
  return c;
}

std::vector<config::Section> ServoConfig::schema() {
  namespace k = servo_keys;
  namespace g = k::gains;
  namespace t = k::timeouts_s;
  namespace w = k::workspace;
  const std::string where = "harvest-servo-controller, config/servo/controller.yaml (docs/servo-controller.md).";
  return {
      config::section(
          "servo_controller", where, k::tick_period_s, k::status_period_s, k::validity_s, k::envelope,
          k::hand_camera_calibration, k::approach_mode, k::orient_law, k::ir_switch_distance, k::ir_approach_speed,
          k::ir_braking_decel, k::ir_min_speed, k::ir_grasp_range, k::ir_max_travel, k::ir_overshoot,
          k::ir_surface_reach, k::ir_surface_travel, k::ir_surface_tolerance, k::ir_vision_agreement, k::ir_split_close, k::ir_split_max,
          k::front_fruit_tolerance, k::grasp_advance, k::grasp_stop_at_joint_limit, k::ir_fold_near, k::ir_fold_jump, k::ir_progress_step,
          k::ir_attempts, k::orient_tolerance, k::position_tolerance, k::retreat_distance, k::gone_in_distance, k::retreat_clearance,
          k::retrace_way_in, k::palm_offset, k::pull_distance, k::twist_angle, k::release_at_detach, k::release_while_retreating,
          k::pull_through, k::turn_while_retreating, k::turn_in_wind, k::turn_ahead_home_within, k::straight_to_next, k::home_after_joint_limit, k::release_opening, k::fruit_order,
          k::max_attempts_per_fruit, k::association_gate_px, k::association_tie_weight, k::association_tie_weight_doubtful, k::association_size_ratio, k::min_ahead_of_home,
          k::max_aim_angle, k::view_angle, k::view_distance, k::triangulation_gap, k::min_triangulation_angle,
          k::image_pose_gap, k::same_fruit_distance, k::same_sight_angle, k::reused_id_distance, k::size_agreement,
          k::size_agreement_min, k::crossing_beyond, k::fixed_depth_gap, k::fills_view, k::front_fruit_size_ratio,
          k::far_view_ahead, k::far_view_age, k::axis_fruit_area, k::whole_fruit_border_px, k::whole_min_visible, k::goal_progress_step, k::goal_progress_angle,
          k::goal_progress_joint_speed, k::in_view_margin, k::sight_aim_margin),
      config::section("servo_controller.workspace", where, w::min, w::max, w::min_reach, w::max_reach),
      config::section("servo_controller.home_pose", where, k::pose::home_position, k::pose::home_orientation),
      config::section("servo_controller.drop_pose", where, k::pose::drop_position, k::pose::drop_orientation),
      config::section("servo_controller.gains", where, g::kp_lateral, g::kd_lateral, g::kp_depth, g::kd_depth,
                      g::derivative_filter, g::centring_tolerance, g::sway_window, g::still_window, g::whole_views, g::kp_orient,
                      g::kd_orient),
      config::section("servo_controller.timeouts_s", where, t::select, t::motion, t::stall, t::acquire, t::lost,
                      t::reacquire, t::approach, t::ir_approach, t::grasp, t::release, t::robot_state, t::ir_stale),
      config::section("servo_controller.sway", where, k::sway::window, k::sway::min_samples, k::sway::min_span, k::sway::min_periods_seen,
                      k::sway::min_frequency_hz, k::sway::max_frequency_hz, k::sway::frequency_step_hz,
                      k::sway::min_amplitude, k::sway::max_amplitude, k::sway::min_confidence, k::sway::learn_fruit,
                      k::sway::max_centre_offset, k::sway::close_delay, k::sway::close_tolerance, k::sway::hold_spread,
                      k::sway::hold_standoff, k::sway::at_standoff, k::sway::hold_time, k::sway::hold_check, k::sway::still_spread,
                      k::sway::max_wait, k::sway::tree_window, k::sway::tree_min_span, k::sway::tree_min_fruit,
                      k::sway::tree_quantile, k::sway::tree_still_rms, k::sway::tree_still_skips_hold),
      config::section("servo_controller.tbz", where, k::tbz::lambda_w, k::tbz::lambda_v, k::tbz::desired_depth_estimate,
                      k::tbz::max_match_age_s, k::tbz::fallback_after_s, k::tbz::min_verified_share,
                      k::tbz::desired_wait_s, k::tbz::arrived_rotation, k::tbz::arrived_translation),
      security::AuthorityConfig::schema("servo_controller.authority", where, security::AuthorityConfig::kSender)};
}

}  // namespace harvest::servo
