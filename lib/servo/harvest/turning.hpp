// ORIENT: turning the gripper to the current fruit. From home (or where RETURN ended) the turn in place or the
// fruit's viewpoint (orient_goal), as a pose goal the robot link runs or, with orient_law thesis_pd, the thesis's
// PD law on the aim angles (eq. 6-24) watched toward where it converges; from the end of a retreat straight to
// the aim from home (straight_to_next); and, when a turn stops short, what comes of it.
#pragma once

#include <Eigen/Geometry>
#include <optional>
#include <string>

#include "servo/harvest/fruit.hpp"
#include "servo/harvest/orientation_law.hpp"
#include "servo/motion_limits.hpp"
#include "servo/servo_config.hpp"

namespace harvest::servo {

class Turning {
 public:
  explicit Turning(const ServoConfig& cfg);

  struct Start {
    Eigen::Isometry3d goal = Eigen::Isometry3d::Identity();
    bool law = false;  // the thesis's law turns the tool to `goal` (ORIENT_PD); false: a pose goal (ORIENT)
  };
  // The turn to `fruit` from `tool` (home, or the end of a RETURN); sets fruit.from_viewpoint to the way chosen.
  Start from_here(const Eigen::Isometry3d& tool, Fruit& fruit);
  // The turn straight from the end of a retreat with the tool at `tool`: to the aim from home; nullopt if that
  // is a viewpoint and the tool is farther than retreat_distance from home (the way there from elsewhere, after
  // another viewpoint, may cross the canopy's front): home first. Sets fruit.from_viewpoint.
  std::optional<Eigen::Isometry3d> from_retreat(const Eigen::Isometry3d& tool, Fruit& fruit);
  // The orientation of the turn from_retreat would make to `fruit` (its aim from home), for a way out that turns
  // on its way; nullopt for a fruit aimed at from a viewpoint.
  std::optional<Eigen::Matrix3d> ahead(const Fruit& fruit) const;
  // ORIENT_PD: one step of the law (eq. 6-24), the roll held at home's.
  Twist law_step(const Eigen::Isometry3d& tool, const Eigen::Vector3d& target) {
    return law_.update(tool, target, cfg_.home_pose.rotation().col(0), cfg_.tick_period_s);
  }

  // The turn stopped short of its goal (`why`: stalled, refused, did not complete), the camera-in-hand at `camera`.
  struct Blocked {
    enum class Action {
      kAcquire,       // the fruit is well inside the hand image: acquire it from here
      kFromHome,      // the turn began at a retreat's end: home, then the turn from there
      kViaViewpoint,  // home, then to the fruit's viewpoint (fruit.from_viewpoint set)
      kUnreachable,   // the arm cannot turn to it, nor reach a viewpoint of it: given up for good
    } action;
    std::string text;  // the status note, or kUnreachable's detail
  };
  Blocked blocked(const std::string& why, const Eigen::Isometry3d& camera, Fruit& fruit) const;

 private:
  ServoConfig cfg_;
  OrientationLaw law_;
  bool from_retreat_ = false;  // the turn under way began at the end of a retreat, not at home
};

}  // namespace harvest::servo
