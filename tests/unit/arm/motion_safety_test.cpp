// Motion safety of the robot link as pure logic: speed scaling and workspace
// clipping of twists, and the supervisor's latches and command freshness.
#include "arm/motion_safety.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>

namespace harvest::arm {
namespace {

kinematics::Twist twist(double vx, double vy, double vz, double wx = 0, double wy = 0, double wz = 0) {
  kinematics::Twist t;
  t << vx, vy, vz, wx, wy, wz;
  return t;
}

Workspace unit_box() {
  Workspace w;
  w.min = Eigen::Vector3d(-1, -1, -1);
  w.max = Eigen::Vector3d(1, 1, 1);
  return w;
}

TEST(ClipTwist, WithinLimitsPassesUnchanged) {
  const MotionLimits lim;
  const auto t = twist(0.1, -0.2, 0.05, 0.3, 0.0, -0.2);
  const ClippedTwist c = clip_twist(t, Eigen::Vector3d::Zero(), unit_box(), lim, 0.01);
  EXPECT_FALSE(c.clipped);
  EXPECT_TRUE(c.reason.empty());
  EXPECT_EQ(c.twist, t);
}

TEST(ClipTwist, LinearSpeedIsScaledKeepingTheDirection) {
  MotionLimits lim;
  lim.linear_speed = 0.381;
  const auto t = twist(3.0, 4.0, 0.0, 0.1, 0.0, 0.0);  // 5 m/s
  const ClippedTwist c = clip_twist(t, Eigen::Vector3d::Zero(), unit_box(), lim, 0.01);
  EXPECT_TRUE(c.clipped);
  EXPECT_NE(c.reason.find("linear speed"), std::string::npos) << c.reason;
  EXPECT_NEAR(c.twist.head<3>().norm(), 0.381, 1e-12);
  EXPECT_NEAR(c.twist[0] / c.twist[1], 0.75, 1e-12);  // same direction
  EXPECT_DOUBLE_EQ(c.twist[3], 0.1);                  // angular part untouched
}

TEST(ClipTwist, AngularSpeedIsScaledKeepingTheAxis) {
  MotionLimits lim;
  lim.angular_speed = 1.0;
  const auto t = twist(0.0, 0.0, 0.0, 0.0, -2.0, 2.0);
  const ClippedTwist c = clip_twist(t, Eigen::Vector3d::Zero(), unit_box(), lim, 0.01);
  EXPECT_TRUE(c.clipped);
  EXPECT_NE(c.reason.find("angular speed"), std::string::npos) << c.reason;
  EXPECT_NEAR(c.twist.tail<3>().norm(), 1.0, 1e-12);
  EXPECT_NEAR(c.twist[4], -c.twist[5], 1e-12);
}

TEST(ClipTwist, WorkspaceBoundaryStopsOnlyTheOutwardComponent) {
  const MotionLimits lim;
  // 5 mm from the +x face; 0.3 m/s for 0.1 s would carry it 30 mm past.
  const Eigen::Vector3d tcp(0.995, 0.0, 0.0);
  const auto t = twist(0.3, 0.1, -0.1);
  const double dt = 0.1;
  const ClippedTwist c = clip_twist(t, tcp, unit_box(), lim, dt);
  EXPECT_TRUE(c.clipped);
  EXPECT_NE(c.reason.find("workspace boundary in x"), std::string::npos) << c.reason;
  EXPECT_NEAR(tcp.x() + c.twist[0] * dt, 1.0, 1e-12);  // reaches the face, does not cross it
  EXPECT_DOUBLE_EQ(c.twist[1], 0.1);                   // motion along the face stays
  EXPECT_DOUBLE_EQ(c.twist[2], -0.1);
}

TEST(ClipTwist, SlowsDownSoItCanBrakeBeforeTheBoundary) {
  MotionLimits lim;
  lim.linear_acceleration = 0.5;
  // 10 cm from the -y face: at most sqrt(2 * 0.5 * 0.1) = 0.316 m/s toward it.
  const Eigen::Vector3d tcp(0.0, -0.9, 0.0);
  const ClippedTwist c = clip_twist(twist(0.0, -0.381, 0.0), tcp, unit_box(), lim, 0.01);
  EXPECT_TRUE(c.clipped);
  EXPECT_NEAR(c.twist[1], -std::sqrt(0.1), 1e-12);
  EXPECT_NE(c.reason.find("workspace boundary in y"), std::string::npos) << c.reason;
  // Away from that face, full speed.
  EXPECT_FALSE(clip_twist(twist(0.0, 0.381, 0.0), tcp, unit_box(), lim, 0.01).clipped);
}

TEST(ClipTwist, MotionBackIntoTheWorkspaceIsAllowed) {
  const MotionLimits lim;
  const Eigen::Vector3d outside(1.2, 0.0, -1.3);  // already outside on x and z
  const auto inward = twist(-0.2, 0.0, 0.2);
  const ClippedTwist c = clip_twist(inward, outside, unit_box(), lim, 0.01);
  EXPECT_FALSE(c.clipped);
  EXPECT_EQ(c.twist, inward);
  const ClippedTwist out = clip_twist(twist(0.2, 0.0, -0.2), outside, unit_box(), lim, 0.01);
  EXPECT_TRUE(out.clipped);
  EXPECT_DOUBLE_EQ(out.twist[0], 0.0);  // no further out
  EXPECT_DOUBLE_EQ(out.twist[2], 0.0);
}

TEST(ClipTwist, NonFiniteTwistBecomesZero) {
  const MotionLimits lim;
  const auto t = twist(std::numeric_limits<double>::quiet_NaN(), 0, 0);
  const ClippedTwist c = clip_twist(t, Eigen::Vector3d::Zero(), unit_box(), lim, 0.01);
  EXPECT_TRUE(c.clipped);
  EXPECT_TRUE(c.twist.isZero());
}

TEST(MotionSupervisor, CommandFreshnessUsesTheValidityWindow) {
  MotionLimits lim;
  lim.default_validity = 100'000;
  lim.max_validity = 1'000'000;
  MotionSupervisor s(lim);
  EXPECT_FALSE(s.command_fresh(0));
  EXPECT_FALSE(s.had_command());
  s.on_command(1'000'000, 0);  // default validity
  EXPECT_TRUE(s.command_fresh(1'100'000));
  EXPECT_FALSE(s.command_fresh(1'100'001));
  EXPECT_TRUE(s.had_command());
  s.on_command(2'000'000, 30'000);  // its own, shorter validity
  EXPECT_TRUE(s.command_fresh(2'030'000));
  EXPECT_FALSE(s.command_fresh(2'030'001));
  s.on_command(3'000'000, 60'000'000);  // too long: cut to max_validity
  EXPECT_TRUE(s.command_fresh(4'000'000));
  EXPECT_FALSE(s.command_fresh(4'000'001));
  s.cancel_command();
  EXPECT_FALSE(s.command_fresh(3'000'001));
}

TEST(MotionSupervisor, EmergencyStopLatchesUntilAnExplicitClear) {
  MotionSupervisor s{MotionLimits{}};
  s.on_command(0, 0);
  ASSERT_TRUE(s.may_move());
  s.on_emergency_stop(true, false, "operator: test");
  EXPECT_TRUE(s.estopped());
  EXPECT_FALSE(s.may_move());
  EXPECT_FALSE(s.command_fresh(1)) << "an e-stop drops the current command";
  EXPECT_NE(s.estop_text().find("operator: test"), std::string::npos);
  s.on_emergency_stop(false, false, "released without clear");
  EXPECT_TRUE(s.estopped()) << "engaged = false without clear does not release";
  EXPECT_FALSE(s.reset_fault()) << "a fault reset does not release an e-stop";
  EXPECT_TRUE(s.estopped());
  s.on_emergency_stop(false, true, "operator: clear");
  EXPECT_FALSE(s.estopped());
  EXPECT_TRUE(s.may_move());
  EXPECT_TRUE(s.estop_text().empty());
  EXPECT_FALSE(s.command_fresh(1)) << "motion needs a new command after a clear";
}

TEST(MotionSupervisor, FaultsLatchAccumulateAndNeedAReset) {
  MotionSupervisor s{MotionLimits{}};
  s.on_command(0, 0);
  s.on_fault("joint 3 (node 3): EMCY 0x2310");
  s.on_fault("joint 3 (node 3): EMCY 0x2310");  // repeated: not duplicated
  s.on_fault("joint 1 (node 1): heartbeat lost");
  EXPECT_TRUE(s.faulted());
  EXPECT_FALSE(s.may_move());
  EXPECT_FALSE(s.command_fresh(1));
  EXPECT_EQ(s.fault_text(), "joint 3 (node 3): EMCY 0x2310; joint 1 (node 1): heartbeat lost");
  EXPECT_TRUE(s.reset_fault());
  EXPECT_FALSE(s.faulted());
  EXPECT_TRUE(s.fault_text().empty());
  EXPECT_TRUE(s.may_move());
}

TEST(MotionSupervisor, FaultResetDuringEmergencyStopKeepsTheFault) {
  MotionSupervisor s{MotionLimits{}};
  s.on_fault("drive fault");
  s.on_emergency_stop(true, false, "x");
  EXPECT_FALSE(s.reset_fault());
  EXPECT_TRUE(s.faulted());
  s.on_emergency_stop(false, true, "x");
  EXPECT_FALSE(s.may_move()) << "clearing the e-stop leaves the fault latched";
  EXPECT_TRUE(s.reset_fault());
  EXPECT_TRUE(s.may_move());
}

}  // namespace
}  // namespace harvest::arm
