#include "servo/harvest/way_out.hpp"

#include <vector>

#include "servo/harvest/aiming.hpp"

namespace harvest::servo {

WayOut::WayOut(const ServoConfig& cfg, bool straight)
    : straight_(straight),
      home_after_joint_limit_(cfg.home_after_joint_limit),
      pull_through_(cfg.pull_through && cfg.release_at_detach && cfg.release_while_retreating),
      retrace_way_in_(cfg.retrace_way_in),
      retreat_clearance_(cfg.retreat_clearance),
      palm_offset_(cfg.palm_offset),
      pull_distance_(cfg.pull_distance),
      retreat_distance_(cfg.retreat_distance),
      twist_angle_(cfg.twist_angle),
      turn_home_within_(cfg.turn_ahead_home_within),
      home_(cfg.home_pose) {}

Eigen::Isometry3d WayOut::retreat(const Eigen::Isometry3d& from, double at_least) const {
  return way_back(from, approach_from_, at_least, retrace_way_in_);
}

Eigen::Isometry3d WayOut::goal(const Eigen::Isometry3d& from, double at_least, const targets_t* fixed) {
  next_from_there_ = straight_ && !(home_after_joint_limit_ && joint_limit_met_);
  if (!next_from_there_ || retreat_clearance_ <= 0.0 || fixed == nullptr) return retreat(from, at_least);
  // Every fruit the fixed camera sees now (the one just picked is in the gripper or falling where the pull ended).
  std::vector<Eigen::Vector3d> fruit;
  for (const auto& t : fixed->targets) fruit.emplace_back(t.position_base[0], t.position_base[1], t.position_base[2]);
  return clear_retreat(from, retreat(from, at_least), at_least, home_, fruit, retreat_clearance_, palm_offset_);
}

WayOut::Start WayOut::start(const Eigen::Isometry3d& tool, const GoalTolerances& at_home) {
  // Every fruit is selected and aimed at from home (the view the fixed camera's estimate is good for).
  if (pose_reached(tool, home_, at_home)) return {Start::Action::kSelect};
  if (out_of_canopy(home_, retreat_distance_, tool.translation())) return {Start::Action::kReturn, home_};
  next_from_there_ = false;  // from an unknown place: home first
  return {Start::Action::kRetreat, back_along_axis(tool, std::nullopt, retreat_distance_)};
}

Eigen::Isometry3d WayOut::turned(const Eigen::Isometry3d& way_out, const Eigen::Matrix3d& aim) const {
  Eigen::Isometry3d way = way_out;
  way.linear() = aim;
  if ((way.translation() - home_.translation()).norm() <= turn_home_within_) way.translation() = home_.translation();
  return way;
}

Eigen::Isometry3d WayOut::through(const Eigen::Isometry3d& grasped, const targets_t* fixed) {
  // No stop at the end of the pull, whose braking and new start cost about 0.4 s a fruit; the fruit is let go on
  // the way (pulled_off).
  Eigen::Isometry3d way = goal(grasped, pull_distance_ + retreat_distance_, fixed);
  way.linear() = detach_goal(grasped, 0.0, twist_angle_).linear();
  pull_from_ = grasped;
  return way;
}

bool WayOut::pulled_off(const Eigen::Isometry3d& tool) const {
  return pull_from_ &&
         (pull_from_->translation() - tool.translation()).dot(pull_from_->rotation().col(2)) >= pull_distance_;
}

}  // namespace harvest::servo
