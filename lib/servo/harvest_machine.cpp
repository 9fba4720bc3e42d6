#include "servo/harvest_machine.hpp"

#include <cmath>

#include "servo/geometry.hpp"
#include "servo/harvest/aiming.hpp"
#include "servo/harvest/selector.hpp"
#include "servo/harvest/status.hpp"

namespace harvest::servo {

HarvestMachine::HarvestMachine(ServoConfig config, std::unique_ptr<ApproachStrategy> approach)
    : cfg_(std::move(config)),
      commands_(cfg_),
      goal_({cfg_.position_tolerance, cfg_.orient_tolerance},
            {cfg_.goal_progress_step, cfg_.goal_progress_angle, cfg_.timeouts.stall}),
      ledger_({cfg_.max_attempts_per_fruit, cfg_.same_fruit_distance, cfg_.same_sight_angle, cfg_.reused_id_distance}),
      going_in_(cfg_, std::move(approach)),
      turning_(cfg_),
      way_(cfg_, straight()) {}

// ---------------------------------------------------------------- transitions

void HarvestMachine::enter(State s, rt::Micros now, MachineOutput& out) {
  if (!keeps_twist(state_, s)) commands_.ramp_from_rest();
  if (s != State::kDetach) way_.pull_alone();
  state_ = s;
  entered_at_ = now;
  out.status_changed = true;
  const StateSpec& row = spec(s);
  if (row.rests) stop_pending_ = true;
  const double timeout = row.timeout ? cfg_.timeouts.*row.timeout : 0.0;
  deadline_ = timeout > 0 ? now + rt::from_seconds(timeout) : 0;
}

void HarvestMachine::start_goal(const Eigen::Isometry3d& goal, State s, rt::Micros now, MachineOutput& out) {
  goal_.start(inside_workspace(cfg_.workspace, tool().translation(), goal), now);
  enter(s, now, out);
  out.robot = commands_.pose_goal(stamp(), goal_.goal());
}

void HarvestMachine::noted(const fruit_outcome_t& o, MachineOutput& out) {
  note_ =
      "fruit " + std::to_string(o.fruit_id) + " " + outcome_name(o.outcome) + (o.detail.empty() ? "" : ": " + o.detail);
  out.status_changed = true;
}

void HarvestMachine::end_fruit(int8_t outcome, const std::string& detail, rt::Micros now, MachineOutput& out) {
  if (current_)
    noted(ledger_.record(outcome, current_->id, current_->estimate, detail, rt::to_seconds(now - current_->selected_at),
                         tool().translation(), &*current_),
          out);
  current_.reset();
}

void HarvestMachine::fail_fruit(int8_t outcome, const std::string& detail, bool retreat, rt::Micros now,
                                MachineOutput& out) {
  const rt::Micros selected_at = current_ ? current_->selected_at : now;
  end_fruit(outcome, detail, now, out);
  going_in_.forget_fruit();
  // Given up before the gripper went in (not seen, measured out of reach): the tool is still out of the canopy,
  // where RETURN would go straight home; the tree is as it was at the selection.
  const bool before_going_in = state_ == State::kOrient || state_ == State::kAcquire || state_ == State::kApproach;
  if (!retreat && before_going_in && straight() &&
      out_of_canopy(cfg_.home_pose, cfg_.retreat_distance, tool().translation()))
    return next_from_here(selected_at, now, out);
  head_home(retreat, now, out);
}

void HarvestMachine::picked(rt::Micros now, MachineOutput& out) {
  end_fruit(fruit_outcome_t::PICKED, "", now, out);
  head_home(way_.approached() && cfg_.release_at_detach, now, out);  // after a drop pose it is out of the canopy
}

void HarvestMachine::head_home(bool retreat, rt::Micros now, MachineOutput& out) {
  if (retreat) {
    Eigen::Isometry3d goal = way_.goal(tool(), cfg_.retreat_distance, fixed_view());
    turn_ahead(goal, now);
    if (const auto note = way_.home_first_note()) note_ = *note;
    start_goal(goal, State::kRetreat, now, out);
  } else {
    start_goal(cfg_.home_pose, State::kReturn, now, out);
  }
  way_.approach_done();
}

void HarvestMachine::turn_ahead(Eigen::Isometry3d& way_out, rt::Micros now) const {
  if (!cfg_.turn_while_retreating || !way_.next_from_there() || !fixed_) return;
  if (!cfg_.turn_in_wind && !going_in_.tree_still(now)) return;  // in wind it picked fewer (docs/demo.md)
  FruitLedger ledger = ledger_;
  if (current_) ledger.use_up_attempts(current_->id);  // in the hand: the fixed view still shows it
  const Selection s = select_fruit(cfg_, *fixed_, ledger, cfg_.home_pose.translation(), now, tool().rotation());
  // The straight line out with a constant-axis rotation: inside the canopy the gripper has turned only a little.
  const auto aim = s.fruit ? turning_.ahead(*s.fruit) : std::nullopt;
  if (aim) way_out = way_.turned(way_out, *aim);
}

void HarvestMachine::let_go_on_the_way_out(bool goal_under_way, rt::Micros now, MachineOutput& out) {
  // Off the tree and in the hand: it is let go as the arm backs out instead of at rest first (the gripper opens in
  // a third of a second), and counted picked now.
  out.gripper = gripper(gripper_command_t::ACTION_OPEN);
  release_due_ = now + rt::from_seconds(cfg_.timeouts.release);
  if (!goal_under_way) return picked(now, out);
  end_fruit(fruit_outcome_t::PICKED, "", now, out);
  if (const auto note = way_.home_first_note()) note_ = *note;
  way_.approach_done();
  enter(State::kRetreat, now, out);  // the same goal, the arm on its way
  out.robot = commands_.pose_goal(stamp(), goal_.goal());
}

void HarvestMachine::pull_first(const std::string& why, rt::Micros now, MachineOutput& out) {
  note_ = "the way out from the grasp " + why + ": pulling first";
  out.log = note_;
  start_goal(detach_goal(tool(), cfg_.pull_distance, cfg_.twist_angle), State::kDetach, now, out);
  way_.pull_alone();  // the pull alone, then RETREAT as without pull_through
}

void HarvestMachine::fault(const std::string& detail, rt::Micros now, MachineOutput& out) {
  end_fruit(fruit_outcome_t::ABORTED, detail, now, out);
  desk_.unpause();
  enter(State::kFault, now, out);
  note_ = "FAULT: " + detail;
  out.robot = stop();
  out.log = note_;
}

void HarvestMachine::motion_blocked(const std::string& why, rt::Micros now, MachineOutput& out) {
  switch (state_) {
    case State::kOrient:
    case State::kOrientPd: {
      const Turning::Blocked b = turning_.blocked(why, camera(), *current_);
      if (b.action == Turning::Blocked::Action::kUnreachable) {
        ledger_.use_up_attempts(current_->id);  // what the arm cannot reach now it never will
        fail_fruit(fruit_outcome_t::UNREACHABLE, b.text, false, now, out);
        break;
      }
      note_ = b.text;
      if (b.action == Turning::Blocked::Action::kAcquire) {
        way_.approach_began(tool().translation());
        enter(State::kAcquire, now, out);
      } else {
        start_goal(cfg_.home_pose, State::kReturn, now, out);  // the turn from home, or home to the viewpoint
      }
      break;
    }
    case State::kBackoff:
      // A blocked back-off (a joint limit next to the canopy) gives up as for an IR that never triggered.
      fail_fruit(fruit_outcome_t::FAILED_GRASP, "IR sensor never triggered (back-off " + why + ")", true, now, out);
      break;
    case State::kRetreat:
      note_ = "retreat " + why + ", returning home directly";
      start_goal(cfg_.home_pose, State::kReturn, now, out);
      break;
    case State::kDetach:
      if (way_.pulling_through()) return pull_first(why, now, out);
      // The pull got part of the way: the drop's other path finishes it (the gripper says if still held).
      note_ = "detach " + why + ", going on to the drop";
      start_goal(cfg_.drop_pose, State::kDrop, now, out);
      break;
    default:
      fault("motion " + why + " in " + state_name(state_), now, out);
      break;
  }
}

void HarvestMachine::on_timeout(rt::Micros now, MachineOutput& out) {
  const StateSpec& row = spec(state_);
  switch (row.expiry) {
    case Expiry::kDone:
      note_ = row.detail;
      enter(State::kDone, now, out);
      break;
    case Expiry::kIrAttempt:
      // Back to where the IR approach began (along the tool axis to abreast of it without retrace_way_in) and try
      // again, or give up.
      if (going_in_.attempts_left()) {
        start_goal(way_back(tool(), going_in_.ir_start(), 0.0, cfg_.retrace_way_in), State::kBackoff, now, out);
        break;
      }
      [[fallthrough]];
    case Expiry::kGiveUp:
    case Expiry::kGiveUpRetreat:
      fail_fruit(row.outcome, row.detail, row.expiry != Expiry::kGiveUp, now, out);
      break;
    case Expiry::kFault:
      fault(row.detail, now, out);
      break;
    case Expiry::kMotionBlocked:
      motion_blocked("did not complete", now, out);
      break;
    case Expiry::kNone:
      break;
  }
}

void HarvestMachine::begin_from_home(rt::Micros now, MachineOutput& out) {
  release_due_.reset();
  const WayOut::Start s = way_.start(tool(), {cfg_.position_tolerance, cfg_.orient_tolerance});
  if (s.action == WayOut::Start::Action::kSelect) return enter(State::kSelect, now, out);
  start_goal(s.goal, s.action == WayOut::Start::Action::kRetreat ? State::kRetreat : State::kReturn, now, out);
}

void HarvestMachine::select(rt::Micros now, MachineOutput& out) {
  if (!take_next(select_fruit(cfg_, *fixed_, ledger_, tool().translation(), now, tool().rotation()), out)) {
    note_ = "no reachable fruit left";
    enter(State::kDone, now, out);
    return;
  }
  orient(now, out);
}

bool HarvestMachine::take_next(const Selection& s, MachineOutput& out) {
  for (const auto& o : s.rejected) noted(o, out);
  if (!s.fruit) return false;
  current_ = s.fruit;
  ledger_.begin_attempt(current_->id);
  going_in_.new_fruit();
  if (current_->depth_doubtful)
    note_ = "fruit " + std::to_string(current_->id) + ": fixed-camera depth doubtful, aiming along its line of sight";
  return true;
}

void HarvestMachine::next_from_here(rt::Micros view_since, rt::Micros now, MachineOutput& out) {
  // The fixed camera sees the tree whatever the arm does: a view taken since `view_since` (after a pick, the
  // start of the retreat: the fruit picked gone from it) chooses the next fruit as SELECT at home would, and the
  // aim is the one from home. From here to there is RETURN's straight line, outside the canopy, turning on the way.
  if (fixed_ && fixed_rx_ > view_since &&
      take_next(select_fruit(cfg_, *fixed_, ledger_, cfg_.home_pose.translation(), now, tool().rotation()), out)) {
    if (const auto goal = turning_.from_retreat(tool(), *current_)) return start_goal(*goal, State::kOrient, now, out);
  }
  // No fruit, or no fresh view: SELECT at home decides.
  start_goal(cfg_.home_pose, State::kReturn, now, out);
}

void HarvestMachine::orient(rt::Micros now, MachineOutput& out) {
  const Turning::Start t = turning_.from_here(tool(), *current_);
  if (!t.law) return start_goal(t.goal, State::kOrient, now, out);
  goal_.start(t.goal, now);  // the law's own motion, watched as a goal
  enter(State::kOrientPd, now, out);
}

// ---------------------------------------------------------------- control step

MachineOutput HarvestMachine::tick(rt::Micros now) {
  MachineOutput out;
  if (desk_.estop() || state_ == State::kFault) {
    out.robot = stop();  // keep the arm held while latched
    return out;
  }
  if (stop_pending_) {
    stop_pending_ = false;
    out.robot = stop();
  }
  if (release_due_ && now >= *release_due_) {  // in any state: DONE may come first, the fruit still in the hand
    release_due_.reset();
    fault("gripper did not report open in time (letting go of a picked fruit while retreating)", now, out);
    return out;
  }
  if (!running()) return out;
  if (!robot_fresh(now)) {
    fault("robot state stale (watchdog)", now, out);
  } else if (desk_.paused()) {
    out.robot = stop();
  } else if (deadline_ != 0 && now >= deadline_) {
    on_timeout(now, out);
  } else {
    step(now, out);
  }
  return out;
}

void HarvestMachine::step(rt::Micros now, MachineOutput& out) {
  if (spec(state_).motion == Motion::kPoseGoal) {
    if (state_ == State::kDetach && way_.pulled_off(tool())) {
      let_go_on_the_way_out(true, now, out);
    } else if (goal_.reached(tool())) {
      goal_reached(now, out);
    } else if (goal_.stalled(tool(), now, joints_moving_home())) {
      motion_blocked("stalled", now, out);
    } else {
      out.robot = commands_.pose_goal(stamp(), goal_.goal());  // re-sent every tick as a keep-alive, same goal_id
    }
    return;
  }
  switch (state_) {
    case State::kSelect:
      if (fixed_ && fixed_rx_ > entered_at_) select(now, out);
      break;
    case State::kAcquire:
    case State::kReacquire:
      out.robot = twist(Twist{});
      if (going_in_.seen_since(now, entered_at_)) enter(State::kApproach, now, out);
      break;
    case State::kOrientPd:
      if (goal_.reached(tool())) return goal_reached(now, out);
      if (goal_.stalled(tool(), now)) return motion_blocked("stalled", now, out);
      out.robot = twist(turning_.law_step(tool(), current_->estimate));
      break;
    case State::kApproach:
      going_in(going_in_.approach(now, tool(), camera(), *current_), now, out);
      break;
    case State::kIrApproach:
      going_in_.watch_sway(now, tool(), camera(), *current_);
      going_in(going_in_.ir(now, tool(), camera(), *current_), now, out);
      break;
    case State::kGrasp:
      grasp_step(out);
      break;
    case State::kRelease:
      out.robot = stop();
      break;
    default:
      break;
  }
}

void HarvestMachine::goal_reached(rt::Micros now, MachineOutput& out) {
  switch (state_) {
    case State::kOrient:
    case State::kOrientPd:
      way_.approach_began(tool().translation());
      enter(State::kAcquire, now, out);
      break;
    case State::kBackoff:
      going_in_.retry(tool().translation(), now);
      enter(State::kIrApproach, now, out);
      break;
    case State::kDetach:
      if (cfg_.release_at_detach && cfg_.release_while_retreating) {
        // (pull_through: a goal reached before pull_distance was the workspace's edge; a retreat from here.)
        let_go_on_the_way_out(false, now, out);
      } else if (cfg_.release_at_detach) {
        // The fruit falls onto the catching frame where the pull ended (HarvestStep5 opens where it grasped).
        release(now, out);
      } else {
        start_goal(cfg_.drop_pose, State::kDrop, now, out);
      }
      break;
    case State::kDrop:
      release(now, out);
      break;
    case State::kRetreat:
      if (way_.next_from_there()) {
        next_from_here(entered_at_, now, out);
      } else {
        start_goal(cfg_.home_pose, State::kReturn, now, out);
      }
      break;
    case State::kReturn:
      way_.home();  // home: the robot link went back to the home posture
      if (current_) {
        orient(now, out);  // back from a blocked turn, or home on the way to a viewpoint: aim from here
      } else {
        enter(State::kSelect, now, out);
      }
      break;
    default:  // HOMING
      note_ = "at home";
      enter(State::kIdle, now, out);
      break;
  }
}

void HarvestMachine::release(rt::Micros now, MachineOutput& out) {
  enter(State::kRelease, now, out);
  out.gripper = gripper(gripper_command_t::ACTION_OPEN);
}

void HarvestMachine::going_in(const GoingIn::Step& s, rt::Micros now, MachineOutput& out) {
  if (s.note) {
    note_ = *s.note;
    out.status_changed = true;
  }
  using Action = GoingIn::Step::Action;
  switch (s.action) {
    case Action::kMove:
      out.robot = twist(s.twist);
      break;
    case Action::kLost:
      enter(State::kReacquire, now, out);
      out.robot = twist(Twist{});
      break;
    case Action::kOutOfReach:
      fail_fruit(fruit_outcome_t::UNREACHABLE, s.detail, s.retreat, now, out);
      break;
    case Action::kFruitInTheWay:
      fail_fruit(fruit_outcome_t::FAILED_GRASP, s.detail, true, now, out);
      break;
    case Action::kIrBegins:
      enter(State::kIrApproach, now, out);
      going_in(going_in_.ir(now, tool(), camera(), *current_), now, out);  // the first IR-guided command at once
      break;
    case Action::kClose:
      out.gripper = gripper(gripper_command_t::ACTION_CLOSE);  // thesis HarvestStep5: close on the fruit
      enter(State::kGrasp, now, out);
      grasp_step(out);
      break;
    case Action::kGiveUp:
      on_timeout(now, out);  // out of travel, past the fruit or blocked: same as the IR timeout
      break;
  }
}

}  // namespace harvest::servo
