// The current fruit and the tree in the wind, for IR guidance: the sway seen by
// the camera-in-hand (SwayEstimator), whether the tree sways at all as the
// fixed camera sees it (TreeSwayGauge), the hold (a fruit seen to sway is
// watched from the standoff, the arm at rest, until the mean over which the
// centring aims spans whole periods) and the timed close (docs/servo-controller.md,
// "A fruit in the wind"). The machine decides when these apply; this part
// keeps what they saw and says what they conclude, with the status note.
#pragma once

#include <Eigen/Geometry>
#include <optional>
#include <string>

#include "harvest/targets_t.hpp"
#include "runtime/clock.hpp"
#include "servo/harvest/fruit.hpp"
#include "servo/harvest/sway.hpp"
#include "servo/harvest/tree_sway.hpp"
#include "servo/servo_config.hpp"

namespace harvest::servo {

class WindWatch {
 public:
  explicit WindWatch(const ServoConfig::Sway& params) : p_(params), sway_(params), tree_(params) {}

  // A valid fixed-camera TARGETS, taken in at `now`.
  void on_fixed(const targets_t& msg, rt::Micros now) {
    tree_.add(msg);
    fixed_rx_ = now;
  }
  // A new fruit: its views and its hold forgotten (not the frequency learned on earlier fruit).
  void new_fruit();
  // A hand image not given to the estimator yet (by its utime).
  bool unseen(int64_t image_utime) const { return image_utime > fed_; }
  // Where the camera-in-hand saw the current fruit in that image, across the gripper axis [m, base frame].
  void add(int64_t image_utime, const Eigen::Vector3d& across_axis);

  // The fixed camera's gauge says the tree is still, from TARGETS no older than its window.
  bool tree_still(rt::Micros now) const;
  // The IR's fold-back rule may close: the fruit has not been seen to sway (or was seen still while held); a
  // swaying fruit swings out of the beam as well.
  bool fold_back_allowed() const { return still_after_all_ || sway_.spread() <= p_.hold_spread; }

  struct Hold {
    std::optional<double> standoff;   // [m] stand off the fruit this far ahead of the tool point; none: go on
    std::optional<std::string> note;  // for HARVEST_STATUS, when something changed
  };
  // Under IR guidance: whether to stand off the current fruit now. `ahead`: its estimate ahead of the tool point
  // [m]; `depth`: where that estimate's depth comes from; `whole`: the followed fruit is whole in the hand image.
  // Once per fruit: after the hold (or a verdict that none is needed), nullopt until new_fruit().
  Hold hold(rt::Micros now, double ahead, Fruit::Depth depth, bool whole);

  struct Close {
    CloseDecision decision;
    std::optional<std::string> note;  // how a swaying fruit was timed, when the close goes out
  };
  // The IR says the fruit is inside, `waited_s` ago: close now or wait for the swaying fruit to come onto the
  // axis (a still tree: at once, as without wind).
  Close close(rt::Micros now, const Eigen::Isometry3d& tool, double waited_s, double step_s) const;

 private:
  ServoConfig::Sway p_;
  SwayEstimator sway_;
  TreeSwayGauge tree_;
  rt::Micros fixed_rx_ = 0;               // the newest fixed-camera TARGETS taken in
  int64_t fed_ = 0;                       // the newest hand image the estimator has (its utime)
  std::optional<rt::Micros> hold_since_;  // standing off the swaying current fruit since ...
  bool held_ = false;                     // ... and done: it has been watched (once per fruit)
  bool still_after_all_ = false;          // ... and seen still while held (hold_check): no swaying fruit
};

}  // namespace harvest::servo
