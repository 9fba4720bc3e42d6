#include "servo/harvest/safety.hpp"

#include <gtest/gtest.h>

#include "harvest/operator_command_t.hpp"

namespace harvest::servo {
namespace {

using C = operator_command_t;

std::string why(int8_t command, CommandContext c) { return refusal(command, c).value_or(""); }

TEST(Safety, ALatchedEmergencyStopOrFaultRefusesEveryCommandThatMoves) {
  for (int8_t command : {C::START, C::HOME}) {
    EXPECT_EQ(why(command, {State::kEstop, false, true, true}), "emergency stop latched");
    EXPECT_EQ(why(command, {State::kFault, false, false, true}), "fault latched, send RESET_FAULT");
    EXPECT_EQ(why(command, {State::kIdle, false, false, false}), "no robot state");
    EXPECT_EQ(why(command, {State::kIdle, false, false, true}), "");
  }
  EXPECT_EQ(why(C::RESUME, {State::kFault, false, false, true}), "not paused");
  EXPECT_EQ(why(C::RESET_FAULT, {State::kFault, false, false, true}), "");
  EXPECT_EQ(why(C::RESET_FAULT, {State::kEstop, false, true, true}), "no fault to reset");
}

TEST(Safety, CommandsThatDoNotFitTheStateAreRefused) {
  EXPECT_EQ(why(C::START, {State::kApproach, false, false, true}), "already running");
  EXPECT_EQ(why(C::HOME, {State::kApproach, false, false, true}), "");  // home from anywhere
  EXPECT_EQ(why(C::PAUSE, {State::kIdle, false, false, true}), "nothing to pause");
  EXPECT_EQ(why(C::PAUSE, {State::kApproach, true, false, true}), "nothing to pause");
  EXPECT_EQ(why(C::PAUSE, {State::kApproach, false, false, true}), "");
  EXPECT_EQ(why(C::RESUME, {State::kApproach, false, false, true}), "not paused");
  EXPECT_EQ(why(C::RESUME, {State::kApproach, true, false, true}), "");
  EXPECT_EQ(why(C::RESET_FAULT, {State::kIdle, false, false, true}), "no fault to reset");
  EXPECT_EQ(why(9, {State::kIdle, false, false, true}), "unknown command 9");
  EXPECT_EQ(why(-1, {State::kIdle, false, false, true}), "unknown command -1");
  // ABORT is obeyed in every state (it never releases a latch: the machine's job).
  for (State s : {State::kIdle, State::kApproach, State::kFault, State::kEstop})
    EXPECT_EQ(why(C::ABORT, {s, false, s == State::kEstop, false}), "");
}

TEST(Safety, RobotAndGripperFaultsAreNamed) {
  robot_state_t r{};
  r.mode = robot_state_t::MODE_FAULT;
  r.fault_text = "joint 2 following error";
  EXPECT_EQ(robot_fault(r).value_or(""), "robot fault: joint 2 following error");
  r.fault_text = "";
  EXPECT_EQ(robot_fault(r).value_or(""), "robot fault: (no text)");
  r.mode = robot_state_t::MODE_ESTOP;
  EXPECT_EQ(robot_fault(r).value_or(""), "robot reports emergency stop");
  r.mode = robot_state_t::MODE_DISABLED;
  EXPECT_EQ(robot_fault(r).value_or(""), "robot drives disabled");
  r.mode = robot_state_t::MODE_MOVING;
  EXPECT_FALSE(robot_fault(r).has_value());

  gripper_state_t g{};
  g.connected = true;
  g.state = gripper_state_t::STATE_FAULT;
  g.fault_code = 7;
  g.fault_text = "overcurrent";
  EXPECT_EQ(gripper_fault(g).value_or(""), "gripper fault 7: overcurrent");
  g.state = gripper_state_t::STATE_DISCONNECTED;
  EXPECT_EQ(gripper_fault(g).value_or(""), "gripper disconnected");
  g.state = gripper_state_t::STATE_OPEN;
  g.connected = false;
  EXPECT_EQ(gripper_fault(g).value_or(""), "gripper disconnected");
  g.connected = true;
  EXPECT_FALSE(gripper_fault(g).has_value());
}

}  // namespace
}  // namespace harvest::servo
