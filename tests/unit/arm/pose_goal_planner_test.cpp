// PoseGoalPlanner: in bounded slices it takes the same decision as the
// all-at-once plan_pose_goal, for each way a pose goal can go (Cartesian,
// joint space to the home posture, joint space by IK, unreachable), and no
// slice does more than its budget.
#include "arm/pose_goal_planner.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <numbers>
#include <vector>

#include "arm_goals.hpp"
#include "config/config.hpp"

namespace harvest::arm {
namespace {

RobotLinkConfig shipped() {
  auto doc = config::Document::load_file("config/arm/robot_link.yaml");
  return RobotLinkConfig::from_config(doc.root());
}

CartesianTrajectory::Limits limits(const RobotLinkConfig& c) { return goal_limits(c); }

struct Sliced {
  PoseGoalPlan plan;
  int slices = 0;
};

// The planner as the link runs it: one slice per control period, joints fixed (the arm holds).
Sliced run_sliced(const RobotLinkConfig& c, const CartesianTrajectory& path, const Eigen::VectorXd& q) {
  PoseGoalPlanner planner(c, path, q, Eigen::VectorXd::Zero(c.model.dof()));
  Sliced out;
  int64_t steps_before = 0;
  while (!planner.done()) {
    ++out.slices;
    planner.run(q);
    const int64_t steps = planner.dry_run().result().steps;
    EXPECT_LE(steps - steps_before, c.dry_run.steps_per_period);
    steps_before = steps;
    if (out.slices > 10'000) {
      ADD_FAILURE() << "the planner never decides";
      break;
    }
  }
  out.plan = planner.plan();
  return out;
}

void expect_same(const PoseGoalPlan& sliced, const PoseGoalPlan& whole) {
  EXPECT_EQ(sliced.way, whole.way);
  EXPECT_EQ(sliced.why, whole.why);
  EXPECT_EQ(sliced.dry_run.steps, whole.dry_run.steps);
  EXPECT_EQ(sliced.dry_run.position_error, whole.dry_run.position_error);
  EXPECT_EQ(sliced.ik_iterations, whole.ik_iterations);
  ASSERT_EQ(sliced.joints.has_value(), whole.joints.has_value());
  if (whole.joints) {
    EXPECT_EQ(sliced.joints->goal(), whole.joints->goal());
    EXPECT_EQ(sliced.joints->duration(), whole.joints->duration());
  }
  ASSERT_EQ(sliced.cartesian.has_value(), whole.cartesian.has_value());
  if (whole.cartesian) {
    EXPECT_EQ(sliced.cartesian->duration(), whole.cartesian->duration());
  }
}

TEST(PoseGoalPlanner, AShortMoveIsCartesianInSlicesAndAtOnce) {
  const RobotLinkConfig c = shipped();
  const Eigen::Isometry3d home = kinematics::tool_pose(c.model, c.model.home);
  Eigen::Isometry3d goal = home;
  goal.translation() += Eigen::Vector3d(-0.05, 0.02, 0.03);
  const CartesianTrajectory path(home, goal, limits(c));
  const PoseGoalPlan whole = plan_pose_goal(c, path, c.model.home, Eigen::VectorXd::Zero(c.model.dof()));
  ASSERT_EQ(whole.way, PoseGoalPlan::Way::kCartesian) << whole.why;
  EXPECT_TRUE(whole.dry_run.reached);
  EXPECT_LE(whole.dry_run.position_error, c.dry_run.position_tolerance);
  EXPECT_EQ(whole.why.rfind("Cartesian (", 0), 0u) << whole.why;
  const Sliced sliced = run_sliced(c, path, c.model.home);
  expect_same(sliced.plan, whole);
  // Step k is taken in slice k / budget + 1; the decision comes with the slice after the last step.
  EXPECT_EQ(sliced.slices, whole.dry_run.steps / c.dry_run.steps_per_period + 1);
}

TEST(PoseGoalPlanner, SlowGoalsTakeManySlicesWithTheSameResult) {
  RobotLinkConfig c = shipped();
  const Eigen::Isometry3d home = kinematics::tool_pose(c.model, c.model.home);
  Eigen::Isometry3d goal = home;
  goal.translation() += Eigen::Vector3d(-0.1, 0.0, 0.05);
  CartesianTrajectory::Limits slow = limits(c);
  slow.linear_speed = c.command_limits.min_goal_linear_speed;
  const CartesianTrajectory path(home, goal, slow);
  const PoseGoalPlan whole = plan_pose_goal(c, path, c.model.home, Eigen::VectorXd::Zero(c.model.dof()));
  const Sliced sliced = run_sliced(c, path, c.model.home);
  expect_same(sliced.plan, whole);
  EXPECT_GT(whole.dry_run.steps, 1000);
  EXPECT_GE(sliced.slices, whole.dry_run.steps / c.dry_run.steps_per_period);
}

// The other ways: re-orientations toward points beside and below the tool
// (the servo controller's ORIENT goals; several the straight path cannot
// complete), and poses far toward the tree with the gripper turned back
// toward the base (as the flood test's unreachable goal).
std::vector<Eigen::Isometry3d> hard_goals(const RobotLinkConfig& c) {
  const Eigen::Isometry3d home = kinematics::tool_pose(c.model, c.model.home);
  std::vector<Eigen::Isometry3d> goals;
  for (double z : {-0.3, -0.5})
    for (double y : {1.3, 0.8}) goals.push_back(aim_goal(home, Eigen::Vector3d(-0.8, y, z)));
  for (double turn : {2.5, 3.0}) {
    Eigen::Isometry3d goal = home;
    goal.translation().x() = -0.3;
    goal.linear() = home.linear() * Eigen::AngleAxisd(turn, Eigen::Vector3d::UnitY()).toRotationMatrix();
    goals.push_back(goal);
  }
  return goals;
}

TEST(PoseGoalPlanner, EveryOtherWayMatchesTheAllAtOnceDecision) {
  const RobotLinkConfig c = shipped();
  const Eigen::Isometry3d home = kinematics::tool_pose(c.model, c.model.home);
  int ways[4] = {0, 0, 0, 0};
  for (const Eigen::Isometry3d& goal : hard_goals(c)) {
    if (!c.workspace.contains(goal.translation())) continue;
    const CartesianTrajectory path(home, goal, limits(c));
    const PoseGoalPlan whole = plan_pose_goal(c, path, c.model.home, Eigen::VectorXd::Zero(c.model.dof()));
    ++ways[static_cast<int>(whole.way)];
    SCOPED_TRACE(whole.why);
    const Sliced sliced = run_sliced(c, path, c.model.home);
    expect_same(sliced.plan, whole);
    if (whole.ik_iterations > c.ik_iterations_per_period) {
      EXPECT_GT(sliced.slices, 1);
    }
    if (whole.way == PoseGoalPlan::Way::kUnreachable) {
      EXPECT_FALSE(whole.joints || whole.cartesian);
    }
  }
  std::printf("Cartesian %d, joint space %d, unreachable %d\n", ways[1], ways[2], ways[3]);
  EXPECT_EQ(ways[0], 0) << "kPending is never a decision";
  EXPECT_GT(ways[2], 0) << "no goal went to joint space";
  EXPECT_GT(ways[3], 0) << "no goal was unreachable";
}

// Back home from where those joint-space goals put the arm: to the home
// posture in joint space when the straight path falls short, no IK search.
TEST(PoseGoalPlanner, GoingHomeUsesTheHomePostureWithoutAnIkSearch) {
  const RobotLinkConfig c = shipped();
  const Eigen::Isometry3d home = kinematics::tool_pose(c.model, c.model.home);
  const Eigen::VectorXd rest = Eigen::VectorXd::Zero(c.model.dof());
  int joint_space = 0;
  for (const Eigen::Isometry3d& goal : hard_goals(c)) {
    const PoseGoalPlan out = plan_pose_goal(c, CartesianTrajectory(home, goal, limits(c)), c.model.home, rest);
    if (out.way != PoseGoalPlan::Way::kJointSpace) continue;
    const Eigen::VectorXd q = out.joints->goal();
    const PoseGoalPlan back =
        plan_pose_goal(c, CartesianTrajectory(kinematics::tool_pose(c.model, q), home, limits(c)), q, rest);
    std::printf("back home: %s\n", back.why.c_str());
    if (back.way == PoseGoalPlan::Way::kCartesian) continue;
    ++joint_space;
    ASSERT_EQ(back.way, PoseGoalPlan::Way::kJointSpace) << back.why;
    EXPECT_EQ(back.ik_iterations, 0) << "no IK search for the home pose";
    EXPECT_TRUE(back.joints->goal().isApprox(c.model.home));
    EXPECT_NE(back.why.find("to the home posture"), std::string::npos) << back.why;
  }
  EXPECT_GT(joint_space, 0) << "no posture whose straight path home falls short";
}

// The way home resets the arm's redundancy: with the tool at the home pose but the joints in another branch (the
// IK seeded where a full-tree run drifted, shoulder roll 150 deg), a goal at the home pose goes to the home posture
// in joint space; with home_posture_tolerance 0 it goes the straight (here: no) way and stays in that branch.
TEST(PoseGoalPlanner, TheWayHomeGoesBackToTheHomePostureFromAnotherBranch) {
  RobotLinkConfig c = shipped();
  constexpr double kDeg = std::numbers::pi / 180.0;
  const Eigen::Isometry3d home = kinematics::tool_pose(c.model, c.model.home);
  Eigen::VectorXd seed(7);
  seed << 150.1, -66.3, -83.3, 83.9, -101.0, 31.9, -35.1;
  const auto other = kinematics::solve_pose(c.model, home, seed * kDeg);
  ASSERT_TRUE(other.has_value());
  ASSERT_GT((*other - c.model.home).cwiseAbs().maxCoeff(), c.dry_run.home_posture_tolerance);
  const CartesianTrajectory path(kinematics::tool_pose(c.model, *other), home, limits(c));
  const PoseGoalPlan plan = plan_pose_goal(c, path, *other, Eigen::VectorXd::Zero(7));
  std::printf("%s\n", plan.why.c_str());
  ASSERT_EQ(plan.way, PoseGoalPlan::Way::kJointSpace) << plan.why;
  EXPECT_EQ(plan.joints->goal(), c.model.home);
  expect_same(run_sliced(c, path, *other).plan, plan);

  c.dry_run.home_posture_tolerance = 0.0;
  EXPECT_EQ(plan_pose_goal(c, path, *other, Eigen::VectorXd::Zero(7)).way, PoseGoalPlan::Way::kCartesian);
}

}  // namespace
}  // namespace harvest::arm
