// Whether the robot link will take the arm to a calibration pose, decided
// offline before anything moves (harvest-calibrate plan): the link's own
// checks and its own pose-goal decision (arm::plan_pose_goal: the straight
// Cartesian path's dry run, else a joint-space path to an IK solution, else
// refused), from the joints the arm will be at after the poses before it. A
// pose the link would refuse can then be replaced by a reachable variant
// instead of being skipped during the run.
#pragma once

#include <Eigen/Geometry>
#include <string>

#include "arm/robot_link_config.hpp"

namespace harvest::calib {

class LinkReach {
 public:
  // `q` the arm's joints now; the speeds those the plan's goals ask for.
  LinkReach(arm::RobotLinkConfig config, Eigen::VectorXd q, double max_linear_speed, double max_angular_speed);

  // Whether the link would take the arm from where the accepted poses left it
  // to `pose` (the arm is then taken to be there); else `why` is its refusal.
  bool accept(const Eigen::Isometry3d& pose, std::string* why = nullptr);
  const Eigen::VectorXd& joints() const { return q_; }

 private:
  arm::RobotLinkConfig config_;
  Eigen::VectorXd q_;
  double linear_speed_, angular_speed_;
};

}  // namespace harvest::calib
