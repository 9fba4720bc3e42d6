// TbzApproach: the servo's ApproachStrategy for teach by zooming, driven by
// feature_matches_t messages (issue 4).
#include <gtest/gtest.h>

#include <Eigen/Dense>

#include "geometry/homography.hpp"
#include "servo/tbz_approach.hpp"

namespace g = harvest::geometry;
namespace s = harvest::servo;
using Eigen::Matrix3d;
using Eigen::Vector3d;

namespace {

const Matrix3d kA = g::intrinsics(500, 480, 1.55, 320, 240);

// Eight points on a tilted plane ~0.4 m ahead of the goal camera F_d (= base).
std::vector<Vector3d> target() {
  std::vector<Vector3d> X;
  for (double x : {-0.06, -0.02, 0.02, 0.06})
    for (double y : {-0.04, 0.04}) X.emplace_back(x, y, 0.4 + 0.2 * x - 0.1 * y);
  return X;
}

harvest::feature_matches_t matches(const Eigen::Isometry3d& camera, int64_t utime, int n = 8) {
  harvest::feature_matches_t m{};
  m.header.utime = utime;
  m.status = harvest::feature_matches_t::STATUS_OK;
  for (const auto& X : target()) {
    if (static_cast<int>(m.desired_u_px.size()) == n) break;
    const Eigen::Vector2d d = (kA * X).hnormalized();
    const Eigen::Vector2d c = (kA * (camera.inverse() * X)).hnormalized();
    m.desired_u_px.push_back(static_cast<float>(d.x()));
    m.desired_v_px.push_back(static_cast<float>(d.y()));
    m.current_u_px.push_back(static_cast<float>(c.x()));
    m.current_v_px.push_back(static_cast<float>(c.y()));
  }
  m.num_matches = static_cast<int32_t>(m.desired_u_px.size());
  m.num_inliers = m.num_matches;
  return m;
}

s::TbzApproachParams params() {
  s::ServoConfig cfg;
  cfg.hand_camera.fx = 470;  // deliberately wrong estimate of kA
  cfg.hand_camera.fy = 500;
  cfg.hand_camera.skew = 0;
  cfg.hand_camera.cx = 330;
  cfg.hand_camera.cy = 230;
  auto p = s::tbz_params_from(cfg);
  p.controller.lambda_v = 0.4;
  p.controller.desired_depth_estimate = 0.5;
  return p;
}

}  // namespace

TEST(TbzApproach, ConvergesOnMatchesWithWrongIntrinsics) {
  s::TbzApproach approach(params());
  EXPECT_EQ(approach.name(), "tbz");
  Eigen::Isometry3d camera = Eigen::Isometry3d::Identity();
  camera.linear() = g::rotation_from_vector(Vector3d(0.1, -0.15, 0.2));
  camera.translation() = Vector3d(0.04, -0.03, -0.06);
  Eigen::Isometry3d cam_to_tool = Eigen::Isometry3d::Identity();
  cam_to_tool.linear() = g::rotation_from_vector(Vector3d(0.0, 0.3, 0.1));
  cam_to_tool.translation() = Vector3d(0, 0.05, -0.1);
  const double dt = 0.02;
  const double p0 = camera.translation().norm();
  for (int k = 0; k < 400; ++k) {
    const int64_t now = 1'000'000 + k * 20'000;
    approach.on_matches(matches(camera, now));
    s::ApproachInput in{now, camera * cam_to_tool, camera, Vector3d::Zero(), std::nullopt, std::nullopt};
    const auto out = approach.update(in);
    ASSERT_TRUE(approach.last_refusal().empty()) << k << ": " << approach.last_refusal();
    // The camera moves with the commanded twist (base frame).
    camera.translation() += out.twist.linear * dt;
    camera.linear() = g::rotation_from_vector(out.twist.angular * dt) * camera.linear();
  }
  const double pos = camera.translation().norm(), ang = g::angle_axis(camera.linear()).theta;
  std::printf("TbzApproach: %.1f mm -> %.4f mm, %.4f deg\n", p0 * 1000, pos * 1000, ang * 180 / M_PI);
  EXPECT_LT(pos, 1e-3);
  EXPECT_LT(ang, 1e-3);
}

TEST(TbzApproach, NoMotionWithoutFreshVerifiedMatches) {
  s::TbzApproach approach(params());
  Eigen::Isometry3d camera = Eigen::Isometry3d::Identity();
  camera.translation() = Vector3d(0.02, 0, -0.05);
  s::ApproachInput in{2'000'000, camera, camera, Vector3d::Zero(), std::nullopt, std::nullopt};
  auto out = approach.update(in);
  EXPECT_EQ(out.twist.linear.norm() + out.twist.angular.norm(), 0.0);
  EXPECT_NE(approach.last_refusal().find("no FEATURE_MATCHES"), std::string::npos);

  auto m = matches(camera, 2'000'000);
  m.status = harvest::feature_matches_t::STATUS_TOO_FEW;
  m.status_text = "3 of 5 matches consistent";
  approach.on_matches(m);
  out = approach.update(in);
  EXPECT_EQ(out.twist.linear.norm(), 0.0);
  EXPECT_NE(approach.last_refusal().find("3 of 5"), std::string::npos);

  approach.on_matches(matches(camera, 1'000'000));  // 1 s old
  out = approach.update(in);
  EXPECT_EQ(out.twist.linear.norm(), 0.0);
  EXPECT_NE(approach.last_refusal().find("stale"), std::string::npos);

  approach.on_matches(matches(camera, 2'000'000, 3));  // three pairs only
  out = approach.update(in);
  EXPECT_EQ(out.twist.linear.norm(), 0.0);
  EXPECT_FALSE(approach.last_refusal().empty());

  approach.on_matches(matches(camera, 2'000'000));
  out = approach.update(in);
  EXPECT_GT(out.twist.linear.norm(), 0.0);
  EXPECT_TRUE(approach.last_refusal().empty());
  // Under IR guidance only the forward speed along the camera axis.
  in.forward_speed = 0.1;
  out = approach.update(in);
  EXPECT_LT((out.twist.linear - camera.linear() * Vector3d(0, 0, 0.1)).norm(), 1e-12);
  EXPECT_EQ(out.twist.angular.norm(), 0.0);
}
