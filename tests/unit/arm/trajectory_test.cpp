// Goal trajectories: minimum-jerk time scaling within the speed and
// acceleration limits, start and end at rest, and arrival at the goal.
#include "arm/trajectory.hpp"

#include <gtest/gtest.h>

#include <cmath>

namespace harvest::arm {
namespace {

TEST(QuinticScaling, StartsAndEndsAtRestAndIsMonotone) {
  QuinticScaling s;
  s.duration = 2.0;
  EXPECT_DOUBLE_EQ(s.s(0.0), 0.0);
  EXPECT_DOUBLE_EQ(s.s(2.0), 1.0);
  EXPECT_DOUBLE_EQ(s.s(5.0), 1.0);
  EXPECT_DOUBLE_EQ(s.ds(0.0), 0.0);
  EXPECT_DOUBLE_EQ(s.ds(2.0), 0.0);
  EXPECT_NEAR(s.s(1.0), 0.5, 1e-12);
  double prev = 0.0;
  for (double t = 0.0; t <= 2.0; t += 0.001) {
    EXPECT_GE(s.s(t), prev - 1e-15);
    prev = s.s(t);
    // ds and dds are the derivatives of s (central differences).
    if (t > 0.01 && t < 1.99) {
      EXPECT_NEAR(s.ds(t), (s.s(t + 1e-6) - s.s(t - 1e-6)) / 2e-6, 1e-6);
      EXPECT_NEAR(s.dds(t), (s.ds(t + 1e-6) - s.ds(t - 1e-6)) / 2e-6, 1e-5);
    }
  }
}

TEST(QuinticScaling, DurationRespectsSpeedAndAccelerationLimits) {
  for (double d : {0.01, 0.1, 0.5, 2.0}) {
    for (double vmax : {0.1, 0.381, 1.0}) {
      for (double amax : {0.2, 0.5, 5.0}) {
        QuinticScaling s;
        s.duration = QuinticScaling::duration_for(d, vmax, amax);
        double peak_v = 0.0, peak_a = 0.0;
        for (int k = 0; k <= 2000; ++k) {
          const double t = s.duration * k / 2000.0;
          peak_v = std::max(peak_v, d * s.ds(t));
          peak_a = std::max(peak_a, std::abs(d * s.dds(t)));
        }
        EXPECT_LE(peak_v, vmax * (1 + 1e-6)) << d << " " << vmax << " " << amax;
        EXPECT_LE(peak_a, amax * (1 + 1e-4)) << d << " " << vmax << " " << amax;
        // ... and is the shortest such: one of the two limits is reached.
        EXPECT_TRUE(peak_v > 0.99 * vmax || peak_a > 0.99 * amax) << d << " " << vmax << " " << amax;
      }
    }
  }
  EXPECT_EQ(QuinticScaling::duration_for(0.0, 1.0, 1.0), 0.0);
}

Eigen::Isometry3d pose(double x, double y, double z, double angle, const Eigen::Vector3d& axis) {
  Eigen::Isometry3d p = Eigen::Isometry3d::Identity();
  p.translation() = Eigen::Vector3d(x, y, z);
  p.linear() = Eigen::AngleAxisd(angle, axis.normalized()).toRotationMatrix();
  return p;
}

TEST(CartesianTrajectory, StraightLineWithinLimitsReachingTheGoal) {
  const Eigen::Isometry3d a = pose(-0.4, 0.7, -0.3, 0.2, Eigen::Vector3d(1, 0, 0));
  const Eigen::Isometry3d b = pose(-0.2, 0.9, -0.25, 0.9, Eigen::Vector3d(0, 1, 1));
  const CartesianTrajectory::Limits lim{0.381, 1.0, 0.5, 2.0};
  const CartesianTrajectory tr(a, b, lim);
  ASSERT_GT(tr.duration(), 0.0);
  EXPECT_TRUE(tr.pose(0.0).isApprox(a, 1e-12));
  EXPECT_TRUE(tr.pose(tr.duration()).isApprox(b, 1e-12));
  EXPECT_TRUE(tr.pose(tr.duration() + 1.0).isApprox(b, 1e-12));
  const Eigen::Vector3d dir = (b.translation() - a.translation()).normalized();
  const double dt = 1e-3;
  for (double t = 0.0; t < tr.duration(); t += dt) {
    const auto v = tr.twist(t);
    EXPECT_LE(v.head<3>().norm(), lim.linear_speed * (1 + 1e-6));
    EXPECT_LE(v.tail<3>().norm(), lim.angular_speed * (1 + 1e-6));
    // On the segment from a to b.
    const Eigen::Vector3d off = tr.pose(t).translation() - a.translation();
    EXPECT_LT((off - off.dot(dir) * dir).norm(), 1e-12);
    // The feed-forward twist is the derivative of the pose.
    const Eigen::Isometry3d p0 = tr.pose(t), p1 = tr.pose(t + dt);
    const Eigen::Vector3d lin = (p1.translation() - p0.translation()) / dt;
    const Eigen::AngleAxisd rot(p1.linear() * p0.linear().transpose());
    const Eigen::Vector3d ang = rot.angle() * rot.axis() / dt;
    EXPECT_LT((lin - v.head<3>()).norm(), 0.01 * lim.linear_speed + 1e-9);
    EXPECT_LT((ang - v.tail<3>()).norm(), 0.01 * lim.angular_speed + 1e-9);
  }
  EXPECT_TRUE(tr.twist(tr.duration()).isZero());
  EXPECT_TRUE(tr.twist(0.0).isZero());
}

TEST(JointTrajectory, AllJointsArriveTogetherWithinTheirLimits) {
  Eigen::VectorXd a(3), b(3), vmax(3), amax(3);
  a << 0.0, 1.0, -0.5;
  b << 1.0, 0.8, 0.5;
  vmax << 1.0, 0.1, 2.0;
  amax << 3.0, 3.0, 0.5;
  const JointTrajectory tr(a, b, vmax, amax);
  EXPECT_TRUE(tr.position(0.0).isApprox(a));
  EXPECT_TRUE(tr.position(tr.duration()).isApprox(b));
  EXPECT_TRUE(tr.velocity(tr.duration()).isZero());
  const double dt = 1e-3;
  Eigen::VectorXd prev_v = tr.velocity(0.0);
  for (double t = dt; t < tr.duration(); t += dt) {
    const Eigen::VectorXd v = tr.velocity(t);
    EXPECT_TRUE((v.cwiseAbs().array() <= vmax.array() * (1 + 1e-6)).all()) << t;
    EXPECT_TRUE((((v - prev_v) / dt).cwiseAbs().array() <= amax.array() * (1 + 1e-2)).all()) << t;
    prev_v = v;
    // Same time scaling: every joint has covered the same fraction.
    const Eigen::VectorXd frac = (tr.position(t) - a).cwiseQuotient(b - a);
    EXPECT_NEAR(frac[0], frac[1], 1e-12);
    EXPECT_NEAR(frac[0], frac[2], 1e-12);
  }
}

}  // namespace
}  // namespace harvest::arm
