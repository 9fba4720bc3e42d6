#include "calib/link_reach.hpp"

#include <fmt/format.h>

#include <algorithm>

#include "arm/pose_goal_planner.hpp"
#include "kinematics/chain.hpp"

namespace harvest::calib {

LinkReach::LinkReach(arm::RobotLinkConfig config, Eigen::VectorXd q, double max_linear_speed, double max_angular_speed)
    : config_(std::move(config)), q_(std::move(q)), linear_speed_(max_linear_speed), angular_speed_(max_angular_speed) {
  if (q_.size() != config_.model.dof())
    throw std::invalid_argument(fmt::format("{} joint values for an arm of {}", q_.size(), config_.model.dof()));
}

bool LinkReach::accept(const Eigen::Isometry3d& pose, std::string* why) {
  // As RobotLinkNode::start_pose_goal: the workspace, the goal's duration, then the planner.
  if (!config_.workspace.contains(pose.translation())) {
    if (why) *why = "pose goal outside the workspace";
    return false;
  }
  const auto& l = config_.limits;
  const arm::CartesianTrajectory path(kinematics::tool_pose(config_.model, q_), pose,
                                      {std::min(l.linear_speed, linear_speed_), std::min(l.angular_speed, angular_speed_),
                                       l.linear_acceleration, l.angular_acceleration});
  if (!(path.duration() <= config_.dry_run.max_duration)) {
    if (why) *why = fmt::format("the pose goal would take {:.0f} s", path.duration());
    return false;
  }
  const arm::PoseGoalPlan plan = arm::plan_pose_goal(config_, path, q_, Eigen::VectorXd::Zero(config_.model.dof()));
  switch (plan.way) {
    case arm::PoseGoalPlan::Way::kCartesian:
      q_ = plan.dry_run.q;
      return true;
    case arm::PoseGoalPlan::Way::kJointSpace:
      q_ = plan.joints->goal();
      return true;
    default:
      if (why) *why = "pose goal not reachable: " + plan.why;
      return false;
  }
}

}  // namespace harvest::calib
