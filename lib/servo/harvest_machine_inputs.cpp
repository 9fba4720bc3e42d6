// HarvestMachine's inputs: what each message does to the machine (the sequencing is in harvest_machine.cpp).
#include "arm/fault_flags.hpp"
#include "servo/harvest/safety.hpp"
#include "servo/harvest_machine.hpp"

namespace harvest::servo {

MachineOutput HarvestMachine::on_hand_fruit(const fruit_detections_t& msg, rt::Micros now) {
  MachineOutput out;
  if (msg.status != fruit_detections_t::STATUS_OK) return out;
  if (auto why = invalid_detections(msg)) {
    out.invalid_input = "FRUIT_HAND from " + msg.camera + " camera refused: " + *why;
    return out;
  }
  if (current_ && spec(state_).follows_fruit && robot_) going_in_.on_hand_detections(msg, *current_, camera(), now);
  return out;
}

MachineOutput HarvestMachine::on_targets(const targets_t& msg, rt::Micros now) {
  MachineOutput out;
  if (auto why = invalid_targets(msg)) {
    out.invalid_input = "TARGETS from " + msg.source_camera + " camera refused: " + *why;
    return out;
  }
  vision_ = Source{msg.header.utime, msg.header.seq};
  if (msg.source_camera == "fixed") {
    out.status_changed = !fixed_;
    fixed_ = msg;
    fixed_rx_ = now;
    going_in_.on_fixed(msg, now);
  } else if (current_) {
    going_in_.on_hand_targets(msg, *current_, camera(), now);
  }
  return out;
}

MachineOutput HarvestMachine::on_robot_state(const robot_state_t& msg, rt::Micros now) {
  MachineOutput out;
  robot_ = msg;
  robot_rx_ = now;
  going_in_.on_robot_state(msg);
  if (!running()) return out;
  if (const auto f = robot_fault(msg)) fault(*f, now, out);
  // A pose goal the robot link refused (no path it can run from here: a joint near its limit, the way leaving the
  // workspace) is blocked now, not after timeouts_s.stall without progress (pull_through's way out: the pull
  // alone). A tick's grace: a state sent before the link had the goal says nothing about it.
  if (running() && spec(state_).motion == Motion::kPoseGoal && (msg.fault_flags & arm::kFlagRefused) != 0 &&
      now - entered_at_ > rt::from_seconds(cfg_.tick_period_s))
    motion_blocked("refused by the robot link", now, out);
  const bool going_in = state_ == State::kApproach || state_ == State::kIrApproach || state_ == State::kBackoff;
  if (going_in && (msg.fault_flags & arm::kFlagJointLimit) != 0) way_.joint_limit_met();
  return out;
}

MachineOutput HarvestMachine::on_gripper(const gripper_state_t& msg, rt::Micros now) {
  MachineOutput out;
  if (release_due_ && released(msg)) release_due_.reset();  // whatever the state: DONE may come first
  if (!running()) return out;
  if (const auto f = gripper_fault(msg)) {
    fault(*f, now, out);
    return out;
  }
  const bool holding = msg.state == gripper_state_t::STATE_HOLDING;
  if (state_ == State::kGrasp && holding && way_.pulls_through()) {
    Eigen::Isometry3d way = way_.through(tool(), fixed_view());  // the fruit let go on the way
    turn_ahead(way, now);
    start_goal(way, State::kDetach, now, out);
  } else if (state_ == State::kGrasp && holding) {
    start_goal(detach_goal(tool(), cfg_.pull_distance, cfg_.twist_angle), State::kDetach, now, out);
  } else if (state_ == State::kGrasp && msg.state == gripper_state_t::STATE_CLOSED) {
    out.gripper = gripper(gripper_command_t::ACTION_OPEN);
    fail_fruit(fruit_outcome_t::FAILED_GRASP, "gripper closed on nothing", true, now, out);
  } else if ((state_ == State::kDetach || state_ == State::kDrop) && !holding) {
    out.gripper = gripper(gripper_command_t::ACTION_OPEN);
    fail_fruit(fruit_outcome_t::FAILED_GRASP, "fruit slipped from the gripper", false, now, out);
  } else if (state_ == State::kRelease && current_ && released(msg)) {
    picked(now, out);
  }
  return out;
}

MachineOutput HarvestMachine::on_operator(const operator_command_t& msg, rt::Micros now) {
  MachineOutput out;
  out.status_changed = true;
  const OperatorDesk::Order o = desk_.command(msg, state_, robot_fresh(now), now);
  using Do = OperatorDesk::Order::Do;
  switch (o.what) {
    case Do::kRefused:
      out.log = o.note;
      break;
    case Do::kStart:
      begin_from_home(now, out);
      break;
    case Do::kPause:
      out.robot = stop();
      break;
    case Do::kResume:  // the timeouts do not run while paused
      if (deadline_ != 0) deadline_ += o.paused_for;
      if (release_due_) *release_due_ += o.paused_for;
      goal_.shift(o.paused_for);
      commands_.ramp_from_rest();
      break;
    case Do::kAbort:
      end_fruit(fruit_outcome_t::ABORTED, "operator abort", now, out);
      // Never a way out of a latched e-stop or fault: those stay until cleared.
      if (!desk_.estop() && state_ != State::kFault) {
        enter(State::kIdle, now, out);
        stop_pending_ = false;
      }
      out.robot = stop();
      break;
    case Do::kHome:
      end_fruit(fruit_outcome_t::ABORTED, "operator home", now, out);
      start_goal(cfg_.home_pose, State::kHoming, now, out);
      break;
    case Do::kResetFault:
      enter(State::kIdle, now, out);
      break;
  }
  note_ = o.note;
  return out;
}

MachineOutput HarvestMachine::on_estop(const emergency_stop_t& msg, rt::Micros now) {
  MachineOutput out;
  const OperatorDesk::Stop s = desk_.on_estop(msg);
  using Do = OperatorDesk::Stop::Do;
  if (s.what == Do::kHold || s.what == Do::kEngage) out.robot = stop();  // the STOP goes out with this very message
  if (s.what == Do::kEngage) {
    end_fruit(fruit_outcome_t::ABORTED, "emergency stop", now, out);
    enter(State::kEstop, now, out);
  } else if (s.what == Do::kClear) {
    enter(State::kIdle, now, out);
    stop_pending_ = false;
  }
  if (!s.note.empty()) out.log = note_ = s.note;
  return out;
}

}  // namespace harvest::servo
