// Closed-loop tests (closed_loop/loop.hpp): faults stop the arm at once and latch until
// RESET_FAULT: robot and gripper faults, the robot-state watchdog, a gripper that never reports.
#include <gtest/gtest.h>

#include <functional>
#include <optional>

#include "closed_loop/loop.hpp"

namespace harvest::servo::testing {
namespace {

// One fault each, injected into experiment I: the field of WorldSpec that
// differs, and the start of the aborted fruit's detail.
struct Fault {
  const char* name;
  std::function<void(WorldSpec&)> inject;
  std::string detail;
  std::optional<double> within_s;  // the fruit is aborted at most this long after the start
};

class FaultStops : public ::testing::TestWithParam<Fault> {};

TEST_P(FaultStops, AbortsTheFruitStopsTheArmAndLatches) {
  WorldSpec spec = experiment_one();
  GetParam().inject(spec);
  Loop loop(spec);
  loop.start();
  expect_fault_stops(loop, GetParam().detail);
  if (GetParam().within_s) {
    EXPECT_LE(loop.outcome(1)->cycle_time_s, *GetParam().within_s);
  }
}

// The silent robot trips the watchdog timeouts.robot_state (0.25 s) after it went quiet at 2 s.
INSTANTIATE_TEST_SUITE_P(
    ClosedLoop, FaultStops,
    ::testing::Values(Fault{"GripperFault", [](WorldSpec& s) { s.gripper_fault_after_s = 1.5; }, "gripper fault 7", {}},
                      Fault{"RobotFault",
                            [](WorldSpec& s) { s.robot_fault_after_s = 2.0; },
                            "robot fault: joint 2 following error",
                            {}},
                      Fault{"SilentRobot", [](WorldSpec& s) { s.robot_silent_after_s = 2.0; }, "robot state stale",
                            2.0 + 0.25 + 0.05},
                      Fault{"RobotEmergencyStopMode",
                            [](WorldSpec& s) { s.robot_estop_after_s = 2.0; },
                            "robot reports emergency stop",
                            {}},
                      Fault{"GripperDisconnect",
                            [](WorldSpec& s) { s.gripper_disconnect_after_s = 1.5; },
                            "gripper disconnected",
                            {}},
                      Fault{"GripperNeverReports",
                            [](WorldSpec& s) { s.gripper_stuck = true; },
                            "gripper did not report holding or closed in time",
                            {}}),
    [](const ::testing::TestParamInfo<Fault>& info) { return std::string(info.param.name); });

TEST(ClosedLoop, GripperThatNeverOpensAtTheDropIsAFaultAndStops) {
  WorldSpec spec = experiment_one();
  spec.gripper_wont_open = true;
  ServoConfig cfg = test_config();
  cfg.release_while_retreating = false;  // RELEASE at rest (the way out: grasp_release_test.cpp)
  Loop loop(spec, cfg);
  loop.start();
  ASSERT_TRUE(loop.run_until_state(State::kRelease, 60.0)) << loop.ctrl.machine().summary();
  expect_fault_stops(loop, "gripper did not report open in time");
}

}  // namespace
}  // namespace harvest::servo::testing
