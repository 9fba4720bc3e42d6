#include "servo/harvest/going_in.hpp"

#include <cmath>

#include "arm/fault_flags.hpp"
#include "servo/geometry.hpp"
#include "servo/harvest/status.hpp"

namespace harvest::servo {

GoingIn::GoingIn(const ServoConfig& config, std::unique_ptr<ApproachStrategy> approach)
    : cfg_(config), approach_(std::move(approach)), hand_(config), ir_(config), wind_(config.sway) {}

void GoingIn::new_fruit() {
  approach_->reset();
  approach_note_.clear();
  hand_.forget_fruit();
  wind_.new_fruit();
  close_wait_since_.reset();
}

void GoingIn::on_robot_state(const robot_state_t& msg) {
  if (cfg_.image_pose_gap > 0.0) camera_poses_.add(msg.header.utime, to_isometry(msg.camera_pose));
  ir_.on_joint_limit((msg.fault_flags & arm::kFlagJointLimit) != 0);
}

std::optional<Eigen::Isometry3d> GoingIn::camera_at(rt::Micros utime) const {
  if (cfg_.image_pose_gap <= 0.0) return std::nullopt;
  return camera_poses_.at(utime, rt::from_seconds(cfg_.image_pose_gap));
}

std::optional<PixelMeasurement> GoingIn::hand_pixel(rt::Micros now) const {
  auto pixel = hand_.fresh(now);
  if (pixel) pixel->camera = camera_at(pixel->utime);
  return pixel;
}

GoingIn::Step GoingIn::approach(rt::Micros now, const Eigen::Isometry3d& tool, const Eigen::Isometry3d& camera,
                                const Fruit& fruit) {
  Step s;
  const auto pixel = hand_pixel(now);
  if (!pixel) {
    s.action = Step::Action::kLost;
    return s;
  }
  if (!fruit.depth_doubtful && !cfg_.workspace.contains(fruit.estimate)) {
    // Measured by the camera-in-hand (eq. 6-15) where the arm may not go: beyond reach, or a neighbour's
    // fragment followed in a cluttered view; not certain, so it counts as one attempt.
    s.action = Step::Action::kOutOfReach;
    s.detail = "the camera-in-hand measures it outside the workspace";
    s.retreat = (tool.translation() - cfg_.home_pose.translation()).norm() > cfg_.gone_in_distance;
    return s;
  }
  const double remaining = ahead_along_axis(tool, fruit.estimate);
  std::string arrived_with;  // the strategy's own word on its arrival
  if (approach_->has_own_goal()) {
    // Teach by zooming: servoed to the zoomed view's pose, then IR guidance from wherever that is.
    const ApproachOutput a = approach_->update({now, tool, camera, fruit.estimate, pixel, std::nullopt});
    if (!a.note.empty() && a.note != approach_note_) s.note = approach_note_ = a.note;
    if (a.arrived ? !*a.arrived : remaining > cfg_.ir_switch_distance) {
      s.twist = a.twist;
      return s;
    }
    if (!a.note.empty()) arrived_with = a.note + "; ";  // how it got here (arrived, or fell back), in the IR line
  } else if (remaining > cfg_.ir_switch_distance) {
    s.twist = approach_->update({now, tool, camera, fruit.estimate, pixel, std::nullopt}).twist;
    return s;
  }
  ir_.begin(tool.translation(), now);
  close_wait_since_.reset();
  s.action = Step::Action::kIrBegins;
  s.note = arrived_with + "IR guidance from " + std::to_string(static_cast<int>(std::lround(remaining * 1000))) +
           " mm (" + depth_source(fruit.depth) + ")";
  return s;
}

void GoingIn::watch_sway(rt::Micros now, const Eigen::Isometry3d& tool, const Eigen::Isometry3d& camera,
                         const Fruit& fruit) {
  const auto pixel = hand_pixel(now);
  if (!pixel || !wind_.unseen(pixel->utime) || !hand_.whole()) return;
  // Whole fruit only: cut by the image border or filling the image, the centroid is not the fruit's centre.
  // Under IR guidance only: the camera is near, the fruit near the image centre, and the arm no longer turns or
  // sweeps sideways (earlier views, taken moving fast, showed a still fruit of experiment I swaying 21 mm at 0.28 Hz).
  // Across the gripper axis only (the close needs nothing else): along it, the hand camera's depth from the apparent
  // size errs by ~10 %, centimetres that would drown the sway. The axis keeps its direction from ORIENT on.
  const Eigen::Vector3d seen = seen_in_base(cfg_.hand_camera, camera, *pixel, fruit.estimate);
  const Eigen::Vector3d axis = tool.rotation().col(2);
  wind_.add(pixel->utime, seen - axis.dot(seen) * axis);
}

GoingIn::Step GoingIn::ir(rt::Micros now, const Eigen::Isometry3d& tool, const Eigen::Isometry3d& camera,
                          const Fruit& fruit) {
  Step s;
  const auto word = [&s](const std::optional<std::string>& note) {
    if (note) s.note = note;
  };
  // Waiting to close on a swaying fruit: the IR said "inside" already (its reading changes as the fruit swings).
  IrStep i{IrStep::Action::kClose, 0.0, 0.0, std::nullopt};
  if (!close_wait_since_) {
    // Whether to stand off the fruit now, and how far (WindWatch::hold).
    const WindWatch::Hold h = wind_.hold(now, ahead_along_axis(tool, fruit.estimate), fruit.depth, hand_.whole());
    word(h.note);
    i = ir_.step(now, tool, fruit, hand_.fruit_in_front(now), h.standoff, hand_.seen_whole(now),
                 hand_.fruit_on_axis(now));
  }
  word(i.note);
  switch (i.action) {
    case IrStep::Action::kFruitInTheWay:
      s.action = Step::Action::kFruitInTheWay;
      s.detail = "a fruit in the way, " + std::to_string(std::lround(i.offset * 1000)) + " mm off the gripper axis";
      break;
    case IrStep::Action::kClose: {
      // A swaying fruit: closed on when it is predicted on the gripper axis as the jaws meet; held still until then.
      if (!close_wait_since_) close_wait_since_ = now;
      const WindWatch::Close c = wind_.close(now, tool, rt::to_seconds(now - *close_wait_since_), cfg_.tick_period_s);
      if (!c.decision.close) break;
      word(c.note);
      ir_.closing_at(tool.translation());
      close_wait_since_.reset();
      s.action = Step::Action::kClose;
      break;
    }
    case IrStep::Action::kGiveUp:
      s.action = Step::Action::kGiveUp;
      break;
    case IrStep::Action::kHold:
      break;  // never advance blind
    case IrStep::Action::kAdvance:
      s.twist = approach_
                    ->update({now, tool, camera, fruit.estimate, hand_pixel(now), i.forward_speed,
                              wind_.tree_still(now) ? cfg_.gains.still_window : cfg_.gains.sway_window, hand_.whole()})
                    .twist;
      break;
  }
  return s;
}

}  // namespace harvest::servo
