// The harvest sequence (thesis section 4.4, appendix D HarvestStep1..6) as a
// pure state machine: messages and ticks in, commands out. No LCM, no clock,
// no logging: ServoControllerNode wires it to the bus.
//
//   IDLE -START-> ([RETREAT ->] RETURN, if not at home) -> SELECT -> ORIENT -> ACQUIRE -> APPROACH
//     -> IR_APPROACH -> GRASP -> DETACH [-> DROP] -> RELEASE [-> RETREAT] -> RETURN -> SELECT ... -> DONE (no reachable
//     fruit left); with straight_to_next the next fruit is selected at the end of the retreat: RETREAT -> ORIENT
//     (docs/servo-controller.md, "From one fruit to the next")
//   failures: APPROACH <-> REACQUIRE -> LOST; IR_APPROACH -> BACKOFF -> IR_APPROACH
//     -> FAILED_GRASP; each then RETREAT -> RETURN -> SELECT. Faults -> FAULT
//     (until RESET_FAULT), emergency stop -> ESTOP (latched until cleared).
//
// The machine sequences; its parts in servo/harvest/ do one job each: the
// state table (states.hpp), which fruit next (selector, fruit_ledger), where
// to aim (aiming), the turn to the fruit (turning), watching a pose goal
// (goal_monitor), the way in from the hand image and the IR (going_in:
// following the fruit in the hand image, hand_tracker; the last centimetres,
// ir_guidance; when to close on a swaying fruit, wind: sway, tree_sway), the
// way out of the canopy (way_out), the operator's commands and the e-stop
// (operator_desk) and the command messages (commands).
#pragma once

#include <cmath>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "harvest/emergency_stop_t.hpp"
#include "harvest/fruit_detections_t.hpp"
#include "harvest/fruit_outcome_t.hpp"
#include "harvest/gripper_command_t.hpp"
#include "harvest/gripper_state_t.hpp"
#include "harvest/harvest_status_t.hpp"
#include "harvest/ir_range_t.hpp"
#include "harvest/operator_command_t.hpp"
#include "harvest/robot_command_t.hpp"
#include "harvest/robot_state_t.hpp"
#include "harvest/targets_t.hpp"
#include "runtime/clock.hpp"
#include "servo/approach.hpp"
#include "servo/geometry.hpp"
#include "servo/harvest/aiming.hpp"
#include "servo/harvest/commands.hpp"
#include "servo/harvest/fruit.hpp"
#include "servo/harvest/fruit_ledger.hpp"
#include "servo/harvest/goal_monitor.hpp"
#include "servo/harvest/going_in.hpp"
#include "servo/harvest/operator_desk.hpp"
#include "servo/harvest/selector.hpp"
#include "servo/harvest/states.hpp"
#include "servo/harvest/status.hpp"
#include "servo/harvest/turning.hpp"
#include "servo/harvest/way_out.hpp"
#include "servo/servo_config.hpp"

namespace harvest::servo {

// What to publish after one input or tick.
struct MachineOutput {
  std::optional<robot_command_t> robot;
  std::optional<gripper_command_t> gripper;
  bool status_changed = false;
  std::string log;  // a line worth logging (refused command, fault), empty if none
  // Why an input message was refused as invalid (NaN or infinite numbers), empty if it was not.
  std::string invalid_input;
};

class HarvestMachine {
 public:
  HarvestMachine(ServoConfig config, std::unique_ptr<ApproachStrategy> approach);

  MachineOutput on_targets(const targets_t& msg, rt::Micros now);
  MachineOutput on_hand_fruit(const fruit_detections_t& msg, rt::Micros now);
  MachineOutput on_robot_state(const robot_state_t& msg, rt::Micros now);
  MachineOutput on_ir(const ir_range_t& msg, rt::Micros now) {
    going_in_.on_ir(msg, now, state_ == State::kIrApproach);
    return {};
  }
  MachineOutput on_gripper(const gripper_state_t& msg, rt::Micros now);
  MachineOutput on_operator(const operator_command_t& msg, rt::Micros now);
  MachineOutput on_estop(const emergency_stop_t& msg, rt::Micros now);
  // The control step, called at config.tick_period_s.
  MachineOutput tick(rt::Micros now);

  State state() const { return state_; }
  bool paused() const { return desk_.paused(); }
  bool estop() const { return desk_.estop(); }
  int current_fruit() const { return current_ ? current_->id : -1; }
  const std::vector<fruit_outcome_t>& outcomes() const { return ledger_.outcomes(); }
  // HARVEST_STATUS content (the node fills seq and publish time).
  harvest_status_t status() const {
    return status_message(status_inputs(), ledger_, fixed_view(), robot_ ? &*robot_ : nullptr);
  }
  std::string summary() const { return summary_line(status_inputs(), ledger_.tally()); }
  int64_t workspace_clips() const { return commands_.workspace_clips(); }
  // The approach strategy, for the node to feed strategy-specific inputs (FEATURE_MATCHES for tbz).
  ApproachStrategy& approach() { return going_in_.strategy(); }
  const ApproachStrategy& approach() const { return going_in_.strategy(); }
  std::string approach_name() const { return going_in_.strategy().name(); }

 private:
  bool running() const { return spec(state_).running; }
  bool robot_fresh(rt::Micros now) const {
    return robot_ && now - robot_rx_ <= rt::from_seconds(cfg_.timeouts.robot_state);
  }
  // The newest fixed-camera TARGETS, if any.
  const targets_t* fixed_view() const { return fixed_ ? &*fixed_ : nullptr; }
  Eigen::Isometry3d tool() const { return robot_ ? to_isometry(robot_->tool_pose) : Eigen::Isometry3d::Identity(); }
  Eigen::Isometry3d camera() const { return robot_ ? to_isometry(robot_->camera_pose) : Eigen::Isometry3d::Identity(); }
  // A command names the newest TARGETS taken in (its utime is that camera frame's, its source_seq that TARGETS
  // seq), so a log traces it back to the frame; every earlier TARGETS was in the machine's state too. Before the
  // first, the robot state it was computed from.
  CommandStamp stamp() const {
    if (vision_) return {vision_->utime, vision_->seq, goal_.id()};
    return {robot_ ? robot_->header.utime : 0, robot_ ? robot_->header.seq : -1, goal_.id()};
  }
  robot_command_t stop() const { return commands_.stop(stamp()); }
  robot_command_t twist(const Twist& desired) { return commands_.twist(stamp(), desired, tool().translation()); }
  gripper_command_t gripper(int8_t action) const {
    return CommandBuilder::gripper(robot_ ? robot_->header.utime : 0, action);
  }
  StatusInputs status_inputs() const {
    return {state_, desk_.paused(), desk_.estop(), current_ ? std::optional<int>(current_->id) : std::nullopt, note_};
  }

  void enter(State s, rt::Micros now, MachineOutput& out);
  void start_goal(const Eigen::Isometry3d& goal, State s, rt::Micros now, MachineOutput& out);

  // Per-state control steps and what ends a state.
  void step(rt::Micros now, MachineOutput& out);
  void goal_reached(rt::Micros now, MachineOutput& out);
  // A pose-goal motion that stalled or timed out: the fruit is unreachable if
  // the arm cannot turn to it, a blocked retreat returns home directly, any
  // other blocked motion is a fault.
  void motion_blocked(const std::string& why, rt::Micros now, MachineOutput& out);
  void on_timeout(rt::Micros now, MachineOutput& out);
  void release(rt::Micros now, MachineOutput& out);  // RELEASE: open the gripper
  // What a step of the way in (APPROACH, IR_APPROACH) says, done: its note, the command, the next state.
  void going_in(const GoingIn::Step& s, rt::Micros now, MachineOutput& out);
  // GRASP: on along the tool axis while the fingers close (IrGuidance::grasp_twist), then STOP.
  void grasp_step(MachineOutput& out) {
    const auto forward = going_in_.grasp_twist(tool());
    out.robot = forward ? twist(*forward) : stop();
  }

  // START: SELECT from the home pose, else retreat and return home first.
  void begin_from_home(rt::Micros now, MachineOutput& out);
  void select(rt::Micros now, MachineOutput& out);
  // Makes the selected fruit current (rejections noted); false if none.
  bool take_next(const Selection& s, MachineOutput& out);
  // straight_to_next (with the pose-goal ORIENT; the thesis's law turns in place, at home).
  bool straight() const { return cfg_.straight_to_next && cfg_.orient_law == "pose_goal"; }
  // Out of the canopy after a fruit (the end of a retreat, or given up before going in): select from a fixed
  // view newer than `view_since` and ORIENT straight to the aim from home, else RETURN (a viewpoint, no fruit
  // left, no fresh view: SELECT at home decides).
  void next_from_here(rt::Micros view_since, rt::Micros now, MachineOutput& out);
  // RELEASE is over: the gripper OPEN, or OPENING at least release_opening of the way (the fruit is free).
  bool released(const gripper_state_t& g) const {
    return g.state == gripper_state_t::STATE_OPEN || (g.state == gripper_state_t::STATE_OPENING &&
                                                      cfg_.release_opening < 1.0 && g.position >= cfg_.release_opening);
  }
  // turn_while_retreating: `way_out` (a pose goal out of the canopy) turned to the aim of the fruit SELECT would choose
  // at its end, the current one counted done (a dry run of the selection on a copy of the ledger: nothing recorded);
  // only while the fixed camera sees the tree still, unless turn_in_wind.
  void turn_ahead(Eigen::Isometry3d& way_out, rt::Micros now) const;
  // ORIENT: aim at the current fruit from home, or from its viewpoint if it
  // lies more than max_aim_angle off the home axis (or the turn was blocked).
  void orient(rt::Micros now, MachineOutput& out);
  // On the way home (RETURN, HOMING) a joint of the arm turns faster than goal_progress_joint_speed (newest robot
  // state): the joint-space path to the home posture may swing the elbow for seconds with the tool put, which is
  // progress too. Not elsewhere: an arm held at a joint limit while the link's null-space motion goes on must stall.
  bool joints_moving_home() const {
    if (state_ != State::kReturn && state_ != State::kHoming) return false;
    if (!robot_ || cfg_.goal_progress_joint_speed <= 0.0) return false;
    for (const double v : robot_->joint_velocity)
      if (std::abs(v) > cfg_.goal_progress_joint_speed) return true;
    return false;
  }
  // The fruit off the tree and in the hand: open the gripper, PICKED, and on out (RETREAT): on the goal under way
  // (pull_through) or on a new one.
  void let_go_on_the_way_out(bool goal_under_way, rt::Micros now, MachineOutput& out);
  // pull_through's goal refused or blocked before the fruit came off: the plain pull from here instead.
  void pull_first(const std::string& why, rt::Micros now, MachineOutput& out);

  // Ends the current fruit with an outcome; `retreat` pulls back along the
  // tool axis before returning home.
  void fail_fruit(int8_t outcome, const std::string& detail, bool retreat, rt::Micros now, MachineOutput& out);
  // Out of the canopy the way the gripper came in (`retreat`: back along the tool axis first), then home.
  void head_home(bool retreat, rt::Micros now, MachineOutput& out);
  // The fruit is off the tree (let go where the pull ended, or at the drop pose): PICKED, then the way out.
  void picked(rt::Micros now, MachineOutput& out);
  // Records an outcome of the current fruit and lets it go.
  void end_fruit(int8_t outcome, const std::string& detail, rt::Micros now, MachineOutput& out);
  void noted(const fruit_outcome_t& o, MachineOutput& out);
  void fault(const std::string& detail, rt::Micros now, MachineOutput& out);

  ServoConfig cfg_;
  CommandBuilder commands_;
  GoalMonitor goal_;
  FruitLedger ledger_;
  GoingIn going_in_;  // APPROACH and IR_APPROACH: the hand image, the approach strategy, the IR, the wind
  Turning turning_;   // ORIENT: the turn to the fruit (pose goal or the thesis's law) and a blocked turn's verdict

  State state_ = State::kIdle;
  OperatorDesk desk_;          // the operator's commands, the pause, the latched e-stop
  bool stop_pending_ = false;  // publish one STOP on the next tick (entering a resting state)
  rt::Micros entered_at_ = 0;
  rt::Micros deadline_ = 0;  // 0: none
  std::string note_;

  std::optional<robot_state_t> robot_;
  rt::Micros robot_rx_ = 0;
  struct Source {
    int64_t utime, seq;
  };
  std::optional<Source> vision_;  // the newest valid TARGETS, either camera
  std::optional<targets_t> fixed_;
  rt::Micros fixed_rx_ = 0;

  std::optional<Fruit> current_;
  // release_while_retreating: the gripper was told to open as the retreat began; it must say so by then.
  std::optional<rt::Micros> release_due_;
  WayOut way_;  // out of the canopy after a fruit: the retreat's goal, where the next is turned to, the pull
};

}  // namespace harvest::servo
