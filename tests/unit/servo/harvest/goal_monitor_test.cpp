#include "servo/harvest/goal_monitor.hpp"

#include <gtest/gtest.h>

namespace harvest::servo {
namespace {

Eigen::Isometry3d at(double x, double angle_z = 0.0) {
  Eigen::Isometry3d t = Eigen::Isometry3d::Identity();
  t.translation() = Eigen::Vector3d(x, 0, 0);
  t.linear() = Eigen::AngleAxisd(angle_z, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  return t;
}
rt::Micros s(double seconds) { return rt::from_seconds(seconds); }

TEST(GoalMonitor, ReachedWithinBothTolerances) {
  GoalMonitor g({0.005, 0.02}, {});
  g.start(at(0.0), 0);
  EXPECT_TRUE(g.reached(at(0.0049)));
  EXPECT_FALSE(g.reached(at(0.0051)));
  EXPECT_TRUE(g.reached(at(0.0, 0.019)));
  EXPECT_FALSE(g.reached(at(0.0, 0.021)));
  EXPECT_TRUE(pose_reached(at(0.001), at(0.0), {0.005, 0.02}));
}

TEST(GoalMonitor, EveryGoalHasANewId) {
  GoalMonitor g({}, {});
  EXPECT_EQ(g.id(), 0);
  g.start(at(0.1), 0);
  EXPECT_EQ(g.id(), 1);
  g.start(at(0.2), 0);
  EXPECT_EQ(g.id(), 2);
  EXPECT_DOUBLE_EQ(g.goal().translation().x(), 0.2);
}

// Hand-worked: steps of 2 mm (or 0.01 rad) count as progress; 2 s without one is a stall.
TEST(GoalMonitor, StallsAfterTheStallTimeWithoutAStepTowardTheGoal) {
  GoalMonitor g({}, {0.002, 0.01, 2.0});
  g.start(at(0.0), s(10));
  EXPECT_FALSE(g.stalled(at(0.100), s(10)));     // first sample: the best so far
  EXPECT_FALSE(g.stalled(at(0.0985), s(11.5)));  // 1.5 mm nearer: not a step
  EXPECT_FALSE(g.stalled(at(0.0985), s(12.0)));  // exactly the stall time: not yet
  EXPECT_TRUE(g.stalled(at(0.0985), s(12.01)));
  // A 2.5 mm step toward the goal is progress again.
  EXPECT_FALSE(g.stalled(at(0.0975), s(12.02)));
  EXPECT_FALSE(g.stalled(at(0.0975), s(14.0)));
  EXPECT_TRUE(g.stalled(at(0.0975), s(14.03)));
}

// The arm's joints turning with the tool put (a joint-space way home swinging the elbow about it) is progress;
// once they rest, the stall time runs from the last such sample.
TEST(GoalMonitor, JointsMovingWithTheToolPutIsProgress) {
  GoalMonitor g({}, {0.002, 0.01, 2.0});
  g.start(at(0.0), s(10));
  EXPECT_FALSE(g.stalled(at(0.100), s(10)));
  EXPECT_FALSE(g.stalled(at(0.100), s(11.5), true));
  EXPECT_FALSE(g.stalled(at(0.100), s(13.0), true));  // 3 s without the tool nearer: the joints moving
  EXPECT_FALSE(g.stalled(at(0.100), s(15.0)));        // at rest since 13.0: not yet
  EXPECT_TRUE(g.stalled(at(0.100), s(15.01)));
}

TEST(GoalMonitor, TurningTowardTheGoalIsProgressToo) {
  GoalMonitor g({}, {0.002, 0.01, 2.0});
  g.start(at(0.0), 0);
  EXPECT_FALSE(g.stalled(at(0.05, 0.5), s(0)));
  EXPECT_FALSE(g.stalled(at(0.05, 0.485), s(1.9)));  // 0.015 rad nearer
  EXPECT_FALSE(g.stalled(at(0.05, 0.485), s(3.8)));
  EXPECT_TRUE(g.stalled(at(0.05, 0.485), s(4.0)));
}

TEST(GoalMonitor, APauseDoesNotCountTowardTheStall) {
  GoalMonitor g({}, {0.002, 0.01, 2.0});
  g.start(at(0.0), 0);
  EXPECT_FALSE(g.stalled(at(0.1), s(0)));
  g.shift(s(5.0));  // paused from 1 s to 6 s
  EXPECT_FALSE(g.stalled(at(0.1), s(6.5)));
  EXPECT_TRUE(g.stalled(at(0.1), s(7.1)));
}

}  // namespace
}  // namespace harvest::servo
