#include "servo/harvest/turning.hpp"

#include <gtest/gtest.h>

#include <cmath>

#include "config/config.hpp"
#include "servo/harvest/aiming.hpp"

namespace harvest::servo {
namespace {

// Default configuration: home at (-0.655, 0.785, -0.251), the gripper axis along base +y, base +x beside it;
// max_aim_angle 1.15 rad, view_angle 0.5 rad, view_distance 0.5 m, retreat_distance 0.15 m. The camera-in-hand
// is taken at the tool pose (833 px focal length: a fruit 0.6 m ahead and 0.05 rad off the axis is 42 px from
// the image centre, well inside; 0.5 rad off it is 455 px, outside).
ServoConfig config() { return ServoConfig::from_yaml(config::Document::load_string("{}").root()); }

Fruit off_axis(const ServoConfig& c, double angle) {
  Fruit f;
  f.id = 4;
  f.estimate = c.home_pose.translation() +
               0.6 * (std::cos(angle) * c.home_pose.linear().col(2) + std::sin(angle) * Eigen::Vector3d::UnitX());
  return f;
}

TEST(Turning, FromHomeInPlaceOrFromTheViewpointAndWithTheThesisLaw) {
  ServoConfig c = config();
  Turning pose_goal(c);
  Fruit near = off_axis(c, 0.5), wide = off_axis(c, 1.2);
  Turning::Start s = pose_goal.from_here(c.home_pose, near);
  EXPECT_FALSE(s.law);
  EXPECT_FALSE(near.from_viewpoint);
  EXPECT_LT((s.goal.translation() - c.home_pose.translation()).norm(), 1e-12);
  EXPECT_NEAR(s.goal.rotation().col(2).dot((near.estimate - c.home_pose.translation()).normalized()), 1.0, 1e-9);
  s = pose_goal.from_here(c.home_pose, wide);
  EXPECT_FALSE(s.law);
  EXPECT_TRUE(wide.from_viewpoint);
  EXPECT_LT((s.goal.translation() - aim_from_viewpoint(c, wide.estimate)->translation()).norm(), 1e-12);
  // orient_law thesis_pd: the law turns in place toward where it converges (the roll of home's x axis); a
  // viewpoint stays a pose goal.
  c.orient_law = "thesis_pd";
  Turning law(c);
  near = off_axis(c, 0.5);
  s = law.from_here(c.home_pose, near);
  EXPECT_TRUE(s.law);
  EXPECT_LT((s.goal.translation() - c.home_pose.translation()).norm(), 1e-12);
  EXPECT_LT((s.goal.linear() - aimed_with_roll(c.home_pose, near.estimate, c.home_pose.linear().col(0))).norm(), 1e-12);
  wide = off_axis(c, 1.2);
  EXPECT_FALSE(law.from_here(c.home_pose, wide).law);
  // One step of the law at home turns toward the fruit (+x of the axis: about base -z) and holds the position.
  const Twist t = law.law_step(c.home_pose, near.estimate);
  EXPECT_EQ(t.linear, Eigen::Vector3d::Zero());
  EXPECT_LT(t.angular.z(), 0.0);
}

// From a retreat's end the aim is the one from home; a viewpoint only from within retreat_distance of home.
TEST(Turning, FromTheRetreatStraightToTheAimFromHomeButAViewpointOnlyFromNearHome) {
  const ServoConfig c = config();
  Turning turning(c);
  Eigen::Isometry3d away = c.home_pose;
  away.translation() += Eigen::Vector3d(0.2, 0.1, 0.0);  // 0.22 m from home
  Fruit near = off_axis(c, 0.5);
  const auto goal = turning.from_retreat(away, near);
  ASSERT_TRUE(goal.has_value());
  EXPECT_LT((goal->translation() - c.home_pose.translation()).norm(), 1e-12);
  Fruit wide = off_axis(c, 1.2);
  EXPECT_FALSE(turning.from_retreat(away, wide).has_value());
  EXPECT_TRUE(wide.from_viewpoint);
  Eigen::Isometry3d close = c.home_pose;
  close.translation() += Eigen::Vector3d(0.1, 0.0, 0.0);
  wide = off_axis(c, 1.2);
  const auto view = turning.from_retreat(close, wide);
  ASSERT_TRUE(view.has_value());
  EXPECT_LT((view->translation() - aim_from_viewpoint(c, wide.estimate)->translation()).norm(), 1e-12);
}

// A turn stopped short: acquired from there if the fruit is well inside the hand image; begun at a retreat's end,
// the turn from home next; else from a viewpoint once; then given up.
TEST(Turning, ABlockedTurnAcquiresFromThereTriesFromHomeThenAViewpointThenGivesUp) {
  const ServoConfig c = config();
  Turning turning(c);
  Fruit in_view = off_axis(c, 0.05);
  Turning::Blocked b = turning.blocked("stalled", c.home_pose, in_view);
  EXPECT_EQ(b.action, Turning::Blocked::Action::kAcquire);
  EXPECT_EQ(b.text, "fruit 4: the turn stalled short of its goal, the fruit in view");

  Fruit f = off_axis(c, 0.5);
  Eigen::Isometry3d away = c.home_pose;
  away.translation() += Eigen::Vector3d(0.2, 0.1, 0.0);
  ASSERT_TRUE(turning.from_retreat(away, f).has_value());
  b = turning.blocked("refused by the robot link", c.home_pose, f);
  EXPECT_EQ(b.action, Turning::Blocked::Action::kFromHome);
  EXPECT_EQ(b.text, "fruit 4: the turn from the retreat refused by the robot link, turning from home");

  turning.from_here(c.home_pose, f);  // at home now
  b = turning.blocked("stalled", c.home_pose, f);
  EXPECT_EQ(b.action, Turning::Blocked::Action::kViaViewpoint);
  EXPECT_TRUE(f.from_viewpoint);
  EXPECT_EQ(b.text, "fruit 4: the arm could not turn to it (stalled), aiming from a viewpoint");

  b = turning.blocked("did not complete", c.home_pose, f);
  EXPECT_EQ(b.action, Turning::Blocked::Action::kUnreachable);
  EXPECT_EQ(b.text, "the arm could not reach a viewpoint of it (did not complete)");
  // Without a viewpoint (view_angle 0): given up at once.
  ServoConfig none = c;
  none.view_angle = 0.0;
  Fruit g = off_axis(none, 0.5);
  EXPECT_EQ(Turning(none).blocked("stalled", none.home_pose, g).text, "the arm could not turn to it (stalled)");
}

}  // namespace
}  // namespace harvest::servo
