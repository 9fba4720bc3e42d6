#include "servo/harvest/aiming.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>

#include "config/config.hpp"

namespace harvest::servo {
namespace {

// Default configuration: workspace box x -0.9..0.7, y 0.3..1.3, z -1..0.3,
// reach 0.3..1.5 m; home at (-0.655, 0.785, -0.251) with the gripper axis
// along base +y; min_ahead_of_home 0.05 m: pickable means y >= 0.835.
ServoConfig config() { return ServoConfig::from_yaml(config::Document::load_string("{}").root()); }

targets_t view_from(const Eigen::Vector3d& camera, const Eigen::Vector3d& target, bool known = true) {
  targets_t v{};
  v.camera_known = known;
  for (int i = 0; i < 3; ++i) v.camera_position_base[i] = camera[i];
  target_t t{};
  for (int i = 0; i < 3; ++i) t.position_base[i] = target[i];
  v.targets.push_back(t);
  v.num_targets = 1;
  return v;
}

TEST(Aiming, PickableIsInsideTheWorkspaceAndAheadOfTheGripperAtHome) {
  const ServoConfig c = config();
  EXPECT_TRUE(pickable(c, {-0.5, 0.9, -0.25}));
  EXPECT_FALSE(pickable(c, {-0.5, 0.82, -0.25}));  // 35 mm ahead of home: less than 50
  EXPECT_FALSE(pickable(c, {-0.5, 1.45, -0.25}));  // beyond the box
}

// Hand-worked: a line of sight from the base origin along +y is pickable
// from y = 0.835 (ahead of home) to y = 1.3 (the box), scanned in 5 mm steps.
TEST(Aiming, SightLineIsThePickablePartOfTheLine) {
  const ServoConfig c = config();
  const targets_t v = view_from({0.0, 0.0, 0.0}, {0.0, 2.0, 0.0});
  const auto line = sight_line(c, v, v.targets[0]);
  ASSERT_TRUE(line.has_value());
  EXPECT_NEAR(line->direction.y(), 1.0, 1e-12);
  EXPECT_NEAR(line->near, 0.835, 0.0051);
  EXPECT_NEAR(line->far, 1.3, 0.0051);
  EXPECT_TRUE(pickable(c, line->at(line->near)));
  EXPECT_TRUE(pickable(c, line->at(line->far)));
  // No camera pose, or a line that never enters the pickable set: none.
  EXPECT_FALSE(sight_line(c, view_from({0, 0, 0}, {0, 2, 0}, false), v.targets[0]).has_value());
  const targets_t away = view_from({0.0, 0.0, 0.0}, {0.0, -1.0, 0.0});
  EXPECT_FALSE(sight_line(c, away, away.targets[0]).has_value());
}

TEST(Aiming, SightAimLooksAlongAStretchTheHandCameraSeesAtOnce) {
  ServoConfig c = config();
  const targets_t v = view_from({0.5, 0.0, -0.25}, {-0.5, 1.3, -0.25});
  const auto line = sight_line(c, v, v.targets[0]);
  ASSERT_TRUE(line.has_value());
  const Eigen::Vector3d from = c.home_pose.translation();
  const Eigen::Vector3d aim = sight_aim(c, *line, line->near, from);
  // On the line, within its pickable part ...
  const double s = (aim - line->origin).dot(line->direction);
  EXPECT_LT((line->at(s) - aim).norm(), 1e-9);
  EXPECT_GE(s, line->near - 1e-9);
  EXPECT_LE(s, line->far + 1e-9);
  // ... and the start of the stretch is within the camera's half field of view less the margin of the aim.
  const geometry::CameraModel& k = c.hand_camera;
  const double half = std::min(std::atan2(k.cx, k.fx), std::atan2(k.cy, k.fy)) - c.sight_aim_margin;
  const Eigen::Vector3d to_aim = (aim - from).normalized(), to_start = (line->at(line->near) - from).normalized();
  EXPECT_LE(std::acos(to_aim.dot(to_start)), half + 1e-3);
  // A wider margin narrows the stretch: the aim moves toward its start.
  c.sight_aim_margin = 0.2;
  const Eigen::Vector3d narrower = sight_aim(c, *line, line->near, from);
  EXPECT_LT((narrower - line->at(line->near)).norm(), (aim - line->at(line->near)).norm());
}

TEST(Aiming, AimInPlaceTurnsTheGripperAxisAtTheTarget) {
  Eigen::Isometry3d tool = Eigen::Isometry3d::Identity();
  tool.translation() = Eigen::Vector3d(0.1, 0.2, 0.3);
  const Eigen::Vector3d target(0.4, 0.0, 1.0);
  const Eigen::Isometry3d g = aim_in_place(tool, target);
  EXPECT_LT((g.translation() - tool.translation()).norm(), 1e-12);
  EXPECT_NEAR(g.rotation().col(2).dot((target - tool.translation()).normalized()), 1.0, 1e-9);
}

// Hand-worked: a target 1 rad off the home axis, view_angle 0.5 rad,
// view_distance 0.5 m: the viewpoint is 0.5 m short of the target along the
// home axis turned 0.5 rad toward it, and looks at it.
TEST(Aiming, ViewpointIsViewDistanceShortAlongTheHomeAxisTurnedTowardTheTarget) {
  const ServoConfig c = config();
  const Eigen::Vector3d home = c.home_pose.translation();
  const Eigen::Vector3d axis = c.home_pose.linear().col(2);  // base +y
  const Eigen::Vector3d side = Eigen::Vector3d::UnitX();     // home +x lies beside the axis
  const Eigen::Vector3d target = home + 0.6 * (std::cos(1.0) * axis + std::sin(1.0) * side);
  const auto view = aim_from_viewpoint(c, target);
  ASSERT_TRUE(view.has_value());
  const Eigen::Vector3d view_axis = (target - view->translation()) / 0.5;
  EXPECT_NEAR((target - view->translation()).norm(), 0.5, 1e-9);
  EXPECT_NEAR(std::acos(view_axis.dot(axis)), 0.5, 1e-9);
  EXPECT_NEAR(view->rotation().col(2).dot(view_axis), 1.0, 1e-9);
  // Off (view_angle 0), or straight ahead: no viewpoint.
  ServoConfig off = c;
  off.view_angle = 0.0;
  EXPECT_FALSE(aim_from_viewpoint(off, target).has_value());
  EXPECT_FALSE(aim_from_viewpoint(c, home + 0.4 * axis).has_value());
}

TEST(Aiming, OrientFromAViewpointWhenTheTurnAtHomeIsTooWideOrWasBlocked) {
  ServoConfig c = config();
  const Eigen::Isometry3d home = c.home_pose;
  const Eigen::Vector3d axis = home.linear().col(2), side = Eigen::Vector3d::UnitX();
  auto off_axis = [&](double angle) {
    return home.translation() + 0.6 * (std::cos(angle) * axis + std::sin(angle) * side);
  };
  // 0.5 rad off: turned to in place.
  OrientGoal g = orient_goal(c, home, off_axis(0.5), false);
  EXPECT_FALSE(g.from_viewpoint);
  EXPECT_LT((g.goal.translation() - home.translation()).norm(), 1e-12);
  // 1.2 rad off (more than max_aim_angle 1.15): from the viewpoint.
  g = orient_goal(c, home, off_axis(1.2), false);
  EXPECT_TRUE(g.from_viewpoint);
  EXPECT_LT((g.goal.translation() - aim_from_viewpoint(c, off_axis(1.2))->translation()).norm(), 1e-12);
  // 0.5 rad off after a blocked turn: from the viewpoint too ...
  EXPECT_TRUE(orient_goal(c, home, off_axis(0.5), true).from_viewpoint);
  // ... unless there is none: in place.
  c.view_angle = 0.0;
  g = orient_goal(c, home, off_axis(1.2), true);
  EXPECT_FALSE(g.from_viewpoint);
  EXPECT_LT((g.goal.translation() - home.translation()).norm(), 1e-12);
}

// retreat_distance 0.15 m: 0.15 m from home (the boundary included) is out of the canopy, 0.151 m is not.
TEST(Aiming, OutOfTheCanopyWithinRetreatDistanceOfHome) {
  const ServoConfig c = config();
  const Eigen::Vector3d home = c.home_pose.translation();
  EXPECT_TRUE(out_of_canopy(c.home_pose, c.retreat_distance, home));
  EXPECT_TRUE(out_of_canopy(c.home_pose, c.retreat_distance, home + Eigen::Vector3d(0.0, 0.09, 0.12)));
  EXPECT_FALSE(out_of_canopy(c.home_pose, c.retreat_distance, home + Eigen::Vector3d(0.151, 0.0, 0.0)));
}

TEST(Aiming, BackAlongTheAxisToAbreastOfAPointOrAtLeastSoFar) {
  Eigen::Isometry3d tool = Eigen::Isometry3d::Identity();
  tool.translation() = Eigen::Vector3d(0.0, 0.0, 0.5);  // axis along +z
  EXPECT_NEAR(back_along_axis(tool, Eigen::Vector3d(0.3, 0.0, 0.2), 0.1).translation().z(), 0.2, 1e-12);
  EXPECT_NEAR(back_along_axis(tool, Eigen::Vector3d(0.0, 0.0, 0.45), 0.1).translation().z(), 0.4, 1e-12);
  EXPECT_NEAR(back_along_axis(tool, std::nullopt, 0.15).translation().z(), 0.35, 1e-12);
  EXPECT_NEAR(back_along_axis(tool, std::nullopt, 0.15).translation().x(), 0.0, 1e-12);
}

// The tool at (0, 0, 1) looking along +z, the approach begun at the origin,
// the way on to (0.5, 0, 0). Hand-worked: from (0, 0, z0) that way passes
// |0.25 - 0.3 z0| / sqrt(0.25 + z0^2) from a fruit at (0.2, 0, 0.5): 0.114 m
// from z0 0.55, 0.125 m from 0.53, the first of the 2 cm steps (back 0.15,
// 0.17, ...) clear by 0.12 m. No fruit: back 0.15 only; a fruit beside the
// last stretch of every way: abreast. The palm: a fruit 7.6 mm from the way
// of a palm 0.3 m behind (0.16 m from the tool point's) holds it back too.
TEST(Aiming, ARetreatEndsWhereTheWayOnClearsTheFruit) {
  Eigen::Isometry3d tool = Eigen::Isometry3d::Identity();
  tool.translation() = Eigen::Vector3d(0.0, 0.0, 1.0);
  Eigen::Isometry3d to = Eigen::Isometry3d::Identity();
  to.translation() = Eigen::Vector3d(0.5, 0.0, 0.0);
  const Eigen::Vector3d start = Eigen::Vector3d::Zero();
  const auto z = [&](const std::vector<Eigen::Vector3d>& fruit, double palm) {
    const Eigen::Isometry3d g = clear_retreat(tool, back_along_axis(tool, start, 0.15), 0.15, to, fruit, 0.12, palm);
    EXPECT_NEAR(g.translation().head<2>().norm(), 0.0, 1e-12);  // straight back along the axis
    EXPECT_TRUE(g.rotation().isApprox(tool.rotation()));
    return g.translation().z();
  };
  EXPECT_NEAR(z({}, 0.0), 0.85, 1e-9);
  EXPECT_NEAR(z({{0.2, 0.0, 0.5}}, 0.0), 0.53, 1e-9);
  EXPECT_NEAR(z({{0.45, 0.0, 0.02}}, 0.0), 0.0, 1e-9);
  EXPECT_NEAR(z({{0.05, 0.0, 0.45}}, 0.0), 0.85, 1e-9);
  EXPECT_LT(z({{0.05, 0.0, 0.45}}, 0.3), 0.85 - 0.01);
  // Never beyond abreast of the start, however far the clearance would need.
  EXPECT_NEAR(clear_retreat(tool, back_along_axis(tool, Eigen::Vector3d(0.0, 0.0, 0.9), 0.15), 0.15, to,
                            {{0.2, 0.0, 0.5}}, 0.12, 0.0)
                  .translation()
                  .z(),
              0.85, 1e-9);
}

// The way in began at the origin and went up +z; centring bent its last 0.2 m 4 cm sideways, to the tool at
// (0.04, 0, 0.5) still looking along +z. Straight back to the origin (the chord), in the tool's orientation; on along
// that line when at_least is farther; along the axis when the start is unknown or not behind the tool.
TEST(Aiming, BackTowardWhereTheWayInBeganGoesStraightThere) {
  Eigen::Isometry3d tool = Eigen::Isometry3d::Identity();
  tool.translation() = Eigen::Vector3d(0.04, 0.0, 0.5);
  const Eigen::Vector3d began = Eigen::Vector3d::Zero();
  const Eigen::Isometry3d g = back_toward(tool, began, 0.15);
  EXPECT_LT((g.translation() - began).norm(), 1e-12);
  EXPECT_TRUE(g.rotation().isApprox(tool.rotation()));
  const double chord = std::hypot(0.04, 0.5);  // 0.5016 m
  const Eigen::Vector3d farther = back_toward(tool, began, 0.6).translation();
  EXPECT_NEAR((farther - tool.translation()).norm(), 0.6, 1e-12);
  EXPECT_NEAR(farther.x(), 0.04 - 0.04 * 0.6 / chord, 1e-12);  // on the same line, past the start
  EXPECT_NEAR(back_toward(tool, std::nullopt, 0.15).translation().z(), 0.35, 1e-12);
  EXPECT_NEAR(back_toward(tool, std::nullopt, 0.15).translation().x(), 0.04, 1e-12);
  EXPECT_NEAR(back_toward(tool, Eigen::Vector3d(0.04, 0.0, 0.7), 0.15).translation().z(), 0.35, 1e-12);  // ahead
  EXPECT_NEAR(back_toward(tool, Eigen::Vector3d(0.6, 0.0, 0.4), 0.15).translation().x(), 0.04, 1e-12);   // beside
}

// The same way in, a neighbour at (0.06, 0, 0.3) that it passed 60 mm off (it went straight up the z axis there).
// Hand-worked for the palm 5 cm behind the tool point, from (0.04, 0, 0.45): straight back along the axis it passes
// x = 0.04 at z = 0.3, 20 mm from the neighbour's centre, inside the 28 mm (0.8 of a 35 mm radius) at which the
// simulated palm knocks a fruit off; straight back to the start, along (-0.08, 0, -1) / 1.0032, it passes
// |(0.02, 0, -0.15) x (-0.0797, 0, -0.9968)| = 0.0319 m from it.
TEST(Aiming, BackTowardWhereTheWayInBeganKeepsThePalmOffANeighbourTheAxisLineSweeps) {
  Eigen::Isometry3d tool = Eigen::Isometry3d::Identity();
  tool.translation() = Eigen::Vector3d(0.04, 0.0, 0.5);
  const Eigen::Vector3d neighbour(0.06, 0.0, 0.3), palm_back(0.0, 0.0, -0.05);
  const auto palm_pass = [&](const Eigen::Isometry3d& goal) {
    const Eigen::Vector3d a = tool.translation() + palm_back, b = goal.translation() + palm_back;
    const double s = std::clamp((neighbour - a).dot(b - a) / (b - a).squaredNorm(), 0.0, 1.0);
    return (a + s * (b - a) - neighbour).norm();
  };
  EXPECT_NEAR(palm_pass(back_along_axis(tool, Eigen::Vector3d::Zero(), 0.15)), 0.020, 1e-9);
  const double chord = palm_pass(back_toward(tool, Eigen::Vector3d::Zero(), 0.15));
  EXPECT_NEAR(chord, 0.0319, 0.0001);
  EXPECT_GT(chord, 0.8 * 0.035);
}

TEST(Aiming, DetachPullsBackAlongTheAxisWhileTwistingAboutIt) {
  Eigen::Isometry3d tool = Eigen::Isometry3d::Identity();
  tool.translation() = Eigen::Vector3d(0.0, 0.0, 0.5);
  const Eigen::Isometry3d g = detach_goal(tool, 0.1, 0.5236);
  EXPECT_NEAR(g.translation().z(), 0.4, 1e-12);
  EXPECT_NEAR(g.rotation().col(2).z(), 1.0, 1e-12);                                // the axis unchanged
  EXPECT_NEAR(std::atan2(g.rotation()(1, 0), g.rotation()(0, 0)), 0.5236, 1e-12);  // turned about it
}

TEST(Aiming, AGoalOutsideTheWorkspaceIsPulledBackAlongTheWayThere) {
  const Workspace ws;  // box y up to 1.3
  Eigen::Isometry3d goal = Eigen::Isometry3d::Identity();
  goal.translation() = Eigen::Vector3d(-0.3, 1.8, 0.0);
  const Eigen::Vector3d from(-0.3, 1.0, 0.0);
  const Eigen::Isometry3d g = inside_workspace(ws, from, goal);
  EXPECT_NEAR(g.translation().y(), 1.3, 1e-6);
  EXPECT_NEAR(g.translation().x(), -0.3, 1e-9);
  EXPECT_TRUE(ws.contains(g.translation()));
  goal.translation() = Eigen::Vector3d(-0.3, 1.2, 0.0);
  EXPECT_EQ(inside_workspace(ws, from, goal).translation(), goal.translation());
}

TEST(Aiming, InHandViewLeavesTheMarginOnEverySide) {
  geometry::CameraModel k = kDefaultHandCamera;
  k.dist = {};
  const Eigen::Isometry3d camera = Eigen::Isometry3d::Identity();
  EXPECT_TRUE(in_hand_view(k, camera, {0.0, 0.0, 0.5}, 0.2));
  // u = u0 + fx x / z: x = 0.1 at z = 0.5 is 166.7 px right of the centre
  // (u = 486.2 of 640): inside 20 % margins (u <= 512), outside 25 % ones (u <= 480).
  EXPECT_TRUE(in_hand_view(k, camera, {0.1, 0.0, 0.5}, 0.2));
  EXPECT_FALSE(in_hand_view(k, camera, {0.1, 0.0, 0.5}, 0.25));
  EXPECT_FALSE(in_hand_view(k, camera, {0.0, 0.0, -0.5}, 0.2));  // behind the camera
}

}  // namespace
}  // namespace harvest::servo
