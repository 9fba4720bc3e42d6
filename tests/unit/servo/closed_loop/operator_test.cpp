// Closed-loop tests (closed_loop/loop.hpp): The operator and the emergency stop: e-stop, pause/resume, abort, home, a
// start away from home, malformed input.
#include <gtest/gtest.h>

#include <algorithm>

#include "closed_loop/loop.hpp"
#include "servo/geometry.hpp"

namespace harvest::servo::testing {
namespace {

TEST(ClosedLoop, EmergencyStopHaltsAtOnceAndLatchesUntilCleared) {
  WorldSpec spec = experiment_one();
  ServoConfig cfg = test_config();
  cfg.max_attempts_per_fruit = 2;
  Loop loop(spec, cfg);
  loop.start();
  ASSERT_TRUE(loop.run_until_state(State::kApproach, 20.0));
  const std::size_t before = loop.commands().size();
  loop.send(loop.t() + 0.005, ch::kEmergencyStop, estop(true, false));
  // The STOP goes out while handling the e-stop message itself, not at the next tick.
  ASSERT_GT(loop.commands().size(), before);
  EXPECT_EQ(loop.commands()[before].first, loop.bus.now());
  EXPECT_EQ(loop.commands()[before].second.type, +robot_command_t::TYPE_STOP);
  EXPECT_TRUE(loop.ctrl.machine().estop());
  EXPECT_EQ(loop.outcome(1)->outcome, +fruit_outcome_t::ABORTED);
  const double engaged_at = loop.t();
  loop.at(engaged_at + 1.0);
  loop.start(loop.t() + 0.001);                                                     // refused while latched
  loop.send(loop.t() + 0.001, ch::kEmergencyStop, estop(false, false));             // not a clear
  loop.send(loop.t() + 0.001, ch::kOperatorCommand, op(operator_command_t::HOME));  // refused
  loop.at(loop.t() + 1.0);
  EXPECT_EQ(loop.ctrl.machine().state(), State::kEstop);
  for (const auto& c : loop.commands_after(engaged_at)) EXPECT_EQ(c.type, +robot_command_t::TYPE_STOP);
  const auto status = loop.bus.messages<harvest_status_t>(ch::kHarvestStatus).back().second;
  EXPECT_TRUE(status.estop);
  // Clear, start again: the fruit gets its second attempt.
  loop.send(loop.t() + 0.001, ch::kEmergencyStop, estop(false, true));
  EXPECT_EQ(loop.ctrl.machine().state(), State::kIdle);
  loop.start(loop.t() + 0.001);
  ASSERT_TRUE(loop.run_until_state(State::kDone, 90.0)) << loop.ctrl.machine().summary();
  EXPECT_EQ(loop.ctrl.machine().outcomes().back().outcome, +fruit_outcome_t::PICKED);
  expect_within_limits(loop);
}

// Command authority (docs/security.md): the controller obeys operator
// commands and an e-stop clear only when an operator signed them; an e-stop
// engage from anyone. What it sends goes out signed as itself.
TEST(ClosedLoop, ObeysOnlyOperatorSignedCommandsAndSignsItsOwn) {
  Loop loop(experiment_one());
  harvest::testing::CommandSigner impostor("attacker", &loop.clock);
  harvest::testing::CommandSigner controller(harvest::testing::kController, &loop.clock);
  loop.at(0.05);
  loop.bus.inject(ch::kOperatorCommand, op(operator_command_t::START));              // unsigned
  loop.bus.inject(ch::kOperatorCommand, impostor(op(operator_command_t::START)));    // unknown sender
  loop.bus.inject(ch::kOperatorCommand, controller(op(operator_command_t::START)));  // not an operator
  loop.at(1.0);
  EXPECT_EQ(loop.ctrl.machine().state(), State::kIdle);
  const auto& counters = loop.ctrl.stats().counters;
  EXPECT_EQ(counters.at("operator_command_refused"), 3);
  EXPECT_EQ(counters.at("operator_command_unsigned"), 1);
  EXPECT_EQ(counters.at("operator_command_unknown_sender"), 2);
  loop.bus.inject(ch::kEmergencyStop, estop(true, false));  // unsigned engage: obeyed
  EXPECT_EQ(loop.ctrl.machine().state(), State::kEstop);
  loop.bus.inject(ch::kEmergencyStop, estop(false, true));  // unsigned clear: refused
  EXPECT_EQ(loop.ctrl.machine().state(), State::kEstop);
  EXPECT_EQ(counters.at("emergency_stop_clear_unsigned"), 1);
  loop.send(1.1, ch::kEmergencyStop, estop(false, true));  // an operator's
  EXPECT_EQ(loop.ctrl.machine().state(), State::kIdle);
  loop.start(1.2);
  loop.at(2.0);
  EXPECT_NE(loop.ctrl.machine().state(), State::kIdle);
  // Its commands carry its signature, each a new seq: the robot link's gate admits them.
  security::Authority link(harvest::testing::sim_authority("", harvest::testing::kController), security::sim_key(),
                           loop.clock, [](const std::string&, int64_t) {});
  const auto cmds = loop.commands();
  ASSERT_GT(cmds.size(), 10u);
  int64_t last = 0;
  for (const auto& [t, c] : cmds) {
    EXPECT_EQ(c.auth.sender, "servo-controller");
    EXPECT_GT(c.auth.seq, last);
    last = c.auth.seq;
  }
  security::Verifier verifier(security::sim_key(), {{"servo-controller"}}, loop.clock);
  EXPECT_EQ(verifier.check(cmds.back().second), security::Verdict::ok)
      << security::to_string(verifier.check(cmds.back().second)) << " signed at " << cmds.back().second.auth.utime
      << " now " << loop.bus.now() << " published at " << cmds.back().first;
}

TEST(ClosedLoop, EmergencyStopWhileIdleLatchesToo) {
  Loop loop(experiment_one());
  loop.at(0.5);
  loop.send(0.5005, ch::kEmergencyStop, estop(true, false));
  ASSERT_FALSE(loop.commands().empty());
  EXPECT_EQ(loop.commands().back().first, loop.bus.now());
  EXPECT_EQ(loop.commands().back().second.type, +robot_command_t::TYPE_STOP);
  for (int8_t c : {operator_command_t::START, operator_command_t::HOME, operator_command_t::RESET_FAULT,
                   operator_command_t::RESUME}) {
    loop.send(loop.t() + 0.1, ch::kOperatorCommand, op(c));
    EXPECT_EQ(loop.ctrl.machine().state(), State::kEstop) << int(c);
  }
  loop.at(loop.t() + 0.5);
  for (const auto& c : loop.commands_after(0.5)) EXPECT_EQ(c.type, +robot_command_t::TYPE_STOP);
  EXPECT_TRUE(loop.bus.messages<harvest_status_t>(ch::kHarvestStatus).back().second.estop);
  loop.send(loop.t() + 0.1, ch::kEmergencyStop, estop(false, true));
  EXPECT_EQ(loop.ctrl.machine().state(), State::kIdle);
  EXPECT_FALSE(loop.bus.messages<harvest_status_t>(ch::kHarvestStatus).back().second.estop);
  expect_within_limits(loop);
}

TEST(ClosedLoop, PauseHoldsStillAndResumeFinishes) {
  WorldSpec spec = experiment_one();
  Loop loop(spec);
  loop.start();
  ASSERT_TRUE(loop.run_until_state(State::kIrApproach, 20.0));
  loop.send(loop.t() + 0.005, ch::kOperatorCommand, op(operator_command_t::PAUSE));
  const double paused_at = loop.t();
  EXPECT_EQ(loop.commands().back().second.type, +robot_command_t::TYPE_STOP);
  loop.at(paused_at + 0.05);
  const Eigen::Vector3d p0 = loop.arm.tool().translation();
  loop.at(paused_at + 12.0);  // longer than the IR timeout: timeouts do not run while paused
  EXPECT_LT((loop.arm.tool().translation() - p0).norm(), 1e-9);
  EXPECT_EQ(loop.ctrl.machine().state(), State::kIrApproach);
  for (const auto& c : loop.commands_after(paused_at)) EXPECT_EQ(c.type, +robot_command_t::TYPE_STOP);
  loop.send(loop.t() + 0.005, ch::kOperatorCommand, op(operator_command_t::RESUME));
  ASSERT_TRUE(loop.run_until_state(State::kDone, 80.0));
  EXPECT_EQ(loop.outcome(1)->outcome, +fruit_outcome_t::PICKED);
  expect_within_limits(loop);
}

TEST(ClosedLoop, AbortStopsAndHomeReturnsToTheHomePose) {
  WorldSpec spec = experiment_one();
  Loop loop(spec);
  loop.start();
  ASSERT_TRUE(loop.run_until_state(State::kApproach, 20.0));
  loop.send(loop.t() + 0.005, ch::kOperatorCommand, op(operator_command_t::ABORT));
  EXPECT_EQ(loop.ctrl.machine().state(), State::kIdle);
  EXPECT_EQ(loop.commands().back().second.type, +robot_command_t::TYPE_STOP);
  EXPECT_EQ(loop.outcome(1)->outcome, +fruit_outcome_t::ABORTED);
  EXPECT_EQ(loop.outcome(1)->detail, "operator abort");
  loop.send(loop.t() + 0.005, ch::kOperatorCommand, op(operator_command_t::HOME));
  ASSERT_TRUE(loop.run_until_state(State::kIdle, 30.0));
  EXPECT_LT((loop.arm.tool().translation() - loop.cfg.home_pose.translation()).norm(), loop.cfg.position_tolerance);
  expect_within_limits(loop);
}

// A start away from home (here next to the fruit after an emergency stop)
// backs out along the tool axis and returns home before selecting.
TEST(ClosedLoop, StartAwayFromHomeBacksOutAndReturnsHomeFirst) {
  WorldSpec spec = experiment_one();
  ServoConfig cfg = test_config();
  cfg.max_attempts_per_fruit = 2;
  Loop loop(spec, cfg);
  loop.start();
  ASSERT_TRUE(loop.run_until_state(State::kIrApproach, 20.0));
  loop.send(loop.t() + 0.005, ch::kEmergencyStop, estop(true, false));
  loop.send(loop.t() + 0.5, ch::kEmergencyStop, estop(false, true));
  const Eigen::Isometry3d stopped = loop.arm.tool();
  loop.start(loop.t() + 0.001);
  EXPECT_EQ(loop.ctrl.machine().state(), State::kRetreat);
  const auto first = loop.commands().back().second;
  ASSERT_EQ(first.type, +robot_command_t::TYPE_POSE_GOAL);
  const Eigen::Vector3d back = to_isometry(first.pose_goal).translation() - stopped.translation();
  EXPECT_NEAR(back.dot(-stopped.rotation().col(2)), cfg.retreat_distance, 1e-6);
  ASSERT_TRUE(loop.run_until_state(State::kDone, 90.0)) << loop.ctrl.machine().summary();
  const auto states = published_states(loop);
  const auto restart = std::find(states.begin(), states.end(), "ESTOP");
  ASSERT_NE(restart, states.end());
  const std::vector<std::string> expected{"ESTOP", "IDLE", "RETREAT", "RETURN", "SELECT", "ORIENT"};
  ASSERT_GE(states.end() - restart, 6);
  EXPECT_EQ(std::vector<std::string>(restart, restart + 6), expected);
  EXPECT_EQ(loop.ctrl.machine().outcomes().back().outcome, +fruit_outcome_t::PICKED);
  expect_within_limits(loop);
}

TEST(ClosedLoop, MalformedInputIsDroppedAndCounted) {
  WorldSpec spec = experiment_one();
  Loop loop(spec);
  loop.start();
  loop.at(1.0);
  loop.bus.inject_raw(ch::kRobotState, {1, 2, 3, 4, 5});
  loop.bus.inject_raw(ch::kEmergencyStop, {9, 9});
  EXPECT_EQ(loop.ctrl.stats().decode_errors, 2);
  ASSERT_TRUE(loop.run_until_state(State::kDone, 60.0));
  EXPECT_EQ(loop.outcome(1)->outcome, +fruit_outcome_t::PICKED);
  expect_within_limits(loop);
}

}  // namespace
}  // namespace harvest::servo::testing
