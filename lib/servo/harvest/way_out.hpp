// How the gripper leaves the canopy after a fruit (RETREAT, and DETACH's pull
// running on into it): back along the tool axis out to abreast of where the
// approach began or, with retrace_way_in, straight back to it; with the
// straight way to the next aim following (straight_to_next), only as far as
// that way needs to clear the fruit the fixed camera sees
// (retreat_clearance); whether the next fruit is then turned to from the
// retreat's end or from home (after a joint met its limit going in: the
// robot link's way home resets the arm's posture); and, with pull_through,
// when the pull is over and the gripper may let go.
// docs/servo-controller.md, "From one fruit to the next".
#pragma once

#include <Eigen/Geometry>
#include <optional>
#include <string>

#include "harvest/targets_t.hpp"
#include "servo/harvest/goal_monitor.hpp"
#include "servo/servo_config.hpp"

namespace harvest::servo {

class WayOut {
 public:
  // `straight`: straight_to_next with the pose-goal ORIENT (the thesis's law turns in place, at home).
  WayOut(const ServoConfig& cfg, bool straight);

  // The approach into the canopy began here (the tool at the end of ORIENT) ...
  void approach_began(const Eigen::Vector3d& tool) { approach_from_ = tool; }
  // ... and is over (the fruit done, the way out under way).
  void approach_done() { approach_from_.reset(); }
  bool approached() const { return approach_from_.has_value(); }
  // A joint met its limit going in (ROBOT_STATE kFlagJointLimit); the arm home again.
  void joint_limit_met() { joint_limit_met_ = true; }
  void home() { joint_limit_met_ = false; }

  // Back along the tool axis by `at_least`, or out to abreast of where the approach began, whichever is farther;
  // with retrace_way_in straight back to where it began (back_toward).
  Eigen::Isometry3d retreat(const Eigen::Isometry3d& from, double at_least) const;
  // The way out from `from`, at least `at_least` back; decides next_from_there(). With the next fruit turned to
  // from its end and retreat_clearance > 0, only as far as the straight way to the aim from home passes that far
  // from every target of `fixed` (null: none known, the full retreat).
  Eigen::Isometry3d goal(const Eigen::Isometry3d& from, double at_least, const targets_t* fixed);
  // The retreat under way ends a fruit: the next one is selected at its end, not at home.
  bool next_from_there() const { return next_from_there_; }
  // The retreat under way goes home first although the next fruit would be turned to from its end: the status note.
  std::optional<std::string> home_first_note() const {
    if (straight_ && !next_from_there_) return "a joint met its limit going in: home first";
    return std::nullopt;
  }

  // START with the tool at `tool`: already home (within `at_home`) SELECT there; else back out along the tool axis
  // by retreat_distance first if farther than that from home (after an e-stop next to the canopy; home first),
  // or straight home.
  struct Start {
    enum class Action { kSelect, kRetreat, kReturn } action;
    Eigen::Isometry3d goal = Eigen::Isometry3d::Identity();
  };
  Start start(const Eigen::Isometry3d& tool, const GoalTolerances& at_home);

  // turn_while_retreating: `way_out` turned to `aim` (the next fruit's aim from home); one that would end within
  // turn_ahead_home_within of home ends there, ORIENT's goal (the rest of the line there is out of the canopy).
  Eigen::Isometry3d turned(const Eigen::Isometry3d& way_out, const Eigen::Matrix3d& aim) const;

  // pull_through: the grasp's way out is one goal to the retreat's end (the fruit let go pull_distance back) ...
  bool pulls_through() const { return pull_through_ && approach_from_.has_value(); }
  // One motion from the fingers' hold at `grasped` to the retreat's end (its goal as if from where the pull would
  // end; twist_angle about the axis spread over the way); the pull is then under way.
  Eigen::Isometry3d through(const Eigen::Isometry3d& grasped, const targets_t* fixed);
  bool pulling_through() const { return pull_from_.has_value(); }
  // ... or the plain pull (the way refused or blocked before the fruit came off; any state but DETACH).
  void pull_alone() { pull_from_.reset(); }
  // The tool has come pull_distance back along the axis it grasped with: the fruit is off.
  bool pulled_off(const Eigen::Isometry3d& tool) const;

 private:
  bool straight_, home_after_joint_limit_, pull_through_, retrace_way_in_;
  double retreat_clearance_, palm_offset_, pull_distance_, retreat_distance_, twist_angle_, turn_home_within_;
  Eigen::Isometry3d home_;
  std::optional<Eigen::Vector3d> approach_from_;
  std::optional<Eigen::Isometry3d> pull_from_;  // where the fingers took hold (pull_through, DETACH only)
  bool next_from_there_ = false;
  bool joint_limit_met_ = false;  // since the arm was last home
};

}  // namespace harvest::servo
