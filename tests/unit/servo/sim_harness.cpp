#include "sim_harness.hpp"

#include <algorithm>
#include <cmath>

#include "arm/fault_flags.hpp"
#include "harvest/fruit_detections_t.hpp"
#include "harvest/gripper_state_t.hpp"
#include "harvest/ir_range_t.hpp"
#include "harvest/targets_t.hpp"
#include "runtime/channels.hpp"
#include "servo/geometry.hpp"
#include "servo/motion_limits.hpp"

namespace harvest::servo::testing {

namespace ch = harvest::channels;

// ---------------------------------------------------------------- arm

ArmDouble::ArmDouble(const WorldSpec& spec) : rt::Node("arm-double"), spec_(spec), tool_(spec.start_tool) {}

Eigen::Isometry3d ArmDouble::camera() const {
  Eigen::Isometry3d c = tool_;
  c.translation() -= spec_.camera_behind_tcp * tool_.rotation().col(2);
  return c;
}

Eigen::Isometry3d ArmDouble::camera_at(rt::Micros t) const {
  for (auto it = cameras_.rbegin(); it != cameras_.rend(); ++it)
    if (it->first <= t) return it->second;
  return cameras_.empty() ? camera() : cameras_.front().second;
}

void ArmDouble::on_attach() {
  start_ = now();
  advertise(ch::kRobotState);
  subscribe<robot_command_t>(ch::kRobotCommand, [this](const robot_command_t& c) {
    cmd_ = c;
    cmd_rx_ = now();
  });
  // Phase-shifted from the controller's 20 ms ticks so no two events tie.
  ctx().add_timer(now() + 3 * rt::kMilli, 10 * rt::kMilli, [this] { step(); });
  step();
}

bool ArmDouble::wide_turn_in_place(const Eigen::Isometry3d& goal) const {
  return (goal.translation() - tool_.translation()).norm() < 0.01 &&
         Eigen::AngleAxisd(goal.rotation() * tool_.rotation().transpose()).angle() > *spec_.arm_max_turn_in_place;
}

void ArmDouble::step() {
  const double dt = 0.01;
  const double t = rt::to_seconds(now() - start_);
  if (spec_.robot_fault_after_s && t >= *spec_.robot_fault_after_s) fault_ = true;
  const bool estopped = spec_.robot_estop_after_s && t >= *spec_.robot_estop_after_s;
  if (estopped) fault_ = true;  // a stopped arm either way; reported as MODE_ESTOP below
  if (spec_.robot_silent_after_s && t >= *spec_.robot_silent_after_s) return;
  const bool valid = cmd_ && now() - cmd_rx_ <= cmd_->validity_us && !fault_;
  const bool pose_goal = valid && cmd_->type == robot_command_t::TYPE_POSE_GOAL;
  if (pose_goal && cmd_->goal_id != last_goal_id_) {
    last_goal_id_ = cmd_->goal_id;
    goal_refused_ = refused_goals_ < spec_.arm_refuses_next_goals;
    if (goal_refused_) ++refused_goals_;
  }
  const bool refused = pose_goal && goal_refused_;
  Eigen::Vector3d v = Eigen::Vector3d::Zero(), w = Eigen::Vector3d::Zero();
  if (valid && cmd_->type == robot_command_t::TYPE_TWIST) {
    v = Eigen::Vector3d(cmd_->twist.linear[0], cmd_->twist.linear[1], cmd_->twist.linear[2]);
    w = Eigen::Vector3d(cmd_->twist.angular[0], cmd_->twist.angular[1], cmd_->twist.angular[2]);
  } else if (pose_goal && !refused && !(spec_.arm_ignores_goals_after_s && t >= *spec_.arm_ignores_goals_after_s) &&
             !(spec_.arm_max_turn_in_place && wide_turn_in_place(to_isometry(cmd_->pose_goal)))) {
    const Eigen::Isometry3d goal = to_isometry(cmd_->pose_goal);
    const Eigen::Vector3d dp = goal.translation() - tool_.translation();
    v = clamp_norm(dp / dt, cmd_->max_linear_speed);
    if (!first_goal_id_) first_goal_id_ = cmd_->goal_id;
    if (spec_.arm_first_goal_stops_short_m && cmd_->goal_id == *first_goal_id_)
      v = clamp_norm(v, std::max(0.0, dp.norm() - *spec_.arm_first_goal_stops_short_m) / dt);
    const Eigen::AngleAxisd err(goal.rotation() * tool_.rotation().transpose());
    w = clamp_norm(err.axis() * err.angle() / dt, cmd_->max_angular_speed);
  }
  if (spec_.arm_blocked_after_s && t >= *spec_.arm_blocked_after_s) v = w = Eigen::Vector3d::Zero();
  tool_.translation() += v * dt;
  if (w.norm() > 0) tool_.linear() = Eigen::AngleAxisd(w.norm() * dt, w.normalized()) * tool_.rotation();

  robot_state_t s{};
  s.header.utime = now();
  s.header.source_seq = -1;
  s.header.frame_id = "base";
  s.mode = estopped ? robot_state_t::MODE_ESTOP
           : fault_ ? robot_state_t::MODE_FAULT
                    : (valid ? robot_state_t::MODE_MOVING : robot_state_t::MODE_IDLE);
  s.num_joints = 0;
  s.tool_pose = to_pose(tool_);
  s.camera_pose = to_pose(camera());
  cameras_.emplace_back(now(), camera());
  while (cameras_.front().first < now() - rt::kSecond) cameras_.pop_front();
  s.tool_twist = to_twist(v, w);
  s.fault_text = fault_ ? "joint 2 following error" : "";
  if (refused) s.fault_flags |= arm::kFlagRefused;
  if (spec_.arm_joint_limit_in_twists && valid && cmd_->type == robot_command_t::TYPE_TWIST && v.norm() > 0.0)
    s.fault_flags |= arm::kFlagJointLimit | arm::kFlagLimited;
  publish(ch::kRobotState, s);
}

// ---------------------------------------------------------------- world

WorldDouble::WorldDouble(const WorldSpec& spec, const ArmDouble& arm)
    : rt::Node("world-double"), spec_(spec), arm_(arm), where_(spec.fruits.size(), Where::kTree), rng_(spec.seed) {}

bool WorldDouble::fruit_picked(int id) const {
  for (std::size_t i = 0; i < spec_.fruits.size(); ++i)
    if (spec_.fruits[i].id == id) return where_[i] == Where::kDropped;
  return false;
}

void WorldDouble::on_attach() {
  start_ = now();
  advertise(ch::kTargets);
  advertise(ch::kFruitHand);
  advertise(ch::kIrRange);
  advertise(ch::kGripperState);
  subscribe<gripper_command_t>(ch::kGripperCommand, [this](const gripper_command_t& c) {
    if (c.action == gripper_command_t::ACTION_CLOSE) {
      gripper_ = gripper_state_t::STATE_CLOSING;
      closing_since_ = now();
      close_position_ = arm_.tool().translation();
    } else if (c.action == gripper_command_t::ACTION_OPEN && !spec_.gripper_wont_open) {
      gripper_ = spec_.gripper_open_s > 0.0 ? gripper_state_t::STATE_OPENING : gripper_state_t::STATE_OPEN;
      opening_since_ = now();
      for (auto& w : where_)
        if (w == Where::kGripper) w = Where::kDropped;
    }
  });
  // Odd phases: never at the same time as a controller tick (multiples of 10 ms).
  ctx().add_timer(now() + 7 * rt::kMilli, 100 * rt::kMilli, [this] { publish_fixed(); });
  ctx().add_timer(now() + 11 * rt::kMilli, 30 * rt::kMilli, [this] { publish_hand(); });
  ctx().add_timer(now() + 13 * rt::kMilli, 20 * rt::kMilli, [this] { publish_ir(); });
  ctx().add_timer(now() + 17 * rt::kMilli, 50 * rt::kMilli, [this] { publish_gripper(); });
}

Eigen::Vector3d WorldDouble::position(std::size_t i, rt::Micros t) const {
  const FruitTruth& f = spec_.fruits[i];
  return f.position + std::sin(2.0 * M_PI * f.sway_hz * rt::to_seconds(t - start_) + f.sway_phase) * f.sway;
}

int WorldDouble::fixed_id(std::size_t i) const {
  if (!spec_.fixed_ids_follow_order) return spec_.fruits[i].id;
  std::size_t k = 0;
  for (std::size_t j = 0; j < i; ++j)
    if (where_[j] == Where::kTree) ++k;
  return spec_.fruits[k].id;
}

void WorldDouble::publish_fixed() {
  if (spec_.fixed_camera_silent) return;
  targets_t m{};
  m.header.utime = now();
  m.header.frame_id = "base";
  m.header.source_seq = -1;
  m.source_camera = "fixed";
  m.selected_fruit_id = -1;
  m.camera_known = !spec_.fixed_camera_unknown;
  for (int k = 0; k < 3 && m.camera_known; ++k) m.camera_position_base[k] = spec_.fixed_camera[k];
  for (std::size_t i = 0; i < spec_.fruits.size(); ++i) {
    if (where_[i] != Where::kTree) continue;
    const auto& f = spec_.fruits[i];
    target_t t{};
    const bool renumbered =
        spec_.fixed_ids_change_after_s && rt::to_seconds(now() - start_) >= *spec_.fixed_ids_change_after_s;
    t.fruit_id = renumbered ? f.id + 1000 : fixed_id(i);
    t.source_camera = "fixed";
    std::uniform_real_distribution<double> jitter(-spec_.fixed_depth_jitter, spec_.fixed_depth_jitter);
    const double scale = spec_.fixed_depth_scale + (spec_.fixed_depth_jitter > 0 ? jitter(rng_) : 0.0);
    const Eigen::Vector3d p = spec_.fixed_camera + scale * (position(i) + spec_.fixed_error - spec_.fixed_camera);
    for (int k = 0; k < 3; ++k) t.position_base[k] = p[k];
    t.covariance_base[0] = t.covariance_base[4] = t.covariance_base[8] = 0.05 * 0.05;
    t.diameter_m = 0.075;
    // Its image: a pinhole (f 300 px, 320 x 240) at fixed_camera looking along base +y, toward the tree; what
    // the controller's tree gauge reads (the fruit's true position: the detector's centroid does not scale).
    const Eigen::Vector3d seen = position(i) - spec_.fixed_camera;
    if (seen.y() > 0.05) {
      t.u_px = static_cast<float>(160.0 + 300.0 * seen.x() / seen.y());
      t.v_px = static_cast<float>(120.0 + 300.0 * seen.z() / seen.y());
      t.diameter_px = static_cast<float>(300.0 * f.diameter / seen.y());
    }
    t.confidence = 1.0f;
    t.cost = static_cast<float>(i);
    m.targets.push_back(t);
  }
  m.num_targets = static_cast<int32_t>(m.targets.size());
  publish(ch::kTargets, m);
}

void WorldDouble::publish_hand() {
  const double t = since_start();
  bool hidden = spec_.hide_hand_after_s && t >= *spec_.hide_hand_after_s;
  if (hidden && spec_.hide_hand_for_s && t >= *spec_.hide_hand_after_s + *spec_.hide_hand_for_s) hidden = false;
  // The image was taken hand_latency_s ago, from where the camera was then.
  const rt::Micros taken = now() - rt::from_seconds(spec_.hand_latency_s);
  const Eigen::Isometry3d cam = arm_.camera_at(taken);
  const geometry::CameraModel& k = spec_.true_hand;
  fruit_detections_t det{};
  det.header.utime = taken;
  det.header.frame_id = "camera_hand";
  det.header.source_seq = -1;
  det.camera = "hand";
  det.image_width = k.width;
  det.image_height = k.height;
  det.status = fruit_detections_t::STATUS_OK;
  det.selected_index = -1;
  targets_t tg{};
  tg.header = det.header;
  tg.source_camera = "hand";
  tg.selected_fruit_id = -1;
  tg.camera_known = true;
  for (int k = 0; k < 3; ++k) tg.camera_position_base[k] = cam.translation()[k];
  std::uniform_real_distribution<double> noise(-spec_.pixel_noise, spec_.pixel_noise);
  for (std::size_t i = 0; i < spec_.fruits.size() && !hidden; ++i) {
    if (where_[i] != Where::kTree) continue;
    const auto& f = spec_.fruits[i];
    const Eigen::Vector3d pc = cam.inverse() * position(i, taken);
    Eigen::Vector2d px;
    if (pc.z() < 0.05 || !project_point(k, pc, px)) continue;
    const double diameter_px = k.fx * f.diameter / pc.z();
    if (px.x() < 0 || px.y() < 0 || px.x() >= k.width || px.y() >= k.height ||
        (diameter_px > 0.9 * k.width && !spec_.hand_reports_filling))
      continue;
    px += Eigen::Vector2d(noise(rng_), noise(rng_));
    fruit_t d{};
    d.id = static_cast<int32_t>(100 + i);  // the hand detector's own track id
    d.u_px = static_cast<float>(px.x());
    d.v_px = static_cast<float>(px.y());
    d.diameter_px = static_cast<float>(diameter_px);
    // Bounding box of the visible part, clipped to the image.
    const double x0 = std::max(0.0, px.x() - diameter_px / 2), y0 = std::max(0.0, px.y() - diameter_px / 2);
    const double x1 = std::min<double>(k.width, px.x() + diameter_px / 2);
    const double y1 = std::min<double>(k.height, px.y() + diameter_px / 2);
    d.bbox_px[0] = static_cast<int32_t>(x0);
    d.bbox_px[1] = static_cast<int32_t>(y0);
    d.bbox_px[2] = static_cast<int32_t>(x1 - x0);
    d.bbox_px[3] = static_cast<int32_t>(y1 - y0);
    d.confidence = 1.0f;
    det.fruits.push_back(d);
    // The reconstructor: the software's calibration and a biased depth (eq. 6-14, 6-15).
    const Eigen::Vector2d m = undistort_pixel(spec_.assumed_hand, px.x(), px.y());
    double z = pc.z() * spec_.hand_depth_scale;
    if (spec_.hand_depth_error_when_filling && diameter_px > 0.8 * k.height) z += *spec_.hand_depth_error_when_filling;
    const Eigen::Vector3d est_cam(m.x() * z, m.y() * z, z);
    const Eigen::Vector3d est_base = cam * est_cam;
    target_t ht{};
    // Associated with the fixed-camera track, unless the reconstructor's 3D match failed.
    ht.fruit_id = spec_.hand_ids_unassociated ? 100000 + static_cast<int32_t>(i) : fixed_id(i);
    ht.source_camera = "hand";
    for (int j = 0; j < 3; ++j) {
      ht.position_base[j] = est_base[j];
      ht.position_camera[j] = est_cam[j];
    }
    ht.depth_m = z;
    ht.u_px = d.u_px;
    ht.v_px = d.v_px;
    ht.diameter_px = d.diameter_px;
    tg.targets.push_back(ht);
  }
  det.num_fruits = static_cast<int32_t>(det.fruits.size());
  tg.num_targets = static_cast<int32_t>(tg.targets.size());
  publish(ch::kFruitHand, det);
  publish(ch::kTargets, tg);
}

void WorldDouble::publish_ir() {
  const Eigen::Isometry3d tool = arm_.tool();
  const Eigen::Vector3d axis = tool.rotation().col(2);
  const Eigen::Vector3d sensor = tool.translation() - spec_.ir_behind_tcp * axis;
  double range = 1e9;
  for (std::size_t i = 0; i < spec_.fruits.size() && !spec_.ir_dead; ++i) {
    if (where_[i] != Where::kTree) continue;
    const Eigen::Vector3d d = position(i) - sensor;
    const double along = d.dot(axis);
    const double lateral = (d - along * axis).norm();
    const double r = spec_.fruits[i].diameter / 2;
    if (along > 0 && lateral < 0.7 * r) range = std::min(range, along - std::sqrt(r * r - lateral * lateral));
  }
  if (spec_.leaf_before_fruit_m && !spec_.fruits.empty() && where_[0] == Where::kTree) {
    const Eigen::Vector3d f = position(0);
    const Eigen::Vector3d leaf = f - *spec_.leaf_before_fruit_m * (f - spec_.start_tool.translation()).normalized();
    const Eigen::Vector3d d = leaf - sensor;
    const double along = d.dot(axis);
    if (along > 0 && (d - along * axis).norm() < 0.03) range = std::min(range, along);
  }
  if (spec_.ir_fold_back_below_m && range < *spec_.ir_fold_back_below_m) range = 0.3;
  ir_range_t m{};
  m.header.utime = now();
  m.header.frame_id = "ir";
  m.header.source_seq = -1;
  m.validity = range < 0.01 ? ir_range_t::TOO_NEAR : range > 0.5 ? ir_range_t::TOO_FAR : ir_range_t::VALID;
  m.range_m = static_cast<float>(std::clamp(range, 0.01, 0.5));
  m.raw = static_cast<int32_t>(1000.0 / m.range_m);
  publish(ch::kIrRange, m);
}

void WorldDouble::publish_gripper() {
  const bool faulty = spec_.gripper_fault_after_s && since_start() >= *spec_.gripper_fault_after_s;
  if (gripper_ == gripper_state_t::STATE_CLOSING && now() - closing_since_ >= 300 * rt::kMilli &&
      !spec_.gripper_stuck) {
    gripper_ = gripper_state_t::STATE_CLOSED;
    const bool misses = spec_.gripper_misses || ++closures_ <= spec_.gripper_misses_first;
    for (std::size_t i = 0; i < spec_.fruits.size() && !misses; ++i) {
      if (where_[i] != Where::kTree) continue;
      const Eigen::Vector3d offset = position(i) - arm_.tool().translation();
      if (i == 0) closed_offset_ = arm_.tool().rotation().transpose() * offset;
      if (offset.norm() < 0.03) {
        where_[i] = Where::kGripper;
        gripper_ = gripper_state_t::STATE_HOLDING;
        holding_since_ = now();
      }
    }
  }
  if (spec_.fruit_slips && gripper_ == gripper_state_t::STATE_HOLDING && now() - holding_since_ >= 200 * rt::kMilli) {
    gripper_ = gripper_state_t::STATE_CLOSED;
    for (auto& w : where_)
      if (w == Where::kGripper) w = Where::kFallen;
  }
  const double opened =
      spec_.gripper_open_s > 0.0 ? rt::to_seconds(now() - opening_since_) / spec_.gripper_open_s : 1.0;
  if (gripper_ == gripper_state_t::STATE_OPENING && opened >= 1.0) gripper_ = gripper_state_t::STATE_OPEN;
  gripper_state_t s{};
  s.header.utime = now();
  s.header.frame_id = "gripper";
  s.header.source_seq = -1;
  const bool gone = spec_.gripper_disconnect_after_s && since_start() >= *spec_.gripper_disconnect_after_s;
  s.state = gone ? gripper_state_t::STATE_DISCONNECTED : faulty ? gripper_state_t::STATE_FAULT : gripper_;
  s.position = gripper_ == gripper_state_t::STATE_OPEN      ? 1.0f
               : gripper_ == gripper_state_t::STATE_OPENING ? static_cast<float>(opened)
                                                            : 0.0f;
  s.connected = !gone;
  s.fault_code = faulty ? 7 : 0;
  s.fault_text = faulty ? "motor overcurrent" : "";
  publish(ch::kGripperState, s);
}

// ---------------------------------------------------------------- scenarios

Eigen::Isometry3d thesis_start_pose() {
  Eigen::Isometry3d t = Eigen::Isometry3d::Identity();
  // z along base +y, image y down (base +x): the controller's home orientation.
  t.linear() = Eigen::Quaterniond(0.5, -0.5, -0.5, -0.5).toRotationMatrix();
  t.translation() = Eigen::Vector3d(-0.655, 0.785, -0.251);
  return t;
}

ServoConfig test_config() {
  const auto doc = config::Document::load_string("{}");
  ServoConfig c = ServoConfig::from_yaml(doc.root());
  // One attempt per fruit: each failure path is seen once; the tests of the
  // retry ask for more.
  c.max_attempts_per_fruit = 1;
  return c;
}

WorldSpec experiment_one() {
  WorldSpec w;
  w.fruits.push_back({1, Eigen::Vector3d(-0.2286, 1.0668, -0.5402), 0.075});  // table 6-3
  w.start_tool = thesis_start_pose();                                         // table 6-5
  w.assumed_hand = test_config().hand_camera;
  w.true_hand = w.assumed_hand;
  w.true_hand.fx *= 1.04;  // the real lens differs from its calibration
  w.true_hand.fy *= 0.97;
  w.true_hand.cx += 6.0;
  w.true_hand.cy -= 4.0;
  // Table 6-4 estimate minus table 6-3 truth: (-237, 1060, -395) - (-228.6, 1066.8, -540.2) mm.
  w.fixed_error = Eigen::Vector3d(-0.0084, -0.0068, 0.1452);
  w.hand_depth_scale = 1.08;
  return w;
}

}  // namespace harvest::servo::testing
