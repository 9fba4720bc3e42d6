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
  CartesianArm arm(setup, {Mat3::Identity(), Vec3::Zero()});
  arm.command(twist(0.0, 1.0, 0.0, 10'000'000), 0.0);  // asks for more than the limit
  run(arm, 0.0, 0.1);
  EXPECT_NEAR(arm.linear_velocity().y(), setup.max_linear_accel * 0.1, 0.02);
  run(arm, 0.1, 2.0);
  EXPECT_NEAR(arm.linear_velocity().norm(), setup.max_linear_speed, 1e-9);
  EXPECT_GT(arm.tool().position.y(), 0.6);
}

TEST(CartesianArm, StopsWhenTheCommandGoesStale) {
  ArmSetup setup;
  CartesianArm arm(setup, {Mat3::Identity(), Vec3::Zero()});
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
  CartesianArm arm(setup, {Mat3::Identity(), Vec3::Zero()});
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

}  // namespace
}  // namespace harvest::sim
