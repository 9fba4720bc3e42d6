// Goal trajectories: a trapezoidal speed profile with sine-squared ramps,
// the shortest of its shape within the speed and acceleration limits, start
// and end at rest with zero acceleration, and arrival at the goal.
#include "arm/trajectory.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <vector>

namespace harvest::arm {
namespace {

constexpr double kPi = std::numbers::pi;

// The peak |D ds| and |D dds| of a profile, sampled densely and at the points
// where the peaks are (the cruise, the middle of each ramp).
struct Peaks {
  double speed = 0.0, acceleration = 0.0;
};
Peaks sampled_peaks(const SmoothTrapezoid& p, double distance) {
  std::vector<double> ts;
  for (int k = 0; k <= 4000; ++k) ts.push_back(p.duration * k / 4000.0);
  for (double t : {0.5 * p.ramp, p.ramp, 0.5 * p.duration, p.duration - p.ramp, p.duration - 0.5 * p.ramp})
    ts.push_back(t);
  Peaks out;
  for (double t : ts) {
    out.speed = std::max(out.speed, std::abs(distance * p.ds(t)));
    out.acceleration = std::max(out.acceleration, std::abs(distance * p.dds(t)));
  }
  return out;
}

TEST(SmoothTrapezoid, HandWorkedDurations) {
  // Reaches the speed limit (D = 0.5 >= pi V^2 / (2 A) = 0.228 m):
  // Ta = pi 0.381 / (2 1.0) = 0.5985 s, T = 0.5 / 0.381 + 0.5985 = 1.3123 + 0.5985 = 1.9108 s.
  // The minimum-jerk quintic took max(1.875 D / V, sqrt(5.7735 D / A)) = max(2.4606, 1.6990) = 2.4606 s:
  // 0.55 s (22 %) longer.
  const SmoothTrapezoid a = SmoothTrapezoid::shortest(0.5, 0.381, 1.0);
  EXPECT_NEAR(a.ramp, 0.5985, 1e-4);
  EXPECT_NEAR(a.duration, 1.9108, 1e-4);
  EXPECT_DOUBLE_EQ(SmoothTrapezoid::duration_for(0.5, 0.381, 1.0), a.duration);
  EXPECT_LT(a.duration, 0.8 * 1.875 * 0.5 / 0.381);
  // Cruises at V: 0.5 ds = 0.381 between the ramps; half of it in the middle of a ramp (sin^2(pi / 4) = 1 / 2),
  // where the acceleration peaks at A = 1.
  EXPECT_NEAR(0.5 * a.ds(1.0), 0.381, 1e-12);
  EXPECT_NEAR(0.5 * a.ds(0.5 * a.ramp), 0.381 / 2, 1e-12);
  EXPECT_NEAR(0.5 * a.dds(0.5 * a.ramp), 1.0, 1e-12);
  EXPECT_NEAR(0.5 * a.dds(a.duration - 0.5 * a.ramp), -1.0, 1e-12);
  // Each ramp covers V Ta / 2 = 0.1140 m.
  EXPECT_NEAR(0.5 * a.s(a.ramp), 0.381 * 0.5985 / 2, 1e-4);

  // Too short to reach V (D = 0.05 < 0.228 m): a pure ramp up and down, D = Vp Ta with Ta = pi Vp / (2 A),
  // so Vp = sqrt(2 A D / pi) = 0.1784 m/s, Ta = sqrt(pi D / (2 A)) = 0.2802 s, T = 2 Ta = 0.5605 s.
  // (Acceleration-limited moves are where the sine-squared ramp is ~4 % slower than the quintic,
  // sqrt(2 pi D / A) against sqrt(5.7735 D / A) = 0.5373 s; it is faster for D > 1.795 V^2 / A = 0.26 m here.)
  const SmoothTrapezoid b = SmoothTrapezoid::shortest(0.05, 0.381, 1.0);
  EXPECT_NEAR(b.ramp, 0.2802, 1e-4);
  EXPECT_NEAR(b.duration, 0.5605, 1e-4);
  EXPECT_DOUBLE_EQ(b.duration, 2.0 * b.ramp);
  EXPECT_NEAR(0.05 * b.ds(0.5 * b.duration), 0.1784, 1e-4);
  EXPECT_NEAR(0.05 * b.dds(0.5 * b.ramp), 1.0, 1e-12);

  // A 1 rad turn at 1 rad/s and 2 rad/s^2 (1 >= pi 1^2 / 4 = 0.785 rad): Ta = pi / 4 = 0.7854 s,
  // T = 1 + 0.7854 = 1.7854 s; the quintic took 1.875 s.
  const SmoothTrapezoid c = SmoothTrapezoid::shortest(1.0, 1.0, 2.0);
  EXPECT_NEAR(c.ramp, kPi / 4, 1e-12);
  EXPECT_NEAR(c.duration, 1.0 + kPi / 4, 1e-12);

  // The sign of the distance does not matter; nothing to move takes no time.
  EXPECT_DOUBLE_EQ(SmoothTrapezoid::duration_for(-0.5, 0.381, 1.0), a.duration);
  EXPECT_EQ(SmoothTrapezoid::duration_for(0.0, 1.0, 1.0), 0.0);
  const SmoothTrapezoid none = SmoothTrapezoid::shortest(0.0, 1.0, 1.0);
  EXPECT_EQ(none.duration, 0.0);
  EXPECT_EQ(none.s(0.0), 1.0);
  EXPECT_EQ(none.ds(0.0), 0.0);
  EXPECT_EQ(none.dds(0.0), 0.0);
}

TEST(SmoothTrapezoid, StartsAndEndsAtRestIsMonotoneAndHasConsistentDerivatives) {
  // One with a cruise, one pure ramp, one barely cruising.
  for (const SmoothTrapezoid& p : {SmoothTrapezoid::shortest(0.5, 0.381, 1.0),
                                   SmoothTrapezoid::shortest(0.05, 0.381, 1.0), SmoothTrapezoid{2.0, 0.99}}) {
    const double T = p.duration, ta = p.ramp;
    SCOPED_TRACE(testing::Message() << "T " << T << " Ta " << ta);
    // Exactly at rest, at the ends and beyond them.
    EXPECT_EQ(p.s(0.0), 0.0);
    EXPECT_EQ(p.s(-1.0), 0.0);
    EXPECT_EQ(p.s(T), 1.0);
    EXPECT_EQ(p.s(T + 1.0), 1.0);
    for (double t : {-1.0, 0.0, T, T + 1.0}) {
      EXPECT_EQ(p.ds(t), 0.0);
      EXPECT_EQ(p.dds(t), 0.0);
    }
    // No acceleration step: the acceleration grows from zero (as does the speed, quadratically).
    EXPECT_LT(std::abs(p.dds(1e-6)), 1e-4 * p.peak_dds());
    EXPECT_LT(std::abs(p.dds(T - 1e-6)), 1e-4 * p.peak_dds());
    EXPECT_LT(p.ds(1e-6), 1e-9 * p.peak_ds());
    // ... nor at the ends of the ramps: zero acceleration on both sides.
    for (double t : {ta, T - ta}) {
      EXPECT_LT(std::abs(p.dds(t - 1e-9)), 1e-6 * p.peak_dds());
      EXPECT_LT(std::abs(p.dds(t + 1e-9)), 1e-6 * p.peak_dds());
    }
    EXPECT_NEAR(p.s(0.5 * T), 0.5, 1e-12);  // symmetric
    double prev = 0.0;
    const double h = 1e-6;
    for (double t = 0.0; t <= T; t += T / 3000.0) {
      EXPECT_GE(p.s(t), prev) << t;
      EXPECT_GE(p.ds(t), 0.0) << t;
      prev = p.s(t);
      // ds and dds are the derivatives of s and ds (central differences; the jerk steps at the ends of the ramps
      // cost O(h jerk) there).
      if (t > h && t < T - h) {
        EXPECT_NEAR(p.ds(t), (p.s(t + h) - p.s(t - h)) / (2 * h), 1e-7 * p.peak_ds()) << t;
        EXPECT_NEAR(p.dds(t), (p.ds(t + h) - p.ds(t - h)) / (2 * h), 1e-4 * p.peak_dds()) << t;
      }
    }
    // It gets there: s is 1 at the end, and the speed integrates to 1.
    double integral = 0.0;
    const int n = 20000;
    for (int k = 0; k < n; ++k) integral += p.ds((k + 0.5) * T / n) * T / n;
    EXPECT_NEAR(integral, 1.0, 1e-7);
    EXPECT_NEAR(p.s(T - 1e-9), 1.0, 1e-9);
  }
}

// The smallest total time of this shape for the axes, searched over the ramp time (1e-4 s to 100 s, in relative steps
// of 7e-5) instead of derived: for a ramp Ta the profile must have L = T - Ta >= Ta, L >= D / V (speed) and
// Ta L >= pi D / (2 A) (acceleration) on every axis. Being a search, it can only be longer than the true shortest.
double searched_shortest(const std::vector<SmoothTrapezoid::Axis>& axes) {
  double best = std::numeric_limits<double>::infinity();
  for (int k = 1; k <= 200000; ++k) {
    const double ta = 1e-4 * std::pow(1e6, k / 200000.0);
    double l = ta;
    for (const auto& a : axes)
      l = std::max({l, std::abs(a.distance) / a.max_speed, kPi * std::abs(a.distance) / (2 * a.max_acceleration * ta)});
    best = std::min(best, l + ta);
  }
  return best;
}

TEST(SmoothTrapezoid, ShortestWithinTheSpeedAndAccelerationLimits) {
  for (double d : {0.001, 0.01, 0.1, 0.228, 0.5, 2.0}) {
    for (double vmax : {0.1, 0.381, 1.0}) {
      for (double amax : {0.2, 0.5, 5.0}) {
        SCOPED_TRACE(testing::Message() << "D " << d << " V " << vmax << " A " << amax);
        const SmoothTrapezoid p = SmoothTrapezoid::shortest(d, vmax, amax);
        const Peaks peak = sampled_peaks(p, d);
        EXPECT_LE(peak.speed, vmax * (1 + 1e-12));
        EXPECT_LE(peak.acceleration, amax * (1 + 1e-12));
        EXPECT_NEAR(peak.speed, d * p.peak_ds(), 1e-12 * vmax);
        EXPECT_NEAR(peak.acceleration, d * p.peak_dds(), 1e-12 * amax);
        // The acceleration limit is always reached (the ramp is as short as it allows); the speed limit
        // exactly when the distance is long enough to cruise.
        EXPECT_NEAR(peak.acceleration, amax, 1e-12 * amax);
        if (d >= kPi * vmax * vmax / (2 * amax)) {
          EXPECT_NEAR(peak.speed, vmax, 1e-12 * vmax);
          EXPECT_NEAR(p.duration, d / vmax + kPi * vmax / (2 * amax), 1e-12);
        } else {
          EXPECT_LT(peak.speed, vmax);
          EXPECT_NEAR(p.duration, std::sqrt(2 * kPi * d / amax), 1e-12);
        }
        // ... and no shape of this kind is shorter (the search finds none, and comes within its step of it).
        const double searched = searched_shortest({{d, vmax, amax}});
        EXPECT_LE(p.duration, searched * (1 + 1e-12));
        EXPECT_GT(p.duration, searched * (1 - 1e-4));
      }
    }
  }
}

TEST(SmoothTrapezoid, OneShapeForSeveralAxesKeepsEachWithinItsLimits) {
  // Axis 1 alone: cruise-limited, T = 2 + 0.005 s; axis 2 alone: a pure ramp, T = 2 s. The slowest single-axis
  // duration (2.005 s) has no ramp time that suits both (axis 1 needs L >= 2 s, so Ta <= 0.005 s, and axis 2
  // needs Ta L >= 1 s^2): together they take L = 2 s, Ta = 1 / 2 s, T = 2.5 s.
  const std::vector<SmoothTrapezoid::Axis> axes = {{2.0, 1.0, kPi * 2.0 / (2 * 0.01)}, {1.0, 10.0, kPi / 2}};
  EXPECT_NEAR(SmoothTrapezoid::duration_for(2.0, 1.0, axes[0].max_acceleration), 2.005, 1e-12);
  EXPECT_NEAR(SmoothTrapezoid::duration_for(1.0, 10.0, kPi / 2), 2.0, 1e-12);
  const SmoothTrapezoid p = SmoothTrapezoid::shortest(axes);
  EXPECT_NEAR(p.ramp, 0.5, 1e-12);
  EXPECT_NEAR(p.duration, 2.5, 1e-12);
  EXPECT_LE(p.duration, searched_shortest(axes) * (1 + 1e-12));
  EXPECT_GT(p.duration, searched_shortest(axes) * (1 - 1e-4));
  const Peaks a1 = sampled_peaks(p, 2.0), a2 = sampled_peaks(p, 1.0);
  EXPECT_NEAR(a1.speed, 1.0, 1e-12);  // axis 1 at its speed limit
  EXPECT_LT(a1.acceleration, axes[0].max_acceleration);
  EXPECT_LT(a2.speed, 10.0);
  EXPECT_NEAR(a2.acceleration, kPi / 2, 1e-12);  // axis 2 at its acceleration limit

  // A grid of pairs: each axis within its limits, one of the limits reached, no shorter shape.
  for (double d1 : {0.05, 0.5, 2.0})
    for (double d2 : {0.0, 0.1, 1.0, 3.0})
      for (double v2 : {0.2, 1.0})
        for (double a2 : {0.3, 2.0, 20.0}) {
          const std::vector<SmoothTrapezoid::Axis> ax = {{d1, 0.381, 1.0}, {d2, v2, a2}};
          SCOPED_TRACE(testing::Message() << d1 << " " << d2 << " " << v2 << " " << a2);
          const SmoothTrapezoid q = SmoothTrapezoid::shortest(ax);
          bool reached = false;
          for (const auto& a : ax) {
            const Peaks pk = sampled_peaks(q, a.distance);
            EXPECT_LE(pk.speed, a.max_speed * (1 + 1e-12));
            EXPECT_LE(pk.acceleration, a.max_acceleration * (1 + 1e-12));
            reached =
                reached || pk.speed > a.max_speed * (1 - 1e-9) || pk.acceleration > a.max_acceleration * (1 - 1e-9);
            EXPECT_GE(q.duration, SmoothTrapezoid::duration_for(a.distance, a.max_speed, a.max_acceleration) - 1e-12);
          }
          EXPECT_TRUE(reached);
          const double searched = searched_shortest(ax);
          EXPECT_LE(q.duration, searched * (1 + 1e-12));
          EXPECT_GT(q.duration, searched * (1 - 1e-4));
        }
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

// Checks a Cartesian trajectory against all four limits: the twist and (by differences of the twist) the
// acceleration; translation and rotation cover the same fraction at every instant and arrive together. Returns
// the peaks (linear speed, angular speed, linear acceleration, angular acceleration).
Eigen::Vector4d check_cartesian(const CartesianTrajectory& tr, const Eigen::Isometry3d& a, const Eigen::Isometry3d& b,
                                const CartesianTrajectory::Limits& lim) {
  const double distance = (b.translation() - a.translation()).norm();
  const double angle = Eigen::AngleAxisd(b.linear() * a.linear().transpose()).angle();
  Eigen::Vector4d peak = Eigen::Vector4d::Zero();
  const double dt = 1e-4;
  for (double t = 0.0; t < tr.duration(); t += dt) {
    const kinematics::Twist v = tr.twist(t), acc = (tr.twist(t + dt) - tr.twist(t - dt)) / (2 * dt);
    peak = peak.cwiseMax(
        Eigen::Vector4d(v.head<3>().norm(), v.tail<3>().norm(), acc.head<3>().norm(), acc.tail<3>().norm()));
    const double lin_frac = (tr.pose(t).translation() - a.translation()).norm() / distance;
    const double rot_frac = Eigen::AngleAxisd(tr.pose(t).linear() * a.linear().transpose()).angle() / angle;
    EXPECT_NEAR(lin_frac, rot_frac, 1e-9) << t;
  }
  EXPECT_LE(peak[0], lim.linear_speed * (1 + 1e-9));
  EXPECT_LE(peak[1], lim.angular_speed * (1 + 1e-9));
  EXPECT_LE(peak[2], lim.linear_acceleration * (1 + 1e-4));
  EXPECT_LE(peak[3], lim.angular_acceleration * (1 + 1e-4));
  EXPECT_TRUE(tr.pose(tr.duration()).isApprox(b, 1e-12));
  EXPECT_TRUE(tr.twist(tr.duration()).isZero());
  return peak;
}

TEST(CartesianTrajectory, RotationSlowerThanTranslation) {
  // 0.1 m (alone a pure ramp, 0.79 s) with a 1.5 rad turn (alone Ta = pi / 4, T = 1.5 + pi / 4 = 2.285 s): the
  // turn sets the shape, at its speed and acceleration limits; the translation is well within its.
  const CartesianTrajectory::Limits lim{0.381, 1.0, 1.0, 2.0};
  const Eigen::Isometry3d a = pose(-0.4, 0.7, -0.3, 0.0, Eigen::Vector3d(1, 0, 0));
  const Eigen::Isometry3d b = pose(-0.4, 0.8, -0.3, 1.5, Eigen::Vector3d(0, 1, 1));
  const CartesianTrajectory tr(a, b, lim);
  EXPECT_NEAR(tr.duration(), 1.5 + kPi / 4, 1e-9);
  EXPECT_NEAR(tr.scaling().ramp, kPi / 4, 1e-9);
  const Eigen::Vector4d peak = check_cartesian(tr, a, b, lim);
  EXPECT_NEAR(peak[1], 1.0, 1e-6);
  EXPECT_NEAR(peak[3], 2.0, 1e-3);
  EXPECT_LT(peak[0], 0.5 * lim.linear_speed);
  EXPECT_LT(peak[2], 0.5 * lim.linear_acceleration);
}

TEST(CartesianTrajectory, TranslationSlowerThanRotation) {
  // 0.5 m (T = 1.9108 s, as in HandWorkedDurations) with a 0.2 rad turn (alone 0.89 s): the translation sets it.
  const CartesianTrajectory::Limits lim{0.381, 1.0, 1.0, 2.0};
  const Eigen::Isometry3d a = pose(-0.4, 0.7, -0.3, 0.1, Eigen::Vector3d(0, 0, 1));
  const Eigen::Isometry3d b = pose(-0.1, 0.3, -0.3, 0.3, Eigen::Vector3d(0, 0, 1));
  const CartesianTrajectory tr(a, b, lim);
  EXPECT_NEAR(tr.duration(), 1.9108, 1e-4);
  const Eigen::Vector4d peak = check_cartesian(tr, a, b, lim);
  EXPECT_NEAR(peak[0], 0.381, 1e-6);
  EXPECT_NEAR(peak[2], 1.0, 1e-3);
  EXPECT_LT(peak[1], 0.5 * lim.angular_speed);
  EXPECT_LT(peak[3], 0.5 * lim.angular_acceleration);
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

TEST(JointTrajectory, JointsWithDifferentLimitsShareTheShortestShape) {
  // Joint 0: 1 rad at 1 rad/s, 2 rad/s^2 (alone 1 + pi / 4 = 1.785 s, speed-limited). Joint 1: 0.5 rad at 2 rad/s,
  // 0.4 rad/s^2 (alone a pure ramp of sqrt(2 pi 0.5 / 0.4) = 2.802 s). Together Lv = 1 s, P = pi 0.5 / 0.8 =
  // 1.963 s^2 > Lv^2, so a pure ramp set by joint 1: T = 2.802 s. Joint 2 (still) takes no part.
  Eigen::VectorXd a(3), b(3), vmax(3), amax(3);
  a << 0.0, 0.0, 0.3;
  b << 1.0, -0.5, 0.3;
  vmax << 1.0, 2.0, 0.01;
  amax << 2.0, 0.4, 0.01;
  const JointTrajectory tr(a, b, vmax, amax);
  EXPECT_NEAR(tr.duration(), std::sqrt(2 * kPi * 0.5 / 0.4), 1e-12);
  EXPECT_NEAR(tr.scaling().ramp, 0.5 * tr.duration(), 1e-12);
  const double dt = 1e-4;
  Eigen::VectorXd peak_v = Eigen::VectorXd::Zero(3), peak_a = Eigen::VectorXd::Zero(3);
  for (double t = 0.0; t < tr.duration(); t += dt) {
    peak_v = peak_v.cwiseMax(tr.velocity(t).cwiseAbs());
    peak_a = peak_a.cwiseMax(((tr.velocity(t + dt) - tr.velocity(t - dt)) / (2 * dt)).cwiseAbs());
  }
  EXPECT_TRUE((peak_v.array() <= vmax.array() * (1 + 1e-9)).all()) << peak_v.transpose();
  EXPECT_TRUE((peak_a.array() <= amax.array() * (1 + 1e-4)).all()) << peak_a.transpose();
  EXPECT_NEAR(peak_a[1], 0.4, 1e-4);
  EXPECT_EQ(peak_v[2], 0.0);
  EXPECT_TRUE(tr.position(tr.duration()).isApprox(b));
  EXPECT_TRUE(tr.velocity(tr.duration()).isZero());
}

}  // namespace
}  // namespace harvest::arm
