#include "servo/harvest/commands.hpp"

#include <gtest/gtest.h>

namespace harvest::servo {
namespace {

ServoConfig config() {
  ServoConfig c;
  c.validity_s = 0.1;
  c.max_linear_speed = 0.381;
  c.max_angular_speed = 1.5;
  c.max_linear_accel = 1.0;
  c.tick_period_s = 0.02;
  return c;
}

TEST(CommandBuilder, EveryRobotCommandCarriesItsStampValidityAndLimits) {
  CommandBuilder b(config());
  const CommandStamp stamp{1234, 56, 7};
  for (const robot_command_t& c : {b.stop(stamp), b.pose_goal(stamp, Eigen::Isometry3d::Identity())}) {
    EXPECT_EQ(c.header.utime, 1234);
    EXPECT_EQ(c.header.source_seq, 56);
    EXPECT_EQ(c.header.frame_id, "base");
    EXPECT_EQ(c.goal_id, 7);
    EXPECT_EQ(c.validity_us, 100'000);
    EXPECT_DOUBLE_EQ(c.max_linear_speed, 0.381);
    EXPECT_DOUBLE_EQ(c.max_angular_speed, 1.5);
  }
  EXPECT_EQ(b.stop(stamp).type, +robot_command_t::TYPE_STOP);
  Eigen::Isometry3d goal = Eigen::Isometry3d::Identity();
  goal.translation() = Eigen::Vector3d(0.1, 0.2, 0.3);
  const robot_command_t g = b.pose_goal(stamp, goal);
  EXPECT_EQ(g.type, +robot_command_t::TYPE_POSE_GOAL);
  EXPECT_DOUBLE_EQ(g.pose_goal.position[1], 0.2);
  EXPECT_DOUBLE_EQ(g.pose_goal.orientation[0], 1.0);
}

// Hand-worked: 1 m/s^2 at 50 Hz lets the speed grow by 0.02 m/s per command.
TEST(CommandBuilder, TwistsRampWithinTheAccelerationLimitAndFromRestAfterAReset) {
  CommandBuilder b(config());
  Twist fast;
  fast.linear = Eigen::Vector3d(0.0, 1.0, 0.0);
  const Eigen::Vector3d inside(-0.655, 0.785, -0.251);
  const robot_command_t first = b.twist({}, fast, inside);
  EXPECT_EQ(first.type, +robot_command_t::TYPE_TWIST);
  EXPECT_NEAR(first.twist.linear[1], 0.02, 1e-12);
  EXPECT_NEAR(b.twist({}, fast, inside).twist.linear[1], 0.04, 1e-12);
  b.ramp_from_rest();
  EXPECT_NEAR(b.twist({}, fast, inside).twist.linear[1], 0.02, 1e-12);
}

TEST(CommandBuilder, GripperOpenAndClose) {
  const gripper_command_t open = CommandBuilder::gripper(99, gripper_command_t::ACTION_OPEN);
  EXPECT_EQ(open.action, +gripper_command_t::ACTION_OPEN);
  EXPECT_FLOAT_EQ(open.position, 1.0f);
  EXPECT_EQ(open.header.utime, 99);
  EXPECT_EQ(open.header.frame_id, "gripper");
  EXPECT_FLOAT_EQ(CommandBuilder::gripper(99, gripper_command_t::ACTION_CLOSE).position, 0.0f);
}

}  // namespace
}  // namespace harvest::servo
