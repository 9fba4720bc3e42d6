#include "sim/cartesian_arm.hpp"

#include <gtest/gtest.h>

#include "sim/scene.hpp"

namespace harvest::sim {
namespace {

robot_command_t twist(double vx, double vy, double vz, int64_t validity_us = 100'000) {
  robot_command_t c{};
  c.type = robot_command_t::TYPE_TWIST;
  c.validity_us = validity_us;
  c.twist.linear[0] = vx;
  c.twist.linear[1] = vy;
  c.twist.linear[2] = vz;
  return c;
}

void run(CartesianArm& arm, double from, double to) {
  for (double t = from; t <= to + 1e-9; t += 0.01) arm.step(t);
}

TEST(CartesianArm, FollowsTwistsWithinTheSpeedAndAccelerationLimits) {
  ArmSetup setup;
  CartesianArm arm(setup, {Mat3::Identity(), Vec3::Zero()}, {});
  arm.command(twist(0.0, 1.0, 0.0, 10'000'000), 0.0);  // asks for more than the limit
  run(arm, 0.0, 0.1);
  EXPECT_NEAR(arm.linear_velocity().y(), setup.max_linear_accel * 0.1, 0.02);
  run(arm, 0.1, 2.0);
  EXPECT_NEAR(arm.linear_velocity().norm(), setup.max_linear_speed, 1e-9);
  EXPECT_GT(arm.tool().position.y(), 0.6);
}

TEST(CartesianArm, StopsWhenTheCommandGoesStale) {
  ArmSetup setup;
  CartesianArm arm(setup, {Mat3::Identity(), Vec3::Zero()}, {});
  arm.command(twist(0.1, 0.0, 0.0), 0.0);
  run(arm, 0.0, 0.09);
  EXPECT_GT(arm.linear_velocity().x(), 0.05);
  EXPECT_FALSE(arm.command_stale(0.09));
  run(arm, 0.09, 0.5);
  EXPECT_TRUE(arm.command_stale(0.5));
  EXPECT_EQ(arm.linear_velocity().norm(), 0.0);
}

TEST(CartesianArm, ReachesAPoseGoalAndRefusesJointGoals) {
  ArmSetup setup;
  CartesianArm arm(setup, {Mat3::Identity(), Vec3::Zero()}, {});
  robot_command_t goal{};
  goal.type = robot_command_t::TYPE_POSE_GOAL;
  const Mat3 r = look_at_rotation(Vec3::Zero(), Vec3(1, 1, 0));
  const Eigen::Quaterniond q(r);
  goal.pose_goal.position[0] = 0.2;
  goal.pose_goal.position[2] = -0.1;
  goal.pose_goal.orientation[0] = q.w();
  goal.pose_goal.orientation[1] = q.x();
  goal.pose_goal.orientation[2] = q.y();
  goal.pose_goal.orientation[3] = q.z();
  ASSERT_TRUE(arm.command(goal, 0.0));
  run(arm, 0.0, 5.0);
  EXPECT_NEAR((arm.tool().position - Vec3(0.2, 0, -0.1)).norm(), 0.0, 1e-3);
  EXPECT_TRUE(arm.tool().rotation.isApprox(r, 1e-3));
  robot_command_t joints{};
  joints.type = robot_command_t::TYPE_JOINT_GOAL;
  EXPECT_FALSE(arm.command(joints, 5.0));
  EXPECT_EQ(arm.refused(), 1);
  robot_state_t s;
  arm.fill_state(s, 5.0);
  EXPECT_NEAR(s.tool_pose.position[0], 0.2, 1e-3);
  EXPECT_EQ(s.num_limit_events, 1);
}

// The camera the simulator renders with is the truth (tool * scenario
// hand-eye); the camera pose it reports on ROBOT_STATE in the robot link's
// place is the software's belief (tool * reported hand-eye). Hand-worked with
// the tool at (1, 2, 3) turned 90 deg about z: truth 10 mm along tool x ->
// (1, 2.01, 3); belief 20 mm along tool y, turned 90 deg about tool z ->
// (0.98, 2, 3), turned 180 deg.
TEST(CartesianArm, RendersTheTrueCameraAndReportsTheSoftwaresHandEye) {
  ArmSetup setup;
  setup.hand_eye = {Mat3::Identity(), Vec3(0.01, 0.0, 0.0)};
  const Mat3 rz90 = Eigen::AngleAxisd(3.14159265358979323846 / 2, Vec3::UnitZ()).toRotationMatrix();
  CartesianArm arm(setup, {rz90, Vec3(1, 2, 3)}, {rz90, Vec3(0.0, 0.02, 0.0)});
  EXPECT_NEAR((arm.hand_camera().position - Vec3(1, 2.01, 3)).norm(), 0.0, 1e-12);
  EXPECT_TRUE(arm.hand_camera().rotation.isApprox(rz90, 1e-12));
  robot_state_t s;
  arm.fill_state(s, 0.0);
  EXPECT_NEAR(
      (Vec3(s.camera_pose.position[0], s.camera_pose.position[1], s.camera_pose.position[2]) - Vec3(0.98, 2, 3)).norm(),
      0.0, 1e-12);
  // Turned 180 deg about z: quaternion (0, 0, 0, +-1).
  EXPECT_NEAR(std::abs(s.camera_pose.orientation[3]), 1.0, 1e-12);
}

}  // namespace
}  // namespace harvest::sim
