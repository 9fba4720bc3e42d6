// command_check: each way a ROBOT_COMMAND is refused, with its reason, and
// what passes (the shipped config/arm/robot_link.yaml limits).
#include "arm/command_check.hpp"

#include <gtest/gtest.h>

#include <cmath>

#include "config/config.hpp"
#include "kinematics/diff_ik.hpp"

namespace harvest::arm {
namespace {

using harvest::robot_command_t;

const RobotLinkConfig& shipped() {
  static const RobotLinkConfig c = [] {
    auto doc = config::Document::load_file("config/arm/robot_link.yaml");
    return RobotLinkConfig::from_config(doc.root());
  }();
  return c;
}

robot_command_t twist(double vx, double wz) {
  robot_command_t c{};
  c.type = robot_command_t::TYPE_TWIST;
  c.twist.linear[0] = vx;
  c.twist.angular[2] = wz;
  return c;
}

// A pose goal at the home pose (inside the workspace, unit quaternion).
robot_command_t home_goal() {
  const Eigen::Isometry3d home = kinematics::tool_pose(shipped().model, shipped().model.home);
  const Eigen::Quaterniond q(home.linear());
  robot_command_t c{};
  c.type = robot_command_t::TYPE_POSE_GOAL;
  for (int i = 0; i < 3; ++i) c.pose_goal.position[i] = home.translation()[i];
  c.pose_goal.orientation[0] = q.w();
  c.pose_goal.orientation[1] = q.x();
  c.pose_goal.orientation[2] = q.y();
  c.pose_goal.orientation[3] = q.z();
  return c;
}

robot_command_t joint_goal(const Eigen::VectorXd& q) {
  robot_command_t c{};
  c.type = robot_command_t::TYPE_JOINT_GOAL;
  c.num_joints = static_cast<int32_t>(q.size());
  c.joint_goal.assign(q.data(), q.data() + q.size());
  return c;
}

TEST(CommandCheck, StopAndPlainCommandsPass) {
  const auto& c = shipped();
  robot_command_t stop{};
  stop.type = robot_command_t::TYPE_STOP;
  EXPECT_EQ(command_problem(c, stop), "");
  EXPECT_EQ(command_problem(c, twist(0.1, 0.2)), "");
  // Faster than the limits but within non_physical_factor x: clipped later, not refused.
  EXPECT_EQ(command_problem(c, twist(2.0 * c.limits.linear_speed, 0.0)), "");
  EXPECT_EQ(command_problem(c, home_goal()), "");
  EXPECT_EQ(command_problem(c, joint_goal(c.model.home)), "");
}

TEST(CommandCheck, TwistsNotFiniteOrNotPhysicalAreRefused) {
  const auto& c = shipped();
  EXPECT_EQ(command_problem(c, twist(NAN, 0.0)), "twist is not finite");
  EXPECT_EQ(command_problem(c, twist(0.0, INFINITY)), "twist is not finite");
  const std::string fast = command_problem(c, twist(1e9, 0.0));
  EXPECT_NE(fast.find("is not physical"), std::string::npos) << fast;
  EXPECT_NE(command_problem(c, twist(0.0, 1.01 * c.command_limits.non_physical_factor * c.limits.angular_speed)), "");
}

TEST(CommandCheck, PoseGoalsMalformedOutsideOrTooSlowAreRefused) {
  const auto& c = shipped();
  auto g = home_goal();
  g.pose_goal.orientation[0] *= 1.1;
  EXPECT_EQ(command_problem(c, g), "pose goal is not a position and a unit quaternion");
  g = home_goal();
  g.pose_goal.position[1] = NAN;
  EXPECT_EQ(command_problem(c, g), "pose goal is not a position and a unit quaternion");
  g = home_goal();
  g.pose_goal.position[2] = c.workspace.max.z() + 0.01;
  EXPECT_EQ(command_problem(c, g), "pose goal outside the workspace");
  g = home_goal();
  g.max_linear_speed = -0.1;
  EXPECT_NE(command_problem(c, g).find("must be 0"), std::string::npos);
  g = home_goal();
  g.max_linear_speed = 0.5 * c.command_limits.min_goal_linear_speed;
  EXPECT_NE(command_problem(c, g).find("below the minimum"), std::string::npos);
  g.max_linear_speed = c.command_limits.min_goal_linear_speed;  // the minimum itself is allowed
  EXPECT_EQ(command_problem(c, g), "");
  g.max_angular_speed = 0.5 * c.command_limits.min_goal_angular_speed;
  EXPECT_NE(command_problem(c, g).find("max_angular_speed"), std::string::npos);
}

TEST(CommandCheck, JointGoalsOfTheWrongSizeOrOutsideTheLimitsAreRefused) {
  const auto& c = shipped();
  auto g = joint_goal(c.model.home);
  g.num_joints = 5;
  g.joint_goal.resize(5);
  EXPECT_EQ(command_problem(c, g), "joint goal has 5 joints");
  Eigen::VectorXd q = c.model.home;
  q[0] = NAN;
  EXPECT_EQ(command_problem(c, joint_goal(q)), "joint goal outside joint limits");
  q = c.model.home;
  q[1] = c.model.joints[1].max + 0.1;
  EXPECT_EQ(command_problem(c, joint_goal(q)), "joint goal outside joint limits");
  robot_command_t odd{};
  odd.type = 9;
  EXPECT_EQ(command_problem(c, odd), "unknown command type 9");
}

TEST(CommandCheck, TheMotionIsReadBack) {
  const auto& c = shipped();
  EXPECT_DOUBLE_EQ(twist_of(twist(0.1, 0.2))[0], 0.1);
  EXPECT_DOUBLE_EQ(twist_of(twist(0.1, 0.2))[5], 0.2);
  auto g = home_goal();
  g.pose_goal.orientation[0] *= 1.0005;  // within the tolerance: normalised
  const Eigen::Isometry3d home = kinematics::tool_pose(c.model, c.model.home);
  EXPECT_TRUE(pose_goal_of(g).isApprox(home, 1e-3));
  EXPECT_TRUE(pose_goal_of(g).linear().isUnitary(1e-12));
  EXPECT_EQ(joint_goal_of(joint_goal(c.model.home)), c.model.home);
}

}  // namespace
}  // namespace harvest::arm
