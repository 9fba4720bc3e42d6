// What the controller knows about the fruit it is after.
#pragma once

#include <Eigen/Geometry>
#include <optional>

#include "runtime/clock.hpp"

namespace harvest::servo {

// The part of the fixed camera's line of sight through a target where a
// fruit we could pick may lie (inside the workspace, ahead of the gripper
// at home): origin + s * direction for s in [near, far].
struct SightLine {
  Eigen::Vector3d origin = Eigen::Vector3d::Zero();
  Eigen::Vector3d direction = Eigen::Vector3d::UnitZ();
  double near = 0.0, far = 0.0;
  Eigen::Vector3d at(double s) const { return origin + s * direction; }
};

struct Fruit {
  int id = -1;
  Eigen::Vector3d estimate = Eigen::Vector3d::Zero();  // base frame, best so far
  rt::Micros selected_at = 0;
  Eigen::Vector3d selected_from = Eigen::Vector3d::Zero();  // the fixed camera's estimate when selected
  std::optional<SightLine> sight;                           // where the fixed camera saw it
  // The fixed camera's depth put it where no fruit can be picked (a piece
  // of a fruit seen as a small, far one; fruit seen together as one large,
  // near one): aimed at its line of sight instead, until the camera-in-hand
  // measures it.
  bool depth_doubtful = false;
  bool from_viewpoint = false;  // ORIENT goes to the viewpoint (the turn at home is too wide or was blocked)
  double diameter = 0.07;       // [m] the diameter the fixed camera assumed (the statistical size)
  // Where the estimate's depth comes from: the apparent size alone, the
  // size confirmed by where the two cameras' rays cross, that crossing
  // (the size disagreed with it far from the fruit: a leaf cutting the fruit),
  // the size near the fruit where a disagreeing crossing was set aside
  // (ServoConfig::crossing_beyond), or the fixed camera's estimate along the
  // hand's ray (the hand's size put it outside the workspace, the rays too
  // parallel to cross).
  enum class Depth { kSize, kConfirmed, kCrossing, kNear, kFixed } depth = Depth::kSize;
};

}  // namespace harvest::servo
