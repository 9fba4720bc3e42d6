#include "servo/harvest/orientation_law.hpp"

#include <gtest/gtest.h>

#include <cmath>

namespace harvest::servo {
namespace {

Eigen::Isometry3d turned_about_z(double angle) {
  Eigen::Isometry3d t = Eigen::Isometry3d::Identity();
  t.linear() = Eigen::AngleAxisd(angle, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  return t;
}

// Hand-worked: the fruit at (0.1, 0.2, 1.0) m in the tool frame:
// alpha = atan(0.2) = 0.197396 rad, beta = -atan(0.1) = -0.099669 rad (eq. 6-19, 6-20);
// the reference x axis on the tool's x axis: gamma = 0.
TEST(OrientationLaw, AnglesOfTheThesis) {
  const OrientationError e =
      orientation_error(Eigen::Isometry3d::Identity(), {0.1, 0.2, 1.0}, Eigen::Vector3d::UnitX());
  EXPECT_NEAR(e.alpha, 0.197396, 1e-6);
  EXPECT_NEAR(e.beta, -0.099669, 1e-6);
  EXPECT_NEAR(e.gamma, 0.0, 1e-12);
  // The reference 0.3 rad about the axis from the tool's x axis: gamma = 0.3.
  const OrientationError r =
      orientation_error(Eigen::Isometry3d::Identity(), {0.0, 0.0, 1.0}, {std::cos(0.3), std::sin(0.3), 0.5});
  EXPECT_NEAR(r.gamma, 0.3, 1e-12);
}

// Eq. 6-24 with kp 2/s, kd 0: omega = 2 (-alpha, -beta, gamma) in the tool
// frame = (-0.394791, 0.199337, 0) rad/s; a tool turned 90 deg about base z
// sees it rotated into the base frame: (-0.199337, -0.394791, 0).
TEST(OrientationLaw, ProportionalTermTurnsTheAxisTowardTheFruit) {
  OrientationLaw law({2.0, 0.0, 0.5});
  const Twist t = law.update(Eigen::Isometry3d::Identity(), {0.1, 0.2, 1.0}, Eigen::Vector3d::UnitX(), 0.02);
  EXPECT_NEAR(t.angular.x(), -0.394791, 1e-6);
  EXPECT_NEAR(t.angular.y(), 0.199337, 1e-6);
  EXPECT_NEAR(t.angular.z(), 0.0, 1e-12);
  EXPECT_NEAR(t.linear.norm(), 0.0, 1e-12);  // the tool's position is held
  OrientationLaw turned({2.0, 0.0, 0.5});
  const Eigen::Isometry3d tool = turned_about_z(M_PI / 2);
  const Twist b = turned.update(tool, tool * Eigen::Vector3d(0.1, 0.2, 1.0), tool.rotation().col(0), 0.02);
  EXPECT_NEAR(b.angular.x(), -0.199337, 1e-6);
  EXPECT_NEAR(b.angular.y(), -0.394791, 1e-6);
}

// The derivative term from the previous step, filtered: kd 0.1 s, filter 0.5,
// gamma 0.30 then 0.28 rad 0.02 s later: rate 0.5 (-1 rad/s) = -0.5 rad/s;
// omega_z = 2 x 0.28 + 0.1 x (-0.5) = 0.51 rad/s.
TEST(OrientationLaw, DerivativeTermDampsFromTheFilteredRate) {
  OrientationLaw law({2.0, 0.1, 0.5});
  const Eigen::Vector3d target(0.0, 0.0, 1.0);
  const Twist first = law.update(Eigen::Isometry3d::Identity(), target, {std::cos(0.30), std::sin(0.30), 0}, 0.02);
  EXPECT_NEAR(first.angular.z(), 0.6, 1e-12);  // no rate from a single error
  const Twist second = law.update(Eigen::Isometry3d::Identity(), target, {std::cos(0.28), std::sin(0.28), 0}, 0.02);
  EXPECT_NEAR(second.angular.z(), 0.51, 1e-9);
  law.reset();
  EXPECT_NEAR(law.update(Eigen::Isometry3d::Identity(), target, {std::cos(0.28), std::sin(0.28), 0}, 0.02).angular.z(),
              0.56, 1e-9);
}

// Integrated in closed loop from 0.9 rad off (tool frame turning by its own
// twist), the law converges where aimed_with_roll says: the axis on the
// fruit, the x axis on the reference projected across it.
TEST(OrientationLaw, ConvergesToTheAimWithTheReferenceRoll) {
  OrientationLaw law({2.0, 0.05, 0.5});
  Eigen::Isometry3d tool = Eigen::Isometry3d::Identity();
  tool.translation() = Eigen::Vector3d(0.2, -0.1, 0.3);
  const Eigen::Vector3d target = tool.translation() + Eigen::Vector3d(0.8, -0.4, 0.5);
  const Eigen::Vector3d reference(1.0, 0.2, 0.0);
  const double dt = 0.02;
  for (int i = 0; i < 500; ++i) {
    const Twist t = law.update(tool, target, reference, dt);
    if (t.angular.norm() > 0)
      tool.linear() = Eigen::AngleAxisd(t.angular.norm() * dt, t.angular.normalized()) * tool.linear();
    tool.translation() += t.linear * dt;
  }
  const Eigen::Matrix3d aimed = aimed_with_roll(tool, target, reference);
  EXPECT_LT(Eigen::AngleAxisd(tool.rotation().transpose() * aimed).angle(), 1e-3);
  EXPECT_NEAR(tool.rotation().col(2).dot((target - tool.translation()).normalized()), 1.0, 1e-6);
  const Eigen::Vector3d across = (reference - reference.dot(aimed.col(2)) * aimed.col(2)).normalized();
  EXPECT_NEAR(aimed.col(0).dot(across), 1.0, 1e-12);
}

}  // namespace
}  // namespace harvest::servo
