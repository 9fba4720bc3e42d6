#include "arm/trajectory.hpp"

#include <algorithm>
#include <cmath>

namespace harvest::arm {
namespace {
constexpr double kPeakSpeed = 1.875;          // max of ds/dtau
constexpr double kPeakAcceleration = 5.7735;  // max of d2s/dtau2 = 10 / sqrt(3)
}  // namespace

double QuinticScaling::duration_for(double distance, double max_speed, double max_acceleration) {
  const double d = std::abs(distance);
  if (d == 0.0) return 0.0;
  return std::max(kPeakSpeed * d / max_speed, std::sqrt(kPeakAcceleration * d / max_acceleration));
}

double QuinticScaling::s(double t) const {
  if (duration <= 0.0 || t >= duration) return 1.0;
  if (t <= 0.0) return 0.0;
  const double u = t / duration;
  return u * u * u * (10.0 - 15.0 * u + 6.0 * u * u);
}

double QuinticScaling::ds(double t) const {
  if (duration <= 0.0 || t <= 0.0 || t >= duration) return 0.0;
  const double u = t / duration;
  return 30.0 * u * u * (1.0 - u) * (1.0 - u) / duration;
}

double QuinticScaling::dds(double t) const {
  if (duration <= 0.0 || t <= 0.0 || t >= duration) return 0.0;
  const double u = t / duration;
  return 60.0 * u * (1.0 - u) * (1.0 - 2.0 * u) / (duration * duration);
}

CartesianTrajectory::CartesianTrajectory(const Eigen::Isometry3d& start, const Eigen::Isometry3d& goal,
                                         const Limits& limits)
    : start_(start), goal_(goal) {
  const Eigen::AngleAxisd aa(goal.linear() * start.linear().transpose());
  angle_ = aa.angle();
  if (angle_ > 1e-12) axis_ = aa.axis();
  const double distance = (goal.translation() - start.translation()).norm();
  scaling_.duration = std::max(QuinticScaling::duration_for(distance, limits.linear_speed, limits.linear_acceleration),
                               QuinticScaling::duration_for(angle_, limits.angular_speed, limits.angular_acceleration));
}

Eigen::Isometry3d CartesianTrajectory::pose(double t) const {
  const double s = scaling_.s(t);
  Eigen::Isometry3d p = Eigen::Isometry3d::Identity();
  p.translation() = start_.translation() + s * (goal_.translation() - start_.translation());
  p.linear() = Eigen::AngleAxisd(s * angle_, axis_).toRotationMatrix() * start_.linear();
  return p;
}

kinematics::Twist CartesianTrajectory::twist(double t) const {
  const double ds = scaling_.ds(t);
  kinematics::Twist v;
  v.head<3>() = ds * (goal_.translation() - start_.translation());
  v.tail<3>() = ds * angle_ * axis_;
  return v;
}

JointTrajectory::JointTrajectory(const Eigen::VectorXd& start, const Eigen::VectorXd& goal,
                                 const Eigen::VectorXd& max_velocity, const Eigen::VectorXd& max_acceleration)
    : start_(start), goal_(goal) {
  for (Eigen::Index i = 0; i < start.size(); ++i)
    scaling_.duration = std::max(
        scaling_.duration, QuinticScaling::duration_for(goal[i] - start[i], max_velocity[i], max_acceleration[i]));
}

Eigen::VectorXd JointTrajectory::position(double t) const { return start_ + scaling_.s(t) * (goal_ - start_); }
Eigen::VectorXd JointTrajectory::velocity(double t) const { return scaling_.ds(t) * (goal_ - start_); }

}  // namespace harvest::arm
