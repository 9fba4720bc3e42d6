#include "arm/trajectory.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <vector>

namespace harvest::arm {

// Choosing the one shape (Ta, T) for all axes. Let L = T - Ta (>= Ta), so the
// cruise speed of s is 1 / L. Axis i moves D_i s(t): its peak speed is D_i / L
// and its peak acceleration pi D_i / (2 Ta L). Within the limits means
//   L >= Lv = max_i D_i / V_i                  (speed)
//   Ta L >= P = max_i pi D_i / (2 A_i)         (acceleration)
//   Ta <= L                                    (the ramps fit)
// and we minimize T = L + Ta. For a given L the shortest ramp is Ta = P / L, so
// T(L) = L + P / L, which falls up to L = sqrt(P) and rises after it; the ramps
// fit only for L >= sqrt(P). Hence L = max(Lv, sqrt(P)), Ta = P / L:
//  - Lv >= sqrt(P): the axis with the largest D / V cruises at its V, the one
//    with the largest P peaks at its A (one axis: Ta = pi V / (2 A), T = D / V + Ta);
//  - otherwise no axis reaches its speed; Ta = L = sqrt(P) (pure ramp up and
//    down, one axis: T = 2 Ta = sqrt(2 pi D / A)) and the largest-P axis peaks at its A.
// The slowest axis's own shortest duration is not always enough for the shared
// shape: axis 1 with Lv = 2 s, P = 0.01 s^2 (alone T = 2.005 s) and axis 2 with
// P = 1 s^2 (alone T = 2 s) need T = 2 + 1 / 2 = 2.5 s together, because a
// 2.005 s profile that keeps axis 1 within its speed (L >= 2) has Ta <= 0.005 s,
// far too short a ramp for axis 2.
SmoothTrapezoid SmoothTrapezoid::shortest(std::span<const Axis> axes) {
  double lv = 0.0, p = 0.0;
  for (const Axis& a : axes) {
    const double d = std::abs(a.distance);
    if (d == 0.0) continue;
    lv = std::max(lv, d / a.max_speed);
    p = std::max(p, std::numbers::pi * d / (2.0 * a.max_acceleration));
  }
  SmoothTrapezoid out;
  const double l = std::max(lv, std::sqrt(p));
  if (l == 0.0) return out;       // nothing moves (or no limits at all)
  out.ramp = std::min(p / l, l);  // min: P / sqrt(P) may round above sqrt(P)
  out.duration = l + out.ramp;
  return out;
}

SmoothTrapezoid SmoothTrapezoid::shortest(double distance, double max_speed, double max_acceleration) {
  const Axis a{distance, max_speed, max_acceleration};
  return shortest(std::span<const Axis>(&a, 1));
}

double SmoothTrapezoid::duration_for(double distance, double max_speed, double max_acceleration) {
  return shortest(distance, max_speed, max_acceleration).duration;
}

namespace {
// The first half of the profile, u in [0, T / 2] (the second half is its mirror).
struct Half {
  double ramp, cruise;  // Ta, c = 1 / (T - Ta)
  double s(double u) const {
    if (u >= ramp) return cruise * (u - 0.5 * ramp);
    return cruise * (0.5 * u - ramp / (2.0 * std::numbers::pi) * std::sin(std::numbers::pi * u / ramp));
  }
  double ds(double u) const {
    if (u >= ramp) return cruise;
    const double sn = std::sin(std::numbers::pi * u / (2.0 * ramp));
    return cruise * sn * sn;
  }
  double dds(double u) const {
    if (u >= ramp) return 0.0;
    return cruise * std::numbers::pi / (2.0 * ramp) * std::sin(std::numbers::pi * u / ramp);
  }
};
Half half(const SmoothTrapezoid& p) { return {p.ramp, 1.0 / (p.duration - p.ramp)}; }
}  // namespace

double SmoothTrapezoid::s(double t) const {
  if (duration <= 0.0 || t >= duration) return 1.0;
  if (t <= 0.0) return 0.0;
  const Half h = half(*this);
  return 2.0 * t <= duration ? h.s(t) : 1.0 - h.s(duration - t);
}

double SmoothTrapezoid::ds(double t) const {
  if (duration <= 0.0 || t <= 0.0 || t >= duration) return 0.0;
  const Half h = half(*this);
  return h.ds(2.0 * t <= duration ? t : duration - t);
}

double SmoothTrapezoid::dds(double t) const {
  if (duration <= 0.0 || t <= 0.0 || t >= duration) return 0.0;
  const Half h = half(*this);
  return 2.0 * t <= duration ? h.dds(t) : -h.dds(duration - t);
}

double SmoothTrapezoid::peak_ds() const { return duration > 0.0 ? 1.0 / (duration - ramp) : 0.0; }

double SmoothTrapezoid::peak_dds() const {
  return ramp > 0.0 ? std::numbers::pi / (2.0 * ramp * (duration - ramp)) : 0.0;
}

CartesianTrajectory::CartesianTrajectory(const Eigen::Isometry3d& start, const Eigen::Isometry3d& goal,
                                         const Limits& limits)
    : start_(start), goal_(goal) {
  const Eigen::AngleAxisd aa(goal.linear() * start.linear().transpose());
  angle_ = aa.angle();
  if (angle_ > 1e-12) axis_ = aa.axis();
  const double distance = (goal.translation() - start.translation()).norm();
  const SmoothTrapezoid::Axis axes[] = {{distance, limits.linear_speed, limits.linear_acceleration},
                                        {angle_, limits.angular_speed, limits.angular_acceleration}};
  scaling_ = SmoothTrapezoid::shortest(axes);
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
  std::vector<SmoothTrapezoid::Axis> axes(static_cast<std::size_t>(start.size()));
  for (Eigen::Index i = 0; i < start.size(); ++i)
    axes[static_cast<std::size_t>(i)] = {goal[i] - start[i], max_velocity[i], max_acceleration[i]};
  scaling_ = SmoothTrapezoid::shortest(axes);
}

Eigen::VectorXd JointTrajectory::position(double t) const { return start_ + scaling_.s(t) * (goal_ - start_); }
Eigen::VectorXd JointTrajectory::velocity(double t) const { return scaling_.ds(t) * (goal_ - start_); }

}  // namespace harvest::arm
