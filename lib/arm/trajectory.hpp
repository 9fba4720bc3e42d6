// Smooth goal motions for the robot link: a trapezoidal speed profile whose
// ramps are sine-squared ("cycloidal") blends. With ramp time Ta, total time T
// and cruise speed c = 1 / (T - Ta) of the normalized scaling s in [0, 1]:
//   ds = c sin^2(pi t / (2 Ta))          for t in [0, Ta]       (ramp up)
//   ds = c                               for t in [Ta, T - Ta]  (cruise)
//   ds(t) = ds(T - t)                    for t in [T - Ta, T]   (ramp down)
// so it starts and ends at rest with zero acceleration (no acceleration step,
// no jerk spike), and the peak acceleration is pi c / (2 Ta). For one axis of
// distance D with limits V, A: if D >= pi V^2 / (2 A) it cruises at V with
// Ta = pi V / (2 A), T = D / V + Ta; else it is a pure ramp up and down (T = 2 Ta)
// with Ta = sqrt(pi D / (2 A)). Example: D = 0.5 m, V = 0.381 m/s, A = 1 m/s^2
// gives Ta = 0.5985 s, T = 1.9108 s (the minimum-jerk quintic took 1.875 D / V
// = 2.4606 s).
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <span>

#include "kinematics/chain.hpp"

namespace harvest::arm {

struct SmoothTrapezoid {
  // One axis moved on the scaling: its distance and its limits (all > 0 except
  // the distance, whose sign is ignored).
  struct Axis {
    double distance, max_speed, max_acceleration;
  };

  double duration = 0.0;  // T [s]
  double ramp = 0.0;      // Ta [s], 0 <= ramp <= duration / 2

  // The shortest profile of this shape for one axis.
  static SmoothTrapezoid shortest(double distance, double max_speed, double max_acceleration);
  // The shortest single profile that keeps every axis within its own speed and
  // acceleration limit (the axes start and arrive together).
  static SmoothTrapezoid shortest(std::span<const Axis> axes);
  // shortest(distance, max_speed, max_acceleration).duration
  static double duration_for(double distance, double max_speed, double max_acceleration);

  double s(double t) const;    // 0..1
  double ds(double t) const;   // [1/s]
  double dds(double t) const;  // [1/s^2]
  double peak_ds() const;      // cruise speed [1/s]
  double peak_dds() const;     // peak |dds| [1/s^2]
};

// Straight line in position and a constant-axis rotation in orientation.
class CartesianTrajectory {
 public:
  struct Limits {
    double linear_speed, angular_speed, linear_acceleration, angular_acceleration;
  };
  CartesianTrajectory(const Eigen::Isometry3d& start, const Eigen::Isometry3d& goal, const Limits& limits);
  double duration() const { return scaling_.duration; }
  const SmoothTrapezoid& scaling() const { return scaling_; }
  Eigen::Isometry3d pose(double t) const;
  kinematics::Twist twist(double t) const;  // feed-forward (linear, angular) in the base frame
  const Eigen::Isometry3d& goal() const { return goal_; }

 private:
  Eigen::Isometry3d start_, goal_;
  Eigen::Vector3d axis_ = Eigen::Vector3d::UnitZ();
  double angle_ = 0.0;
  SmoothTrapezoid scaling_;
};

// All joints move on the same time scaling, so they start and arrive together.
class JointTrajectory {
 public:
  JointTrajectory(const Eigen::VectorXd& start, const Eigen::VectorXd& goal, const Eigen::VectorXd& max_velocity,
                  const Eigen::VectorXd& max_acceleration);
  double duration() const { return scaling_.duration; }
  const SmoothTrapezoid& scaling() const { return scaling_; }
  Eigen::VectorXd position(double t) const;
  Eigen::VectorXd velocity(double t) const;
  const Eigen::VectorXd& goal() const { return goal_; }

 private:
  Eigen::VectorXd start_, goal_;
  SmoothTrapezoid scaling_;
};

}  // namespace harvest::arm
