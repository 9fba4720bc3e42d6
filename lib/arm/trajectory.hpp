// Smooth goal motions for the robot link: minimum-jerk (quintic) time scaling
// s(tau) = 10 tau^3 - 15 tau^4 + 6 tau^5, which starts and ends at rest with
// zero acceleration. The duration is the shortest that keeps the peak speed
// (1.875 D / T) and peak acceleration (5.774 D / T^2) within the limits.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "kinematics/chain.hpp"

namespace harvest::arm {

struct QuinticScaling {
  double duration = 0.0;  // [s]
  // Shortest duration for distance d with speed and acceleration limits.
  static double duration_for(double distance, double max_speed, double max_acceleration);
  double s(double t) const;    // 0..1
  double ds(double t) const;   // [1/s]
  double dds(double t) const;  // [1/s^2]
};

// Straight line in position and a constant-axis rotation in orientation.
class CartesianTrajectory {
 public:
  struct Limits {
    double linear_speed, angular_speed, linear_acceleration, angular_acceleration;
  };
  CartesianTrajectory(const Eigen::Isometry3d& start, const Eigen::Isometry3d& goal, const Limits& limits);
  double duration() const { return scaling_.duration; }
  Eigen::Isometry3d pose(double t) const;
  kinematics::Twist twist(double t) const;  // feed-forward (linear, angular) in the base frame
  const Eigen::Isometry3d& goal() const { return goal_; }

 private:
  Eigen::Isometry3d start_, goal_;
  Eigen::Vector3d axis_ = Eigen::Vector3d::UnitZ();
  double angle_ = 0.0;
  QuinticScaling scaling_;
};

// All joints move on the same time scaling, so they start and arrive together.
class JointTrajectory {
 public:
  JointTrajectory(const Eigen::VectorXd& start, const Eigen::VectorXd& goal, const Eigen::VectorXd& max_velocity,
                  const Eigen::VectorXd& max_acceleration);
  double duration() const { return scaling_.duration; }
  Eigen::VectorXd position(double t) const;
  Eigen::VectorXd velocity(double t) const;
  const Eigen::VectorXd& goal() const { return goal_; }

 private:
  Eigen::VectorXd start_, goal_;
  QuinticScaling scaling_;
};

}  // namespace harvest::arm
