// Closed-loop tests (closed_loop/loop.hpp): Grasp, detach, release and the way back out of the canopy.
#include <gtest/gtest.h>

#include <algorithm>
#include <optional>

#include "closed_loop/loop.hpp"
#include "servo/geometry.hpp"

namespace harvest::servo::testing {
namespace {

TEST(ClosedLoop, GripperClosingOnNothingIsAFailedGrasp) {
  WorldSpec spec = experiment_one();
  spec.gripper_misses = true;
  Loop loop(spec);
  loop.start();
  ASSERT_TRUE(loop.run_until_state(State::kDone, 60.0));
  EXPECT_EQ(loop.outcome(1)->outcome, +fruit_outcome_t::FAILED_GRASP);
  EXPECT_EQ(loop.outcome(1)->detail, "gripper closed on nothing");
  const auto grips = loop.bus.messages<gripper_command_t>(ch::kGripperCommand);
  ASSERT_GE(grips.size(), 2u);
  EXPECT_EQ(grips.back().second.action, +gripper_command_t::ACTION_OPEN);
  expect_published(loop, 1, fruit_outcome_t::FAILED_GRASP, "gripper closed on nothing");
  expect_motion_stopped(loop);
}

TEST(ClosedLoop, FruitSlippingFromTheGripperIsAFailedGrasp) {
  WorldSpec spec = experiment_one();
  spec.fruit_slips = true;
  Loop loop(spec);
  loop.start();
  ASSERT_TRUE(loop.run_until_state(State::kDone, 60.0)) << loop.ctrl.machine().summary();
  EXPECT_EQ(loop.outcome(1)->outcome, +fruit_outcome_t::FAILED_GRASP);
  EXPECT_FALSE(loop.world.fruit_picked(1));
  const auto grips = loop.bus.messages<gripper_command_t>(ch::kGripperCommand);
  ASSERT_EQ(grips.size(), 2u);  // close on the fruit, open after the slip; never the drop's open
  EXPECT_EQ(grips.back().second.action, +gripper_command_t::ACTION_OPEN);
  bool dropped = false;
  for (const auto& [time, st] : loop.bus.messages<harvest_status_t>(ch::kHarvestStatus)) dropped |= st.state == "DROP";
  EXPECT_FALSE(dropped) << "went on to the drop pose without the fruit";
  expect_within_limits(loop);
  expect_published(loop, 1, fruit_outcome_t::FAILED_GRASP, "fruit slipped from the gripper");
  expect_motion_stopped(loop);
}

// A stalled pull goes on to the drop; once the fruit is held, a drop the arm
// does not carry out is a fault: the controller stops the arm and latches,
// it does not wait 20 s.
// By default the fruit is let go where the pull ended (it falls onto the
// catching frame): no carry to drop_pose, one gripper OPEN, picked. (Here at
// rest, in RELEASE: release_while_retreating off.)
TEST(ClosedLoop, FruitIsReleasedWhereThePullEnded) {
  WorldSpec spec = experiment_one();
  ServoConfig cfg = test_config();
  cfg.release_while_retreating = false;
  Loop loop(spec, cfg);
  ASSERT_TRUE(loop.cfg.release_at_detach);
  loop.start();
  ASSERT_TRUE(loop.run_until_state(State::kRelease, 30.0)) << loop.ctrl.machine().summary();
  ASSERT_TRUE(loop.world.close_position().has_value());
  // The pull starts where the arm stopped, grasp_advance past where the
  // gripper was told to close, and goes back along the same axis.
  const double from_grasp = (loop.arm.tool().translation() - *loop.world.close_position()).norm();
  EXPECT_NEAR(from_grasp, loop.cfg.pull_distance - loop.cfg.grasp_advance, 0.01);
  ASSERT_TRUE(loop.run_until_state(State::kDone, 30.0)) << loop.ctrl.machine().summary();
  EXPECT_EQ(loop.outcome(1)->outcome, +fruit_outcome_t::PICKED);
  const auto states = published_states(loop);
  EXPECT_EQ(std::count(states.begin(), states.end(), "DROP"), 0);
  EXPECT_EQ(std::count(states.begin(), states.end(), "RELEASE"), 1);
}

// release_while_retreating (default): the gripper is told to open as the retreat begins, no RELEASE at rest;
// the fruit counts as picked at the pull's end, the gripper's opening (here 0.6 s, RELEASE ends half open)
// sooner than with RELEASE at rest.
TEST(ClosedLoop, FruitIsLetGoWhileRetreating) {
  double at_rest_cycle = 0.0;
  for (const bool overlap : {false, true}) {
    WorldSpec spec = experiment_one();
    spec.gripper_open_s = 0.6;
    ServoConfig cfg = test_config();
    ASSERT_TRUE(cfg.release_while_retreating);  // the default
    cfg.release_while_retreating = overlap;
    Loop loop(spec, cfg);
    loop.start();
    ASSERT_TRUE(loop.run_until_state(State::kDone, 60.0)) << loop.ctrl.machine().summary();
    ASSERT_NE(loop.outcome(1), nullptr);
    EXPECT_EQ(loop.outcome(1)->outcome, +fruit_outcome_t::PICKED) << loop.outcome(1)->detail;
    const auto states = published_states(loop);
    EXPECT_EQ(std::count(states.begin(), states.end(), "RELEASE"), overlap ? 0 : 1);
    if (!overlap) {
      at_rest_cycle = loop.outcome(1)->cycle_time_s;
      continue;
    }
    EXPECT_LT(loop.outcome(1)->cycle_time_s, at_rest_cycle - 0.25);
    EXPECT_TRUE(loop.world.fruit_picked(1));
    const auto detach = std::find(states.begin(), states.end(), "DETACH");
    ASSERT_NE(detach, states.end());
    ASSERT_NE(detach + 1, states.end());
    EXPECT_EQ(*(detach + 1), "RETREAT");
    EXPECT_FALSE(ever_noted(loop, "did not report open"));
    // The OPEN went out as the retreat began.
    rt::Micros retreat_at = 0, open_at = 0;
    for (const auto& [time, st] : loop.bus.messages<harvest_status_t>(ch::kHarvestStatus))
      if (st.state == "RETREAT" && retreat_at == 0) retreat_at = time;
    for (const auto& [time, g] : loop.bus.messages<gripper_command_t>(ch::kGripperCommand))
      if (g.action == gripper_command_t::ACTION_OPEN && open_at == 0) open_at = time;
    EXPECT_NE(retreat_at, 0);
    EXPECT_EQ(open_at, retreat_at);
  }
}

// pull_through (default): the pull and the retreat are one pose goal, the arm does not stop where the pull ends;
// the gripper opens once the tool has come pull_distance back from where the fingers took hold, and the way out
// ends where the pull-then-retreat did (the same goal, twisted the same).
TEST(ClosedLoop, ThePullRunsOnIntoTheRetreatAndLetsGoOnTheWay) {
  Eigen::Isometry3d way_out_end[2];
  for (const bool through : {false, true}) {
    ServoConfig cfg = test_config();
    ASSERT_TRUE(cfg.pull_through);  // the default
    cfg.pull_through = through;
    Loop loop(experiment_one(), cfg);
    loop.start();
    ASSERT_TRUE(loop.run_until_state(State::kDetach, 30.0)) << loop.ctrl.machine().summary();
    const Eigen::Isometry3d grasped = loop.arm.tool();
    ASSERT_TRUE(loop.run_until_state(State::kDone, 60.0)) << loop.ctrl.machine().summary();
    // When DETACH and RETREAT began (their first status), and the pose goals sent in each.
    rt::Micros detach_at = 0, retreat_at = 0;
    for (const auto& [time, st] : loop.bus.messages<harvest_status_t>(ch::kHarvestStatus)) {
      if (st.state == "DETACH" && detach_at == 0) detach_at = time;
      if (st.state == "RETREAT" && retreat_at == 0) retreat_at = time;
    }
    ASSERT_GT(retreat_at, detach_at);
    std::vector<int64_t> detach_ids, retreat_ids;
    Eigen::Isometry3d retreat_goal = Eigen::Isometry3d::Identity();
    for (const auto& [at, c] : loop.commands()) {
      if (c.type != robot_command_t::TYPE_POSE_GOAL) continue;
      if (at >= detach_at && at < retreat_at) detach_ids.push_back(c.goal_id);
      if (at >= retreat_at && retreat_ids.empty()) retreat_goal = to_isometry(c.pose_goal);
      if (at >= retreat_at) retreat_ids.push_back(c.goal_id);
    }
    ASSERT_FALSE(detach_ids.empty());
    ASSERT_FALSE(retreat_ids.empty());
    EXPECT_EQ(retreat_ids.front() == detach_ids.back(), through) << "one goal for the pull and the retreat";
    way_out_end[through] = retreat_goal;
    ASSERT_NE(loop.outcome(1), nullptr);
    EXPECT_EQ(loop.outcome(1)->outcome, +fruit_outcome_t::PICKED) << loop.outcome(1)->detail;
    EXPECT_TRUE(loop.world.fruit_picked(1));
    if (!through) continue;
    // The OPEN went out at the let-go, pull_distance back along the axis, the arm moving on at speed.
    rt::Micros open_at = 0;
    for (const auto& [time, g] : loop.bus.messages<gripper_command_t>(ch::kGripperCommand))
      if (g.action == gripper_command_t::ACTION_OPEN && open_at == 0) open_at = time;
    EXPECT_EQ(open_at, retreat_at);
    std::optional<robot_state_t> at_open;  // the newest robot state the let-go was decided on
    for (const auto& [time, st] : loop.bus.messages<robot_state_t>(ch::kRobotState))
      if (time <= open_at) at_open = st;
    ASSERT_TRUE(at_open.has_value());
    const Eigen::Isometry3d tool = to_isometry(at_open->tool_pose);
    const double back = (grasped.translation() - tool.translation()).dot(grasped.rotation().col(2));
    EXPECT_NEAR(back, cfg.pull_distance, 0.01);
    const auto& v = at_open->tool_twist.linear;
    EXPECT_GT(Eigen::Vector3d(v[0], v[1], v[2]).norm(), 0.5 * cfg.max_linear_speed)
        << "the arm stopped where the pull ended";
  }
  EXPECT_LT((way_out_end[0].translation() - way_out_end[1].translation()).norm(), 0.005);
  EXPECT_LT(Eigen::AngleAxisd(way_out_end[0].rotation().transpose() * way_out_end[1].rotation()).angle(), 0.01);
}

// ... and when the robot link refuses that one motion (no path to the retreat's end from the grasp: a joint near
// its limit), the fruit still on the tree, the pull alone goes on at once, then the retreat: picked, no DROP.
// The same when the motion gets nowhere (stalled): the pull alone, not the drop.
TEST(ClosedLoop, AWayOutRefusedOrStalledFromTheGraspFallsBackToThePullAlone) {
  for (const bool refused : {true, false}) {
    Loop loop(experiment_one());
    ASSERT_TRUE(loop.cfg.pull_through);
    loop.start();
    ASSERT_TRUE(loop.run_until_state(State::kGrasp, 30.0)) << loop.ctrl.machine().summary();
    if (refused)
      loop.spec.arm_refuses_next_goals = 1;
    else
      loop.spec.arm_ignores_goals_after_s = loop.t();
    ASSERT_TRUE(loop.run_until_state(State::kDetach, 5.0)) << loop.ctrl.machine().summary();
    const double detach_at = loop.t();
    if (!refused) {
      loop.at(detach_at + loop.cfg.timeouts.stall + 0.1);
      loop.spec.arm_ignores_goals_after_s.reset();
    }
    ASSERT_TRUE(loop.run_until_state(State::kRetreat, 10.0)) << loop.ctrl.machine().summary();
    const std::string why = refused ? "refused by the robot link" : "stalled";
    EXPECT_TRUE(ever_noted(loop, "the way out from the grasp " + why + ": pulling first")) << why;
    if (refused) EXPECT_LT(loop.t() - detach_at, 1.5) << "waited for the stall instead of reading the refusal";
    ASSERT_TRUE(loop.run_until_state(State::kDone, 60.0)) << loop.ctrl.machine().summary();
    ASSERT_NE(loop.outcome(1), nullptr);
    EXPECT_EQ(loop.outcome(1)->outcome, +fruit_outcome_t::PICKED) << loop.outcome(1)->detail;
    EXPECT_TRUE(loop.world.fruit_picked(1));
    const auto states = published_states(loop);
    EXPECT_EQ(std::count(states.begin(), states.end(), "DROP"), 0);
    EXPECT_EQ(std::count(states.begin(), states.end(), "FAULT"), 0);
  }
}

// Any pose goal the robot link refuses is blocked at once, not after the stall time: a refused first turn is
// judged within a few ticks as a blocked turn (here: the fruit aimed at from a viewpoint instead, and picked).
TEST(ClosedLoop, APoseGoalTheRobotLinkRefusesIsBlockedAtOnce) {
  Loop loop(experiment_one());
  loop.spec.arm_refuses_next_goals = 1;
  loop.start();
  ASSERT_TRUE(loop.run_until_state(State::kOrient, 10.0)) << loop.ctrl.machine().summary();
  const double orient_at = loop.t();
  loop.at(orient_at + 0.2);  // well inside timeouts_s.stall (2 s)
  ASSERT_LT(0.2, loop.cfg.timeouts.stall);
  EXPECT_TRUE(
      ever_noted(loop, "fruit 1: the arm could not turn to it (refused by the robot link), aiming from a viewpoint"))
      << loop.ctrl.machine().summary();
  ASSERT_TRUE(loop.run_until_state(State::kDone, 60.0)) << loop.ctrl.machine().summary();
  ASSERT_NE(loop.outcome(1), nullptr);
  EXPECT_EQ(loop.outcome(1)->outcome, +fruit_outcome_t::PICKED) << loop.outcome(1)->detail;
}

// ... and a gripper that never reports open is a fault within timeouts_s.release: the arm stops and stays.
TEST(ClosedLoop, AGripperThatNeverLetsGoWhileRetreatingIsAFaultAndStops) {
  WorldSpec spec = experiment_one();
  spec.gripper_wont_open = true;
  ServoConfig cfg = test_config();
  cfg.release_while_retreating = true;
  Loop loop(spec, cfg);
  loop.start();
  ASSERT_TRUE(loop.run_until_state(State::kRetreat, 60.0)) << loop.ctrl.machine().summary();
  const double retreat_at = loop.t();
  ASSERT_TRUE(loop.run_until_state(State::kFault, 30.0)) << loop.ctrl.machine().summary();
  EXPECT_NEAR(loop.t() - retreat_at, cfg.timeouts.release, 0.1);
  EXPECT_TRUE(ever_noted(loop, "gripper did not report open in time (letting go of a picked fruit while retreating)"));
  EXPECT_EQ(loop.outcome(1)->outcome, +fruit_outcome_t::PICKED);
  const Eigen::Vector3d held = loop.arm.tool().translation();
  loop.at(loop.t() + 1.0);
  EXPECT_LT((loop.arm.tool().translation() - held).norm(), 1e-9) << "the arm moved while faulted";
}

TEST(ClosedLoop, DetachThatStallsGoesOnToTheDropAndAStalledDropIsAFault) {
  // Even when the fruit is released at the detach otherwise, a stalled pull
  // goes on to the drop, whose path finishes pulling it off.
  WorldSpec spec = experiment_one();
  Loop loop(spec);
  ASSERT_TRUE(loop.cfg.release_at_detach);
  loop.start();
  ASSERT_TRUE(loop.run_until_state(State::kGrasp, 30.0)) << loop.ctrl.machine().summary();
  loop.spec.arm_ignores_goals_after_s = 0.0;
  ASSERT_TRUE(loop.run_until_state(State::kDrop, 10.0)) << loop.ctrl.machine().summary();
  expect_fault_stops(loop, "motion stalled in DROP");
}

// Experiment I with a dead IR: the fruit is given up deep in the canopy.
// Where the approach began, the tool as RETREAT starts, and its goal.
struct RetreatSeen {
  Eigen::Vector3d approach_from;
  Eigen::Isometry3d tool;
  Eigen::Vector3d goal;
};
RetreatSeen retreat_after_giving_up(const ServoConfig& cfg) {
  WorldSpec spec = experiment_one();
  spec.ir_dead = true;
  Loop loop(spec, cfg);
  loop.start();
  RetreatSeen r;
  EXPECT_TRUE(loop.run_until_state(State::kAcquire, 30.0)) << loop.ctrl.machine().summary();
  r.approach_from = loop.arm.tool().translation();
  EXPECT_TRUE(loop.run_until_state(State::kRetreat, 90.0)) << loop.ctrl.machine().summary();
  r.tool = loop.arm.tool();
  const robot_command_t c = loop.commands().back().second;  // commands() returns a copy
  EXPECT_EQ(c.type, +robot_command_t::TYPE_POSE_GOAL);
  r.goal = to_isometry(c.pose_goal).translation();
  return r;
}

// After giving a fruit up deep in the canopy, RETREAT goes back along the
// tool axis out to abreast of where the approach began (farther than
// retreat_distance), so the way home does not cut through the canopy
// (retreat_clearance 0, the default; with it, a way on clear of every fruit
// ends the retreat sooner: below).
TEST(ClosedLoop, RetreatLeavesTheCanopyTheWayTheGripperCameIn) {
  const ServoConfig cfg = test_config();
  ASSERT_EQ(cfg.retreat_clearance, 0.0);  // the default
  const RetreatSeen r = retreat_after_giving_up(cfg);
  const Eigen::Vector3d axis = r.tool.rotation().col(2);
  ASSERT_GT((r.tool.translation() - r.approach_from).dot(axis), cfg.retreat_distance + 0.1);  // deep in
  EXPECT_LT((r.goal - r.tool.translation()).cross(axis).norm(), 1e-4);                        // straight back
  EXPECT_NEAR((r.goal - r.approach_from).dot(axis), 0.0, 1e-3);                               // abreast of the start
}

// retreat_clearance 0.12: the one fruit given up is the only one on the
// tree, 0.15 m and more ahead of the way home from retreat_distance back:
// the retreat ends there, straight back along the axis.
TEST(ClosedLoop, RetreatEndsWhereTheWayHomeClearsTheFruit) {
  ServoConfig cfg = test_config();
  cfg.retreat_clearance = 0.12;
  const RetreatSeen r = retreat_after_giving_up(cfg);
  const Eigen::Vector3d axis = r.tool.rotation().col(2);
  EXPECT_LT((r.goal - r.tool.translation()).cross(axis).norm(), 1e-4);
  EXPECT_NEAR((r.tool.translation() - r.goal).dot(axis), cfg.retreat_distance, 1e-3);
}

}  // namespace
}  // namespace harvest::servo::testing
