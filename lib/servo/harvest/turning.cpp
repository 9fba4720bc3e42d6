#include "servo/harvest/turning.hpp"

#include "servo/harvest/aiming.hpp"

namespace harvest::servo {

Turning::Turning(const ServoConfig& cfg)
    : cfg_(cfg), law_({cfg.gains.kp_orient, cfg.gains.kd_orient, cfg.gains.derivative_filter}) {}

Turning::Start Turning::from_here(const Eigen::Isometry3d& tool, Fruit& fruit) {
  from_retreat_ = false;
  const OrientGoal g = orient_goal(cfg_, tool, fruit.estimate, fruit.from_viewpoint);
  fruit.from_viewpoint = g.from_viewpoint;
  if (g.from_viewpoint || cfg_.orient_law != "thesis_pd") return {g.goal, false};
  // The thesis's law turns the tool in place to where it converges, watched as a goal.
  Eigen::Isometry3d aimed = tool;
  aimed.linear() = aimed_with_roll(tool, fruit.estimate, cfg_.home_pose.rotation().col(0));
  law_.reset();
  return {aimed, true};
}

std::optional<Eigen::Isometry3d> Turning::from_retreat(const Eigen::Isometry3d& tool, Fruit& fruit) {
  const OrientGoal g = orient_goal(cfg_, cfg_.home_pose, fruit.estimate, fruit.from_viewpoint);
  fruit.from_viewpoint = g.from_viewpoint;
  if (g.from_viewpoint && !out_of_canopy(cfg_.home_pose, cfg_.retreat_distance, tool.translation()))
    return std::nullopt;
  from_retreat_ = true;
  return g.goal;
}

std::optional<Eigen::Matrix3d> Turning::ahead(const Fruit& fruit) const {
  const OrientGoal g = orient_goal(cfg_, cfg_.home_pose, fruit.estimate, fruit.from_viewpoint);
  if (g.from_viewpoint) return std::nullopt;
  return g.goal.rotation();
}

Turning::Blocked Turning::blocked(const std::string& why, const Eigen::Isometry3d& camera, Fruit& fruit) const {
  const std::string name = "fruit " + std::to_string(fruit.id);
  // The aim is a means to get the fruit into the hand image: an arm stopped short of it (a joint limit just
  // before the viewpoint) with the fruit well inside the image acquires it from there.
  if (in_hand_view(cfg_.hand_camera, camera, fruit.estimate, cfg_.in_view_margin))
    return {Blocked::Action::kAcquire, name + ": the turn " + why + " short of its goal, the fruit in view"};
  // The way from the end of the retreat is not the way from home: try the turn from home before any verdict.
  if (from_retreat_)
    return {Blocked::Action::kFromHome, name + ": the turn from the retreat " + why + ", turning from home"};
  if (!fruit.from_viewpoint && aim_from_viewpoint(cfg_, fruit.estimate)) {
    // Aiming happens outside the canopy: back home, then to the viewpoint.
    fruit.from_viewpoint = true;
    return {Blocked::Action::kViaViewpoint,
            name + ": the arm could not turn to it (" + why + "), aiming from a viewpoint"};
  }
  return {Blocked::Action::kUnreachable,
          (fruit.from_viewpoint ? "the arm could not reach a viewpoint of it (" : "the arm could not turn to it (") +
              why + ")"};
}

}  // namespace harvest::servo
