#include "servo/harvest/safety.hpp"

#include <gtest/gtest.h>

#include <limits>

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

TEST(Safety, HandDetectionsWithNoImageSizeOrNonFiniteNumbersAreInvalidInput) {
  fruit_detections_t m{};
  m.camera = "hand";
  m.image_width = 640;
  m.image_height = 480;
  m.fruits = {fruit_t{}, fruit_t{}};
  m.num_fruits = 2;
  EXPECT_FALSE(invalid_detections(m));
  auto with = [&](auto set) {
    fruit_detections_t bad = m;
    set(bad);
    return invalid_detections(bad).value_or("");
  };
  EXPECT_EQ(with([](fruit_detections_t& b) { b.image_width = 0; }), "image size 0 x 480");
  EXPECT_EQ(with([](fruit_detections_t& b) { b.image_height = -480; }), "image size 640 x -480");
  const float nan = std::numeric_limits<float>::quiet_NaN(), inf = std::numeric_limits<float>::infinity();
  EXPECT_EQ(with([&](fruit_detections_t& b) { b.fruits[1].area_px = inf; }),
            "fruit 1: pixel position, diameter or area is not finite");
  EXPECT_NE(with([&](fruit_detections_t& b) { b.fruits[0].u_px = nan; }), "");
  EXPECT_NE(with([&](fruit_detections_t& b) { b.fruits[0].v_px = -inf; }), "");
  EXPECT_NE(with([&](fruit_detections_t& b) { b.fruits[0].diameter_px = nan; }), "");
}

TEST(Safety, TargetsWithNonFiniteNumbersAreInvalidInput) {
  targets_t m{};
  m.source_camera = "fixed";
  target_t t{};
  t.fruit_id = 4;
  t.position_base[1] = 0.8;
  m.targets = {t, t};
  m.num_targets = 2;
  EXPECT_FALSE(invalid_targets(m));
  const double nan = std::numeric_limits<double>::quiet_NaN(), inf = std::numeric_limits<double>::infinity();
  auto with = [&](auto set) {
    targets_t bad = m;
    set(bad);
    return invalid_targets(bad).value_or("");
  };
  EXPECT_EQ(with([&](targets_t& b) { b.targets[1].position_base[2] = nan; }),
            "target 1 (fruit 4): position_base is not finite");
  EXPECT_EQ(with([&](targets_t& b) { b.targets[0].position_camera[0] = -inf; }),
            "target 0 (fruit 4): position_camera is not finite");
  EXPECT_EQ(with([&](targets_t& b) { b.targets[0].covariance_base[8] = inf; }),
            "target 0 (fruit 4): covariance_base is not finite");
  EXPECT_NE(with([&](targets_t& b) { b.targets[0].depth_m = nan; }), "");
  EXPECT_NE(with([&](targets_t& b) { b.targets[0].u_px = static_cast<float>(inf); }), "");
  // The camera position counts only when the message says it is known.
  EXPECT_EQ(with([&](targets_t& b) { b.camera_position_base[0] = nan; }), "");
  EXPECT_EQ(with([&](targets_t& b) {
              b.camera_known = 1;
              b.camera_position_base[0] = nan;
            }),
            "camera_position_base is not finite");
}

}  // namespace
}  // namespace harvest::servo
