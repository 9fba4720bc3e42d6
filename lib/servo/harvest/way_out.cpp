#include "servo/harvest/way_out.hpp"

#include <vector>

#include "servo/harvest/aiming.hpp"

namespace harvest::servo {

WayOut::WayOut(const ServoConfig& cfg, bool straight)
    : straight_(straight),
      home_after_joint_limit_(cfg.home_after_joint_limit),
      pull_through_(cfg.pull_through && cfg.release_at_detach && cfg.release_while_retreating),
      retreat_clearance_(cfg.retreat_clearance),
      palm_offset_(cfg.palm_offset),
      pull_distance_(cfg.pull_distance),
      home_(cfg.home_pose) {}

Eigen::Isometry3d WayOut::retreat(const Eigen::Isometry3d& from, double at_least) const {
  return back_along_axis(from, approach_from_, at_least);
}

Eigen::Isometry3d WayOut::goal(const Eigen::Isometry3d& from, double at_least, const targets_t* fixed) {
  next_from_there_ = straight_ && !(home_after_joint_limit_ && joint_limit_met_);
  if (!next_from_there_ || retreat_clearance_ <= 0.0 || fixed == nullptr) return retreat(from, at_least);
  // Every fruit the fixed camera sees now (the one just picked is in the gripper or falling where the pull ended).
  std::vector<Eigen::Vector3d> fruit;
  for (const auto& t : fixed->targets) fruit.emplace_back(t.position_base[0], t.position_base[1], t.position_base[2]);
  return clear_retreat(from, approach_from_, at_least, home_, fruit, retreat_clearance_, palm_offset_);
}

bool WayOut::pulled_off(const Eigen::Isometry3d& tool) const {
  return pull_from_ &&
         (pull_from_->translation() - tool.translation()).dot(pull_from_->rotation().col(2)) >= pull_distance_;
}

}  // namespace harvest::servo
