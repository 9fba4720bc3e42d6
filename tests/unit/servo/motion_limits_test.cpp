// The speed, acceleration and workspace limits applied to every commanded twist (motion_limits.hpp).
#include "servo/motion_limits.hpp"

#include <gtest/gtest.h>

#include <random>

#include "config/config.hpp"

namespace harvest::servo {
namespace {

// Every key at its default, as the controller reads an empty configuration.
ServoConfig defaults() { return ServoConfig::from_yaml(config::Document::load_string("{}").root()); }

// clip_to_workspace over random positions inside and random velocities: the
// predicted point never leaves, the speed never grows.
TEST(MotionLimits, WorkspaceClipNeverLeavesAndNeverSpeedsUp) {
  const Workspace ws;  // the default box and reach shell
  std::mt19937 rng(42);
  std::uniform_real_distribution<double> u(0.0, 1.0), vel(-1.0, 1.0);
  int tested = 0, clipped = 0;
  while (tested < 20000) {
    const Eigen::Vector3d p = ws.min + (ws.max - ws.min).cwiseProduct(Eigen::Vector3d(u(rng), u(rng), u(rng)));
    if (!ws.contains(p)) continue;
    ++tested;
    const Eigen::Vector3d v(vel(rng), vel(rng), vel(rng));
    const double horizon = 0.02 + 0.2 * u(rng);
    const Eigen::Vector3d c = clip_to_workspace(ws, p, v, horizon);
    clipped += (c - v).norm() > 1e-12;
    ASSERT_TRUE(ws.contains(p + c * horizon, -1e-9)) << p.transpose() << " v " << v.transpose();
    ASSERT_LE(c.norm(), v.norm() + 1e-12);
  }
  EXPECT_GT(clipped, 100);  // the boundary was exercised
}

TEST(MotionLimits, LimiterCapsSpeedAndAcceleration) {
  ServoConfig cfg = defaults();
  TwistLimiter limiter(
      {cfg.max_linear_speed, cfg.max_angular_speed, cfg.max_linear_accel, cfg.max_angular_accel, cfg.validity_s},
      cfg.workspace);
  const Eigen::Vector3d p = cfg.home_pose.translation();
  Twist want;
  want.linear = Eigen::Vector3d(3.0, 0.0, 0.0);
  want.angular = Eigen::Vector3d(0.0, 0.0, 5.0);
  Twist prev;
  for (int i = 0; i < 100; ++i) {
    const Twist t = limiter.apply(want, p, cfg.tick_period_s);
    EXPECT_LE(t.linear.norm(), cfg.max_linear_speed + 1e-12);
    EXPECT_LE(t.angular.norm(), cfg.max_angular_speed + 1e-12);
    EXPECT_LE((t.linear - prev.linear).norm(), cfg.max_linear_accel * cfg.tick_period_s + 1e-12);
    EXPECT_LE((t.angular - prev.angular).norm(), cfg.max_angular_accel * cfg.tick_period_s + 1e-12);
    prev = t;
  }
  EXPECT_NEAR(prev.linear.norm(), cfg.max_linear_speed, 1e-9);  // reached the limit, not beyond
  EXPECT_EQ(defaults().max_linear_speed, 0.381);                // thesis 15 in/s is the default
  EXPECT_EQ(defaults().validity_s, 0.1);
}

}  // namespace
}  // namespace harvest::servo
