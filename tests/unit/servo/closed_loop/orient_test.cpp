// Closed-loop tests (closed_loop/loop.hpp): ORIENT: turning to the fruit at home, viewpoints, turns the arm cannot make
// or complete.
#include <gtest/gtest.h>

#include <algorithm>
#include <optional>

#include "closed_loop/loop.hpp"
#include "servo/geometry.hpp"

namespace harvest::servo::testing {
namespace {

// The arm cannot turn to the fruit (blocked at its joint limits), nor reach
// the viewpoint: the fruit is given up as unreachable without waiting for
// the motion timeout, the arm returns home and the harvest goes on (here:
// nothing left, DONE).
TEST(ClosedLoop, OrientThatStallsMakesTheFruitUnreachable) {
  WorldSpec spec = experiment_one();
  spec.arm_ignores_goals_after_s = 0.0;
  ServoConfig cfg = test_config();
  cfg.timeouts.stall = 1.0;
  cfg.max_attempts_per_fruit = 2;  // a fruit the arm cannot reach is not tried a second time
  Loop loop(spec, cfg);
  loop.start();
  ASSERT_TRUE(loop.run_until_state(State::kDone, 10.0)) << loop.ctrl.machine().summary();
  ASSERT_TRUE(loop.outcome(1));
  EXPECT_EQ(loop.outcome(1)->outcome, +fruit_outcome_t::UNREACHABLE);
  EXPECT_EQ(loop.outcome(1)->detail, "the arm could not reach a viewpoint of it (stalled)");
  EXPECT_LT(loop.outcome(1)->cycle_time_s, 2.5);  // two stalls, not the 20 s motion timeouts
  EXPECT_EQ(published_outcomes(loop, 1).size(), 1u);
  const std::vector<std::string> expected{"SELECT", "ORIENT", "RETURN", "ORIENT", "RETURN"};
  const auto states = published_states(loop);
  const auto select = std::find(states.begin(), states.end(), "SELECT");
  ASSERT_GE(states.end() - select, 5);
  EXPECT_EQ(std::vector<std::string>(select, select + 5), expected);
  expect_motion_stopped(loop);
}

// The arm cannot make the turn at home (no joint solution): the fruit is
// aimed at from the viewpoint instead, and picked.
TEST(ClosedLoop, FruitTheArmCannotTurnToAtHomeIsAimedAtFromAViewpoint) {
  WorldSpec spec = experiment_one();
  spec.arm_max_turn_in_place = 0.5;  // the fruit is about 1.0 rad off the axis at home
  ServoConfig cfg = test_config();
  cfg.timeouts.stall = 1.0;
  Loop loop(spec, cfg);
  loop.start();
  ASSERT_TRUE(loop.run_until_state(State::kDone, 60.0)) << loop.ctrl.machine().summary();
  expect_published(loop, 1, fruit_outcome_t::PICKED, "");
  EXPECT_TRUE(loop.world.fruit_picked(1));
  expect_within_limits(loop);
}

// Too wide a turn for the wrist at home: the fruit is aimed at from a
// viewpoint view_distance short of it, along the home axis turned
// view_angle toward it, straight away (no blocked turn first).
TEST(ClosedLoop, FruitFarOffTheAxisAtHomeIsAimedAtFromAViewpoint) {
  WorldSpec spec = experiment_one();
  spec.fixed_error.setZero();
  spec.hand_depth_scale = 1.0;
  const Eigen::Vector3d fruit(-0.05, 0.92, -0.30);  // about 1.38 rad off the home axis
  spec.fruits = {FruitTruth{1, fruit, 0.075}};
  const ServoConfig cfg = test_config();
  Loop loop(spec, cfg);
  loop.start();
  ASSERT_TRUE(loop.run_until_state(State::kDone, 60.0)) << loop.ctrl.machine().summary();
  expect_published(loop, 1, fruit_outcome_t::PICKED, "");
  const Eigen::Vector3d axis = cfg.home_pose.linear().col(2);
  const Eigen::Vector3d to = (fruit - cfg.home_pose.translation()).normalized();
  ASSERT_GT(std::acos(axis.dot(to)), cfg.max_aim_angle);
  const Eigen::Vector3d view_axis = Eigen::AngleAxisd(cfg.view_angle, axis.cross(to).normalized()) * axis;
  const Eigen::Vector3d viewpoint = fruit - cfg.view_distance * view_axis;
  // The first pose goal (ORIENT) goes to the viewpoint; the fixed camera's
  // estimate is exact here, so within a few millimetres of it.
  std::optional<robot_command_t> first;
  for (const auto& [t, c] : loop.commands())
    if (c.type == robot_command_t::TYPE_POSE_GOAL) {
      first = c;
      break;
    }
  ASSERT_TRUE(first);
  const Eigen::Isometry3d goal = to_isometry(first->pose_goal);
  EXPECT_LT((goal.translation() - viewpoint).norm(), 0.02);
  EXPECT_LT(std::acos(std::clamp(goal.linear().col(2).dot((fruit - goal.translation()).normalized()), -1.0, 1.0)),
            0.03);
  expect_within_limits(loop);
}

// The arm stops 8 mm short of the viewpoint (a joint limit; the robot link
// runs the straight path "as near as it gets") and never reaches the goal's
// 5 mm tolerance: the fruit is well inside the hand image, so it is acquired
// from there and picked, not given up as unreachable.
TEST(ClosedLoop, OrientThatStopsShortWithTheFruitInViewGoesOn) {
  WorldSpec spec = experiment_one();
  spec.fixed_error.setZero();
  spec.hand_depth_scale = 1.0;
  spec.fruits = {FruitTruth{1, Eigen::Vector3d(-0.05, 0.92, -0.30), 0.075}};  // aimed at from a viewpoint
  spec.arm_first_goal_stops_short_m = 0.008;
  ServoConfig cfg = test_config();
  cfg.timeouts.stall = 1.0;
  ASSERT_GT(spec.arm_first_goal_stops_short_m, cfg.position_tolerance);
  Loop loop(spec, cfg);
  loop.start();
  ASSERT_TRUE(loop.run_until_state(State::kDone, 60.0)) << loop.ctrl.machine().summary();
  expect_published(loop, 1, fruit_outcome_t::PICKED, "");
  EXPECT_TRUE(loop.world.fruit_picked(1));
  EXPECT_TRUE(ever_noted(loop, "fruit 1: the turn stalled short of its goal, the fruit in view"));
  expect_within_limits(loop);
}

// ... but a turn blocked before the fruit is in view still gives it up (see
// OrientThatStallsMakesTheFruitUnreachable): stopped 0.4 m short of the
// viewpoint, the fruit lies outside the middle of the hand image.
TEST(ClosedLoop, OrientThatStopsFarShortOfItsGoalIsNotTakenAsAimed) {
  WorldSpec spec = experiment_one();
  spec.fixed_error.setZero();
  spec.hand_depth_scale = 1.0;
  spec.fruits = {FruitTruth{1, Eigen::Vector3d(-0.05, 0.92, -0.30), 0.075}};
  spec.arm_first_goal_stops_short_m = 0.4;
  ServoConfig cfg = test_config();
  cfg.timeouts.stall = 1.0;
  Loop loop(spec, cfg);
  loop.start();
  ASSERT_TRUE(loop.run_until_state(State::kDone, 30.0)) << loop.ctrl.machine().summary();
  ASSERT_TRUE(loop.outcome(1));
  EXPECT_EQ(loop.outcome(1)->outcome, +fruit_outcome_t::UNREACHABLE);
  EXPECT_FALSE(ever_noted(loop, "the fruit in view"));
  expect_motion_stopped(loop);
}

TEST(ClosedLoop, MotionThatNeverCompletesIsAFaultAndStops) {
  // Stalls are not detected (stall longer than the motion timeout): the
  // timeout is the last resort.
  WorldSpec spec = experiment_one();
  spec.arm_ignores_goals_after_s = 0.0;
  ServoConfig cfg = test_config();
  cfg.timeouts.motion = 2.0;
  cfg.timeouts.stall = 5.0;
  Loop loop(spec, cfg);
  loop.start();
  ASSERT_TRUE(loop.run_until_state(State::kDone, 10.0)) << loop.ctrl.machine().summary();
  EXPECT_EQ(loop.outcome(1)->detail, "the arm could not reach a viewpoint of it (did not complete)");
}

// The thesis's own rotation law (orient_law: thesis_pd, eq. 6-24): ORIENT_PD
// turns the gripper in place by twists, holding the roll about its axis at the
// home pose's, and experiment I is picked as with the pose goal.
TEST(ClosedLoop, ThesisOrientationLawTurnsInPlaceAndPicksExperimentOne) {
  WorldSpec spec = experiment_one();
  ServoConfig cfg = test_config();
  cfg.orient_law = "thesis_pd";
  Loop loop(spec, cfg);
  loop.start();
  ASSERT_TRUE(loop.run_until_state(State::kOrientPd, 5.0));
  const Eigen::Vector3d from = loop.arm.tool().translation();
  const rt::Micros turning = loop.bus.now();
  ASSERT_TRUE(loop.run_until_state(State::kAcquire, 10.0)) << loop.ctrl.machine().summary();
  int turns = 0;
  for (const auto& [time, c] : loop.commands()) {
    if (time <= turning || time >= loop.bus.now()) continue;
    EXPECT_EQ(c.type, +robot_command_t::TYPE_TWIST) << "at " << time;
    EXPECT_LT(linear_speed(c), 1e-12);
    turns += angular_speed(c) > 0.1;
  }
  EXPECT_GT(turns, 10);
  EXPECT_LT((loop.arm.tool().translation() - from).norm(), 0.002);  // turned in place
  // The axis on the fixed camera's estimate, the roll that of home (x axis across the axis, closest to home's).
  const Eigen::Isometry3d tool = loop.arm.tool();
  const Eigen::Vector3d home_x = cfg.home_pose.rotation().col(0);
  const Eigen::Vector3d across = (home_x - home_x.dot(tool.rotation().col(2)) * tool.rotation().col(2)).normalized();
  EXPECT_LT(std::acos(std::min(1.0, tool.rotation().col(0).dot(across))), cfg.orient_tolerance);
  ASSERT_TRUE(loop.run_until_state(State::kDone, 60.0)) << loop.ctrl.machine().summary();
  expect_published(loop, 1, fruit_outcome_t::PICKED, "");
  EXPECT_TRUE(loop.world.fruit_picked(1));
  const auto states = published_states(loop);
  EXPECT_NE(std::find(states.begin(), states.end(), "ORIENT_PD"), states.end());
  EXPECT_EQ(std::find(states.begin(), states.end(), "ORIENT"), states.end());
  expect_within_limits(loop);
}

}  // namespace
}  // namespace harvest::servo::testing
