// Closed-loop tests (closed_loop/loop.hpp): The last centimetres under IR guidance: braking, leaves, fruit in the way,
// the sensor's fold-back, back-off and retry, the advance while the gripper closes.
#include <gtest/gtest.h>

#include <algorithm>

#include "closed_loop/loop.hpp"
#include "servo/geometry.hpp"

namespace harvest::servo::testing {
namespace {

// Under IR guidance the arm moves fast while the fruit is far and slows in
// proportion to the range still to go, arriving at the grasp range slowly.
TEST(ClosedLoop, IrGuidedApproachSlowsDownNearTheFruit) {
  WorldSpec spec = experiment_one();
  Loop loop(spec);
  loop.start();
  ASSERT_TRUE(loop.run_until_state(State::kIrApproach, 30.0)) << loop.ctrl.machine().summary();
  const Eigen::Vector3d from = loop.arm.tool().translation();
  const double t0 = loop.t();
  double last = 0.0;
  while (loop.ctrl.machine().state() == State::kIrApproach && loop.t() < 60.0) {
    const robot_command_t c = loop.commands().back().second;  // commands() returns a copy
    if (c.type == robot_command_t::TYPE_TWIST)
      last = Eigen::Vector3d(c.twist.linear[0], c.twist.linear[1], c.twist.linear[2])
                 .dot(loop.arm.tool().rotation().col(2));
    loop.at(loop.t() + 0.01);
  }
  ASSERT_EQ(loop.ctrl.machine().state(), State::kGrasp);
  // A constant ir_min_speed approach would average that speed; this one is
  // well above it on average and arrives at about it.
  const double mean = (loop.arm.tool().translation() - from).norm() / (loop.t() - t0);
  EXPECT_GT(mean, 3.0 * loop.cfg.ir_min_speed) << mean;
  EXPECT_LT(last, loop.cfg.ir_min_speed + 0.02) << last;
}

// A leaf 15 cm in front of the fruit reads like the fruit at the grasp range;
// the camera-in-hand puts the fruit much farther: the approach goes on past
// the leaf and closes on the fruit.
TEST(ClosedLoop, LeafInFrontOfTheFruitIsPassedNotGraspedAt) {
  WorldSpec spec = experiment_one();
  spec.fixed_error.setZero();  // the cameras' rays cross: a triangulated estimate
  spec.leaf_before_fruit_m = 0.15;
  ServoConfig cfg = test_config();
  ASSERT_GT(cfg.ir_vision_agreement, 0.0);
  Loop loop(spec, cfg);
  loop.start();
  ASSERT_TRUE(loop.run_until_state(State::kDone, 60.0)) << loop.ctrl.machine().summary();
  EXPECT_EQ(loop.outcome(1)->outcome, +fruit_outcome_t::PICKED) << loop.outcome(1)->detail;
  ASSERT_TRUE(loop.world.close_position().has_value());
  EXPECT_LT((*loop.world.close_position() - spec.fruits[0].position).norm(), 0.02);
  EXPECT_TRUE(ever_noted(loop, "past a leaf"));
  expect_within_limits(loop);
}

// The thing the IR reads at the grasp range, 15 cm before the fruit aimed
// at, fills the hand image: a fruit in front of it, not a leaf. The gripper
// closes on that one instead of pushing on and knocking it off; the one
// aimed at is picked afterwards.
TEST(ClosedLoop, FruitInFrontOfTheOneAimedAtIsGraspedNotPushedPast) {
  WorldSpec spec = experiment_one();
  spec.fixed_error.setZero();
  spec.hand_reports_filling = true;
  const Eigen::Vector3d aimed = spec.fruits[0].position;
  const Eigen::Vector3d in_front = aimed - 0.15 * (aimed - spec.start_tool.translation()).normalized();
  spec.fruits.push_back({2, in_front, 0.075});
  Loop loop(spec);
  loop.start();
  ASSERT_TRUE(loop.run_until_state(State::kDetach, 30.0)) << loop.ctrl.machine().summary();
  EXPECT_EQ(loop.ctrl.machine().current_fruit(), 1);  // aimed at the far one ...
  ASSERT_TRUE(loop.world.close_position().has_value());
  EXPECT_LT((*loop.world.close_position() - in_front).norm(), 0.03);  // ... closed on the near one
  ASSERT_TRUE(loop.run_until_state(State::kDone, 90.0)) << loop.ctrl.machine().summary();
  EXPECT_TRUE(loop.world.fruit_picked(1));
  EXPECT_TRUE(loop.world.fruit_picked(2));
  EXPECT_FALSE(ever_noted(loop, "past a leaf"));
}

// The fruit in front lies 2 cm beside the gripper's path: the IR reads it,
// but a closing finger would knock it off and pushing on would too. The
// attempt is given up without closing; the fruit in front is picked in its
// own turn, and the one aimed at after it.
TEST(ClosedLoop, FruitInFrontBesideTheGripperAxisIsNeitherGraspedNorPushedPast) {
  WorldSpec spec = experiment_one();
  spec.fixed_error.setZero();
  spec.hand_reports_filling = true;
  const Eigen::Vector3d aimed = spec.fruits[0].position;
  const Eigen::Vector3d path = (aimed - spec.start_tool.translation()).normalized();
  // Off the plane of the two cameras' rays, so the camera-in-hand keeps
  // following the fruit aimed at (its image lies on the fixed camera's line of sight).
  const Eigen::Vector3d beside = path.cross((aimed - spec.fixed_camera).normalized()).normalized();
  const Eigen::Vector3d in_front = aimed - 0.15 * path + 0.02 * beside;  // inside the IR beam (26 mm)
  spec.fruits.push_back({2, in_front, 0.075});
  ServoConfig cfg = test_config();
  cfg.max_attempts_per_fruit = 2;
  cfg.fruit_order = "cost";  // the order this test is about
  Loop loop(spec, cfg);
  loop.start();
  ASSERT_TRUE(loop.run_until_state(State::kDone, 120.0)) << loop.ctrl.machine().summary();
  const auto& outcomes = loop.ctrl.machine().outcomes();
  ASSERT_GE(outcomes.size(), 3u);
  EXPECT_EQ(outcomes[0].fruit_id, 1);
  EXPECT_EQ(outcomes[0].outcome, +fruit_outcome_t::FAILED_GRASP);
  EXPECT_EQ(outcomes[0].detail.rfind("a fruit in the way, ", 0), 0u) << outcomes[0].detail;
  EXPECT_EQ(outcomes[1].fruit_id, 2);
  EXPECT_EQ(outcomes[1].outcome, +fruit_outcome_t::PICKED);
  EXPECT_TRUE(loop.world.fruit_picked(1));
  EXPECT_TRUE(loop.world.fruit_picked(2));
  EXPECT_FALSE(ever_noted(loop, "past a leaf"));
  expect_within_limits(loop);
}

// ... but not with a depth from the apparent size alone (here the rays do
// not cross: the fixed camera's estimate is 145 mm off across its line of
// sight): that depth may be decimetres off, and the IR reading is taken ...
// unless the fruit is seen whole in a fresh hand image with its estimate a
// decimetre or more ahead (far_view_ahead): then its size is a current depth
// from the whole fruit, and what the IR reads 15 cm before it is a leaf.
TEST(ClosedLoop, LeafRuleNeedsATriangulatedEstimateOrTheFruitSeenWholeAndFar) {
  WorldSpec spec = experiment_one();
  spec.leaf_before_fruit_m = 0.15;
  ServoConfig off = test_config();
  off.far_view_ahead = 0.0;
  Loop loop(spec, off);
  loop.start();
  ASSERT_TRUE(loop.run_until_state(State::kDone, 60.0)) << loop.ctrl.machine().summary();
  ASSERT_TRUE(loop.world.close_position().has_value());
  EXPECT_GT((*loop.world.close_position() - spec.fruits[0].position).norm(), 0.1);  // closed at the leaf
  EXPECT_FALSE(ever_noted(loop, "past a leaf"));

  Loop seen(spec);
  ASSERT_GT(test_config().far_view_ahead, 0.0);
  seen.start();
  ASSERT_TRUE(seen.run_until_state(State::kDone, 60.0)) << seen.ctrl.machine().summary();
  EXPECT_EQ(seen.outcome(1)->outcome, +fruit_outcome_t::PICKED) << seen.outcome(1)->detail;
  ASSERT_TRUE(seen.world.close_position().has_value());
  EXPECT_LT((*seen.world.close_position() - spec.fruits[0].position).norm(), 0.02);
  EXPECT_TRUE(ever_noted(seen, "seen whole: past a leaf"));
}

// A leaf 12 cm before the fruit: at the leaf's reading the fruit aimed at
// already fills the hand image, at the size its estimate says. That is the
// fruit aimed at, not one in front of it: the leaf is still passed.
TEST(ClosedLoop, LeafIsPassedWhileTheFruitAimedAtFillsTheImage) {
  WorldSpec spec = experiment_one();
  spec.fixed_error.setZero();
  spec.hand_reports_filling = true;
  spec.leaf_before_fruit_m = 0.12;
  Loop loop(spec);
  loop.start();
  ASSERT_TRUE(loop.run_until_state(State::kDone, 60.0)) << loop.ctrl.machine().summary();
  EXPECT_EQ(loop.outcome(1)->outcome, +fruit_outcome_t::PICKED) << loop.outcome(1)->detail;
  EXPECT_TRUE(ever_noted(loop, "past a leaf"));
}

// Without retrace_way_in (the default) BACKOFF goes straight back along the
// tool axis, to abreast of where the IR phase started.
TEST(ClosedLoop, BackOffRetracesTheToolAxis) {
  WorldSpec spec = experiment_one();
  spec.ir_dead = true;
  Loop loop(spec);
  loop.start();
  ASSERT_TRUE(loop.run_until_state(State::kBackoff, 60.0)) << loop.ctrl.machine().summary();
  const Eigen::Isometry3d tool = loop.arm.tool();
  const auto goal = to_isometry(loop.commands().back().second.pose_goal);
  ASSERT_EQ(loop.commands().back().second.type, +robot_command_t::TYPE_POSE_GOAL);
  const Eigen::Vector3d back = goal.translation() - tool.translation();
  EXPECT_GT(back.norm(), 0.1);
  EXPECT_LT(back.cross(tool.rotation().col(2)).norm(), 1e-4);  // no sideways part
  EXPECT_LT(back.dot(tool.rotation().col(2)), 0.0);            // backwards
  EXPECT_LT(rotation_distance(goal.rotation(), tool.rotation()), 1e-6);
}

// With retrace_way_in (off by default, docs/demo.md) BACKOFF goes straight back
// to where the IR phase started, in the tool's orientation: the centring
// moved the tool sideways on the way in, and the axis line would pass that
// far beside the way the palm came (docs/demo.md).
TEST(ClosedLoop, BackOffRetracingTheWayInGoesStraightBackToWhereIrGuidanceBegan) {
  WorldSpec spec = experiment_one();
  spec.ir_dead = true;
  ServoConfig cfg = test_config();
  cfg.retrace_way_in = true;
  Loop loop(spec, cfg);
  loop.start();
  ASSERT_TRUE(loop.run_until_state(State::kIrApproach, 60.0)) << loop.ctrl.machine().summary();
  const Eigen::Vector3d began = loop.arm.tool().translation();
  ASSERT_TRUE(loop.run_until_state(State::kBackoff, 60.0)) << loop.ctrl.machine().summary();
  const Eigen::Isometry3d tool = loop.arm.tool();
  ASSERT_EQ(loop.commands().back().second.type, +robot_command_t::TYPE_POSE_GOAL);
  const auto goal = to_isometry(loop.commands().back().second.pose_goal);
  EXPECT_LT((goal.translation() - began).norm(), 0.01);
  EXPECT_GT((tool.translation() - began).cross(tool.rotation().col(2)).norm(), 1e-3);  // not along the axis
  EXPECT_LT(rotation_distance(goal.rotation(), tool.rotation()), 1e-6);
}

// An IR sensor that folds back before the grasp range reads a near fruit as
// far: the camera-in-hand's estimate bounds the range to go, so the arm keeps
// braking into the fruit instead of speeding up, and backs off past it.
TEST(ClosedLoop, IrFoldBackDoesNotSpeedTheArmIntoTheFruit) {
  WorldSpec spec = experiment_one();
  spec.hand_depth_scale = 1.0;
  spec.ir_fold_back_below_m = 0.06;
  ServoConfig cfg = test_config();
  cfg.ir_grasp_range = 0.035;  // never read: the sensor folds back first
  Loop loop(spec, cfg);
  loop.start();
  ASSERT_TRUE(loop.run_until_state(State::kIrApproach, 30.0)) << loop.ctrl.machine().summary();
  double fastest_near = 0.0;  // forward speed commanded with the fruit centre < 3 cm ahead
  while (loop.ctrl.machine().state() == State::kIrApproach && loop.t() < 60.0) {
    const robot_command_t c = loop.commands().back().second;  // commands() returns a copy
    const Eigen::Isometry3d tool = loop.arm.tool();
    const double ahead = (spec.fruits[0].position - tool.translation()).dot(tool.rotation().col(2));
    if (c.type == robot_command_t::TYPE_TWIST && ahead < 0.03)
      fastest_near = std::max(fastest_near, linear(c).dot(tool.rotation().col(2)));
    loop.at(loop.t() + 0.01);
  }
  EXPECT_EQ(loop.ctrl.machine().state(), State::kBackoff);
  EXPECT_LT(fastest_near, 0.25) << "m/s";
}

// The back-off for the second IR attempt cannot be completed (the arm is
// blocked next to the canopy): the fruit is given up, the arm retreats and
// returns home; no fault.
TEST(ClosedLoop, BlockedBackOffGivesTheFruitUpWithoutAFault) {
  WorldSpec spec = experiment_one();
  spec.ir_dead = true;
  Loop loop(spec);
  loop.start();
  ASSERT_TRUE(loop.run_until_state(State::kBackoff, 30.0)) << loop.ctrl.machine().summary();
  loop.spec.arm_ignores_goals_after_s = 0.0;
  ASSERT_TRUE(loop.run_until_state(State::kRetreat, 10.0)) << loop.ctrl.machine().summary();
  loop.spec.arm_ignores_goals_after_s.reset();
  ASSERT_TRUE(loop.run_until_state(State::kDone, 30.0)) << loop.ctrl.machine().summary();
  expect_published(loop, 1, fruit_outcome_t::FAILED_GRASP, "IR sensor never triggered (back-off stalled)");
  const auto states = published_states(loop);
  EXPECT_EQ(std::count(states.begin(), states.end(), "FAULT"), 0);
}

// Under IR guidance the arm stops moving (the edge of its reach, a joint
// limit): after timeouts.stall without 5 mm of progress it is treated as an
// IR attempt that failed, not waited out for the whole IR timeout.
TEST(ClosedLoop, BlockedIrApproachIsNotWaitedOut) {
  WorldSpec spec = experiment_one();
  spec.ir_dead = true;
  Loop loop(spec);
  loop.start();
  ASSERT_TRUE(loop.run_until_state(State::kIrApproach, 30.0)) << loop.ctrl.machine().summary();
  const double blocked_at = loop.t();
  loop.spec.arm_blocked_after_s = blocked_at;
  while (loop.ctrl.machine().state() == State::kIrApproach && loop.t() < blocked_at + 20.0) loop.at(loop.t() + 0.01);
  EXPECT_EQ(loop.ctrl.machine().state(), State::kBackoff);
  EXPECT_LT(loop.t() - blocked_at, loop.cfg.timeouts.stall + 0.5);
  EXPECT_LT(loop.cfg.timeouts.stall + 0.5, loop.cfg.timeouts.ir_approach);
}

// The sensor folds back 1 mm above the grasp range, so no reading ever falls
// inside it: a reading just above it followed by a jump to far is the fruit
// inside the fold-back, and the gripper closes on it.
TEST(ClosedLoop, IrFoldBackJumpIsTheFruitInsideTheGraspRange) {
  WorldSpec spec = experiment_one();
  spec.ir_fold_back_below_m = 0.036;
  ServoConfig cfg = test_config();
  cfg.ir_grasp_range = 0.035;
  Loop loop(spec, cfg);
  loop.start();
  ASSERT_TRUE(loop.run_until_state(State::kDone, 60.0)) << loop.ctrl.machine().summary();
  EXPECT_EQ(loop.outcome(1)->outcome, +fruit_outcome_t::PICKED) << loop.outcome(1)->detail;
  const auto states = published_states(loop);
  EXPECT_EQ(std::count(states.begin(), states.end(), "BACKOFF"), 0);
}

TEST(ClosedLoop, IrNeverTriggersBacksOffRetriesOnceThenFails) {
  WorldSpec spec = experiment_one();
  spec.ir_dead = true;
  Loop loop(spec);
  loop.start();
  ASSERT_TRUE(loop.run_until_state(State::kDone, 90.0)) << loop.ctrl.machine().summary();
  ASSERT_NE(loop.outcome(1), nullptr);
  EXPECT_EQ(loop.outcome(1)->outcome, +fruit_outcome_t::FAILED_GRASP);
  EXPECT_EQ(loop.outcome(1)->detail, "IR sensor never triggered");
  std::vector<std::string> states;
  for (const auto& [time, s] : loop.bus.messages<harvest_status_t>(ch::kHarvestStatus))
    if (states.empty() || states.back() != s.state) states.push_back(s.state);
  EXPECT_EQ(std::count(states.begin(), states.end(), "IR_APPROACH"), 2);
  EXPECT_EQ(std::count(states.begin(), states.end(), "BACKOFF"), 1);
  EXPECT_FALSE(loop.world.close_position().has_value());
  // It backs off once past the estimated fruit centre by ir_overshoot, not
  // after ir_max_travel: the tool point never got that far beyond the fruit.
  double deepest = -1.0;
  for (const auto& [time, st] : loop.bus.messages<robot_state_t>(ch::kRobotState)) {
    const Eigen::Isometry3d tool = to_isometry(st.tool_pose);
    deepest = std::max(deepest, (tool.translation() - spec.fruits[0].position).dot(tool.rotation().col(2)));
  }
  EXPECT_LT(deepest, loop.cfg.ir_overshoot + 0.03) << "tool point " << deepest * 1000 << " mm past the fruit";
  expect_within_limits(loop);
  expect_published(loop, 1, fruit_outcome_t::FAILED_GRASP, "IR sensor never triggered");
  expect_motion_stopped(loop);
}

// At the IR grasp reading the gripper is told to close, and the arm goes on
// grasp_advance along its axis while the fingers close (the fruit centre is
// still ~2 cm ahead: the sensor folds back nearer), slowly, then stops;
// grasp_advance 0 stops at once (the thesis's HarvestStep5).
TEST(ClosedLoop, ArmGoesOnAlongTheAxisWhileTheGripperCloses) {
  for (const double advance : {0.015, 0.0}) {
    WorldSpec spec = experiment_one();
    ServoConfig cfg = test_config();
    cfg.grasp_advance = advance;
    cfg.ir_min_speed = 0.06;  // 15 mm in 0.25 s, within the world double's 0.3 s close
    Loop loop(spec, cfg);
    loop.start();
    ASSERT_TRUE(loop.run_until_state(State::kGrasp, 30.0)) << loop.ctrl.machine().summary();
    const double closed_at = loop.t();
    const Eigen::Isometry3d at_close = loop.arm.tool();
    ASSERT_TRUE(loop.run_until_state(State::kDetach, 30.0)) << loop.ctrl.machine().summary();
    const Eigen::Vector3d moved = loop.arm.tool().translation() - at_close.translation();
    const Eigen::Vector3d axis = at_close.rotation().col(2);
    EXPECT_NEAR(moved.dot(axis), advance, 0.002) << "advance " << advance;
    EXPECT_LT((moved - moved.dot(axis) * axis).norm(), 0.001) << "straight along the axis";
    for (const auto& c : loop.commands_after(closed_at)) {
      if (c.type != robot_command_t::TYPE_TWIST) continue;
      EXPECT_LE(linear_speed(c), std::max(cfg.ir_min_speed, 0.1) + 1e-9);
    }
    EXPECT_EQ(loop.commands_after(loop.t() - 0.05).back().type, +robot_command_t::TYPE_POSE_GOAL);  // the pull
    ASSERT_TRUE(loop.run_until_state(State::kDone, 30.0)) << loop.ctrl.machine().summary();
    EXPECT_EQ(loop.outcome(1)->outcome, +fruit_outcome_t::PICKED);
    expect_within_limits(loop);
  }
}

}  // namespace
}  // namespace harvest::servo::testing
