// The way in to the current fruit: APPROACH (the camera-in-hand servo, eq. 6-25..6-28, until ir_switch_distance)
// and IR_APPROACH (the last centimetres, thesis HarvestStep5) up to the close. It follows the fruit in the hand
// image (HandTracker), runs the approach strategy, IR guidance (IrGuidance) and the wind's watch (WindWatch), and
// knows where the camera-in-hand was when it took each image. Each step says what the sequencer is to do next
// (GoingIn::Step); the states, their entry and the commands stay the sequencer's.
#pragma once

#include <Eigen/Geometry>
#include <memory>
#include <optional>
#include <string>

#include "geometry/pose_history.hpp"
#include "harvest/fruit_detections_t.hpp"
#include "harvest/ir_range_t.hpp"
#include "harvest/robot_state_t.hpp"
#include "harvest/targets_t.hpp"
#include "runtime/clock.hpp"
#include "servo/approach.hpp"
#include "servo/harvest/fruit.hpp"
#include "servo/harvest/hand_tracker.hpp"
#include "servo/harvest/ir_guidance.hpp"
#include "servo/harvest/wind.hpp"
#include "servo/servo_config.hpp"

namespace harvest::servo {

class GoingIn {
 public:
  GoingIn(const ServoConfig& config, std::unique_ptr<ApproachStrategy> approach);

  struct Step {
    enum class Action {
      kMove,           // send `twist` (zero: hold still)
      kLost,           // the fruit is not (or no longer) in the hand image: REACQUIRE, holding still
      kOutOfReach,     // the camera-in-hand measures it outside the workspace: UNREACHABLE (`retreat` first)
      kIrBegins,       // within ir_switch_distance: IR_APPROACH, its first step at once
      kFruitInTheWay,  // a nearer fruit fills the view beside the axis: this attempt given up (FAILED_GRASP)
      kClose,          // the fruit is inside (and, if swaying, due on the axis): close the gripper, GRASP
      kGiveUp,         // out of travel, past the fruit or blocked: as the IR_APPROACH timeout
    } action = Action::kMove;
    Twist twist;                      // kMove
    std::string detail;               // kOutOfReach, kFruitInTheWay: the outcome's detail
    bool retreat = false;             // kOutOfReach: the tool has gone in, back out along its axis first
    std::optional<std::string> note;  // the step's last word for HARVEST_STATUS, if it has one
  };

  // Inputs. A new current fruit: the strategy starts again, the followed detection, the fruit's views and its
  // hold are forgotten ...
  void new_fruit();
  // ... a fruit given up: the followed detection only.
  void forget_fruit() { hand_.forget_fruit(); }
  // Every ROBOT_STATE: the camera-in-hand's pose by time (image_pose_gap).
  void on_robot_state(const robot_state_t& msg);
  // FRUIT_HAND and the hand camera's TARGETS while following `fruit`; `camera`: the newest camera pose, used when
  // the one at the image's time is not known. A hand target may re-estimate the fruit (eq. 6-15).
  void on_hand_detections(const fruit_detections_t& msg, const Fruit& fruit, const Eigen::Isometry3d& camera,
                          rt::Micros now) {
    hand_.on_detections(msg, fruit, camera_at(msg.header.utime).value_or(camera), now);
  }
  void on_hand_targets(const targets_t& msg, Fruit& fruit, const Eigen::Isometry3d& camera, rt::Micros now) {
    hand_.on_hand_targets(msg, fruit, camera_at(msg.header.utime).value_or(camera), now);
  }
  void on_fixed(const targets_t& msg, rt::Micros now) { wind_.on_fixed(msg, now); }
  // Every IR_RANGE; `guiding`: in IR_APPROACH. The fold-back rule (a near reading, then a far one: the fruit
  // inside) is not for a fruit seen to sway: it swings out of the beam as well, and in tree_wind every close the
  // rule made closed beside or short of one.
  void on_ir(const ir_range_t& msg, rt::Micros now, bool guiding) {
    ir_.on_reading(msg, now, guiding && wind_.fold_back_allowed());
  }

  // The fixed camera's gauge says the tree is still (WindWatch::tree_still).
  bool tree_still(rt::Micros now) const { return wind_.tree_still(now); }
  // ACQUIRE, REACQUIRE: the fruit is followed in a hand image taken in after `since`.
  bool seen_since(rt::Micros now, rt::Micros since) const { return hand_.fresh(now) && hand_.seen_at() > since; }
  // One APPROACH step toward `fruit`, the tool at `tool` and the camera-in-hand at `camera`.
  Step approach(rt::Micros now, const Eigen::Isometry3d& tool, const Eigen::Isometry3d& camera, const Fruit& fruit);
  // IR_APPROACH: a new hand view of the fruit goes to the sway estimator (each tick, before ir(); not on the step
  // that begins IR guidance) ...
  void watch_sway(rt::Micros now, const Eigen::Isometry3d& tool, const Eigen::Isometry3d& camera, const Fruit& fruit);
  // ... and one IR-guided step.
  Step ir(rt::Micros now, const Eigen::Isometry3d& tool, const Eigen::Isometry3d& camera, const Fruit& fruit);
  // GRASP: on along the tool axis while the fingers close (IrGuidance::grasp_twist); nullopt: STOP.
  std::optional<Twist> grasp_twist(const Eigen::Isometry3d& tool) const { return ir_.grasp_twist(tool); }

  // The IR attempts: another one left; where the first began (a back-off retraces the axis to abreast of it);
  // the next one begins with the tool at `tool`.
  bool attempts_left() const { return ir_.attempts_left(); }
  const Eigen::Vector3d& ir_start() const { return ir_.start(); }
  void retry(const Eigen::Vector3d& tool, rt::Micros now) {
    ir_.retry(tool, now);
    close_wait_since_.reset();
  }

  ApproachStrategy& strategy() { return *approach_; }
  const ApproachStrategy& strategy() const { return *approach_; }

 private:
  // The camera-in-hand when it took the image of `utime` (image_pose_gap), if the robot states around it are known.
  std::optional<Eigen::Isometry3d> camera_at(rt::Micros utime) const;
  // The followed centroid of the fruit, if fresh, with the camera pose it was seen from.
  std::optional<PixelMeasurement> hand_pixel(rt::Micros now) const;

  ServoConfig cfg_;
  std::unique_ptr<ApproachStrategy> approach_;
  std::string approach_note_;  // the strategy's last note (shown once per change)
  HandTracker hand_;
  IrGuidance ir_;
  WindWatch wind_;                              // the fruit's sway and the tree's, the hold, the timed close
  std::optional<rt::Micros> close_wait_since_;  // IR said "inside", the close waits for the swaying fruit
  geometry::PoseHistory camera_poses_{64};      // ROBOT_STATE camera poses by their utime (about 0.6 s at 100 Hz)
};

}  // namespace harvest::servo
