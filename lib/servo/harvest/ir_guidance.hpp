// IR_APPROACH, the last centimetres (thesis HarvestStep5): when the IR
// reading says the fruit is inside the gripper, when a reading is a leaf in
// front of the fruit (or may be either: then close between the two), when a
// nearer fruit is in the way, how fast to go on, and when an attempt has run
// out of travel or is blocked.
#pragma once

#include <Eigen/Geometry>
#include <optional>
#include <string>
#include <utility>

#include "harvest/ir_range_t.hpp"
#include "runtime/clock.hpp"
#include "servo/harvest/fruit.hpp"
#include "servo/motion_limits.hpp"
#include "servo/servo_config.hpp"

namespace harvest::servo {

struct IrStep {
  enum class Action {
    kClose,          // the fruit is inside: STOP, close the gripper
    kFruitInTheWay,  // a nearer fruit fills the view beside the axis: give this attempt up
    kGiveUp,         // out of travel, past the fruit (the IR reading nothing that stays put ahead) or blocked
    kHold,           // no fresh IR reading: never advance blind
    kAdvance,        // go on, centring, at forward_speed
  } action = Action::kHold;
  double forward_speed = 0.0;       // [m/s] kAdvance
  double offset = 0.0;              // [m] kFruitInTheWay: the nearer fruit's centre off the gripper axis
  std::optional<std::string> note;  // set once per attempt when going on past a leaf
};

class IrGuidance {
 public:
  explicit IrGuidance(ServoConfig config) : cfg_(std::move(config)) {}

  // IR guidance begins with the tool at `tool` (first attempt) ...
  void begin(const Eigen::Vector3d& tool, rt::Micros now);
  // ... or begins again after a back-off (the travel still counts from where the first began).
  void retry(const Eigen::Vector3d& tool, rt::Micros now);
  int attempt() const { return attempt_; }
  bool attempts_left() const { return attempt_ < cfg_.ir_attempts; }
  // Where the first attempt began: a back-off retraces the tool axis to abreast of it.
  const Eigen::Vector3d& start() const { return start_; }

  // Every IR_RANGE message; `guiding`: the controller is in IR_APPROACH.
  void on_reading(const ir_range_t& msg, rt::Micros now, bool guiding);

  // One control step toward `fruit` with the tool at `tool`; `fruit_in_front`
  // (from the hand tracker): a nearer fruit fills the view, its centre this
  // far off the axis. `hold_at`: stop this far short of the fruit's centre
  // (braking at ir_braking_decel; the tool standing there is not blocked).
  // `seen_whole` (from the hand tracker): the fruit is whole in a fresh hand
  // image, so its estimate's depth is current (ServoConfig::far_view_ahead).
  // `fruit_on_axis` (from the hand tracker): a fruit covers the centre of a
  // fresh hand image (ServoConfig::axis_fruit_area): a grasp reading then is
  // a fruit, never a leaf.
  IrStep step(rt::Micros now, const Eigen::Isometry3d& tool, const Fruit& fruit, std::optional<double> fruit_in_front,
              std::optional<double> hold_at = std::nullopt, bool seen_whole = false, bool fruit_on_axis = false);

  // The forward speed for the range still to go (the IR range if it sees the
  // fruit, the estimate always): the speed from which braking at
  // ir_braking_decel stops at the grasp range, in [ir_min_speed, ir_approach_speed].
  // With `hold_at` the speed from which it stops that far short of the
  // estimate, down to zero there.
  double forward_speed(const Eigen::Isometry3d& tool, const Fruit& fruit, bool ir_sees_fruit,
                       std::optional<double> hold_at = std::nullopt) const;

  // The gripper is told to close with the tool at `tool` ...
  void closing_at(const Eigen::Vector3d& tool) {
    grasp_from_ = tool;
    advance_stopped_ = cfg_.grasp_stop_at_joint_limit && joint_at_limit_;
  }
  // ... every ROBOT_STATE: a joint held at its limit (kFlagJointLimit) as it closes or while it does stops the
  // advance for the rest of the close (grasp_stop_at_joint_limit): the robot link clips the twist and the tool
  // goes sideways instead.
  void on_joint_limit(bool at_limit) {
    joint_at_limit_ = at_limit;
    if (at_limit) advance_stopped_ = cfg_.grasp_stop_at_joint_limit;
  }
  // ... GRASP: on along the tool axis at ir_min_speed until grasp_advance
  // past there, then STOP (nullopt). The IR folds back nearer than its peak,
  // so the grasp reading comes with the fruit centre still ~2 cm ahead of the
  // tool point: going on while the fingers close centres it between them,
  // and a fruit swaying away along the axis during the close stays inside.
  std::optional<Twist> grasp_twist(const Eigen::Isometry3d& tool) const;

 private:
  void reset_attempt(const Eigen::Vector3d& tool, rt::Micros now);
  // Follows the surface the IR reads ahead with each new reading (tool along its axis + range).
  void track_surface(const Eigen::Isometry3d& tool);
  // The IR has read one surface staying put while the tool came ir_surface_travel toward it.
  bool surface_ahead() const;
  // The range of the grasp reading: the near one before the sensor folded back, else the newest.
  double grasp_reading() const;

  ServoConfig cfg_;
  std::optional<ir_range_t> ir_;
  rt::Micros ir_rx_ = 0;
  int attempt_ = 0;
  // Going on past a leaf the IR read in front of the fruit, there along the
  // tool axis (tool position + range, as Surface::at); unset once the sensor is past it.
  std::optional<double> leaf_at_;
  bool leaf_noted_ = false;  // this attempt has gone past a leaf (noted once)
  // Leaf or fruit (ir_split_close): the gripper closes once the tool has come
  // this far along its axis (as leaf_at_); unset when not splitting.
  std::optional<double> split_close_at_;
  std::optional<double> last_near_;  // last IR range just above the grasp range in this attempt [m]
  bool folded_ = false;              // ... followed by a jump far beyond it: the sensor folded back
  rt::Micros progress_at_ = 0;       // when the tool last moved ir_progress_step ...
  Eigen::Vector3d progress_from_ = Eigen::Vector3d::Zero();  // ... from here
  // The surface the IR reads ahead: where it is along the tool axis (tool position + range), and the span of
  // tool positions along the axis over which the readings agreed with it.
  struct Surface {
    double at = 0.0, from = 0.0, to = 0.0;
  };
  std::optional<Surface> surface_;
  rt::Micros surface_rx_ = -1;  // the reading last tracked
  Eigen::Vector3d start_ = Eigen::Vector3d::Zero();
  Eigen::Vector3d grasp_from_ = Eigen::Vector3d::Zero();
  bool joint_at_limit_ = false;   // the newest ROBOT_STATE has a joint at its limit
  bool advance_stopped_ = false;  // GRASP: a joint met its limit since the close began
};

}  // namespace harvest::servo
