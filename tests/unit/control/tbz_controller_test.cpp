// TBZ control law: signs, limits, refusals (thesis eq. 5-33..5-63).
#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <cmath>

#include "control/tbz_controller.hpp"
#include "control/tbz_simulation.hpp"

namespace c = harvest::control;
namespace g = harvest::geometry;
using Eigen::Matrix3d;
using Eigen::Vector3d;

namespace {

const Matrix3d kA = g::intrinsics(500, 500, M_PI / 2, 320, 240);

// A square target 1 m ahead of the goal camera; returns its pixels seen by a
// camera whose pose in F_d is (R_wc, p_wc).
g::Points2 view(const Matrix3d& R_wc, const Vector3d& p_wc) {
  g::Points2 px;
  for (const Vector3d& X : {Vector3d(-0.1, -0.1, 1.0), Vector3d(0.1, -0.1, 1.0), Vector3d(0.1, 0.1, 1.1),
                           Vector3d(-0.1, 0.1, 1.1)})
    px.push_back((kA * (R_wc.transpose() * (X - p_wc))).hnormalized());
  return px;
}

c::TbzParams params() {
  c::TbzParams p;
  p.A_hat = kA;
  p.max_linear_speed = 0;
  p.max_angular_speed = 0;
  return p;
}

}  // namespace

TEST(TbzTransforms, RobotCameraTwistRoundTrip) {
  const Matrix3d R = g::rotation_from_vector(Vector3d(0.2, -0.1, 0.4));
  const Vector3d t(0.02, 0.04, 0.03);
  c::Twist r;
  r.v = Vector3d(0.1, -0.2, 0.3);
  r.w = Vector3d(-0.5, 0.2, 0.1);
  const auto cam = c::robot_to_camera(r, R, t);
  EXPECT_LT((cam.w - R * r.w).norm(), 1e-15);
  EXPECT_LT((cam.v - (R * r.v + t.cross(R * r.w))).norm(), 1e-15);  // eq. 5-33
  const auto back = c::camera_to_robot(cam, R, t);
  EXPECT_LT((back.v - r.v).norm(), 1e-14);
  EXPECT_LT((back.w - r.w).norm(), 1e-14);
}

TEST(TbzTransforms, GainFunction) {
  EXPECT_NEAR(c::translation_gain_f(0, 0), 1.0 / 3.0, 1e-15);
  EXPECT_GT(c::translation_gain_f(0.5, 0.5), 0.0);
  EXPECT_LT(c::translation_gain_f(0.5, 0.5), c::translation_gain_f(0.1, 0.1));
}

TEST(TbzController, AtTheGoalTheTwistIsZero) {
  c::TbzController ctrl(params());
  const auto px = view(Matrix3d::Identity(), Vector3d::Zero());
  const auto out = ctrl.step({px, px, {}, {}});
  ASSERT_TRUE(out.ok()) << out.message;
  EXPECT_LT(out.robot.v.norm(), 1e-12);
  EXPECT_LT(out.robot.w.norm(), 1e-12);
  EXPECT_NEAR(out.alpha1, 1.0, 1e-12);
}

TEST(TbzController, TwistPointsTowardTheGoal) {
  // Camera displaced and rotated: the commanded camera motion must reduce
  // both the distance to F_d and the rotation angle.
  // The target is tilted 27 deg; the decomposition needs its normal to pick
  // the right one of the two visible solutions on the first frame.
  auto p0 = params();
  p0.reference_normal = Vector3d(0, -1, 2).normalized();
  c::TbzController ctrl(p0);
  const Matrix3d R = g::rotation_from_vector(Vector3d(0.05, -0.08, 0.1));
  const Vector3d p(0.03, -0.02, -0.1);
  const auto out = ctrl.step({view(R, p), view(Matrix3d::Identity(), Vector3d::Zero()), {}, {}});
  ASSERT_TRUE(out.ok()) << out.message;
  const Vector3d v_world = R * out.camera_estimate.v;
  EXPECT_LT(v_world.dot(p), 0.0);
  // Small rotation step about the camera axis must lower the angle.
  const Matrix3d R_next = R * g::rotation_from_vector(1e-3 * out.camera_estimate.w);
  EXPECT_LT(g::angle_axis(R_next).theta, g::angle_axis(R).theta);
  EXPECT_NEAR(out.theta, g::angle_axis(R).theta, 1e-9);
}

TEST(TbzController, SpeedLimitsTrip) {
  auto p = params();
  p.max_linear_speed = 0.05;
  p.max_angular_speed = 0.1;
  c::TbzController ctrl(p);
  const auto out = ctrl.step({view(g::rotation_from_vector(Vector3d(0, 0.3, 0)), Vector3d(0.2, 0, -0.3)),
                              view(Matrix3d::Identity(), Vector3d::Zero()), {}, {}});
  ASSERT_TRUE(out.ok());
  EXPECT_TRUE(out.saturated);
  EXPECT_NEAR(out.robot.v.norm(), 0.05, 1e-12);
  EXPECT_NEAR(out.robot.w.norm(), 0.1, 1e-12);
}

TEST(TbzController, RefusesBadInputWithZeroTwist) {
  c::TbzController ctrl(params());
  const auto px = view(Matrix3d::Identity(), Vector3d::Zero());
  g::Points2 three(px.begin(), px.begin() + 3);
  auto out = ctrl.step({three, three, {}, {}});
  EXPECT_EQ(out.status, c::TbzStatus::kTooFewPoints);
  EXPECT_EQ(out.robot.v.norm() + out.robot.w.norm(), 0.0);
  g::Points2 line{{0, 0}, {10, 10}, {20, 20}, {30, 30}};
  out = ctrl.step({line, line, {}, {}});
  EXPECT_EQ(out.status, c::TbzStatus::kDegenerate);
  EXPECT_FALSE(out.message.empty());
  auto nan = px;
  nan[1].x() = std::nan("");
  out = ctrl.step({nan, px, {}, {}});
  EXPECT_EQ(out.status, c::TbzStatus::kNonFinite);
  EXPECT_EQ(out.robot.v.norm() + out.robot.w.norm(), 0.0);
  auto p = params();
  p.translation_point = 7;
  c::TbzController bad(p);
  EXPECT_EQ(bad.step({px, px, {}, {}}).status, c::TbzStatus::kBadIndex);
}
