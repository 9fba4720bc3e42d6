// The robot link's active motion: exactly one of these at a time. Each knows
// what it needs (the goal's id for "same goal, refreshed", a trajectory and
// when it started); the node turns the active one into joint velocities.
#pragma once

#include <cstdint>
#include <harvest/robot_command_t.hpp>
#include <optional>
#include <variant>

#include "arm/motion_safety.hpp"
#include "arm/pose_goal_planner.hpp"
#include "arm/trajectory.hpp"
#include "kinematics/chain.hpp"

namespace harvest::arm {

struct NoMotion {};  // at rest, or ramping to rest

struct TwistMotion {
  kinematics::Twist twist;
};

// A pose goal on its straight Cartesian path.
struct CartesianMotion {
  CartesianTrajectory path;
  Micros start = 0;
  int64_t goal_id = 0;
};

// A new pose goal being planned (PoseGoalPlanner, a slice per period) while the arm holds.
struct PlanningMotion {
  harvest::robot_command_t cmd;  // refused with this command if unreachable
  PoseGoalPlanner planner;
};

// A joint goal, or a pose goal executed in joint space.
struct JointMotion {
  JointTrajectory path;
  Micros start = 0;
  int64_t goal_id = 0;
  bool pose_goal = false;
};

using Motion = std::variant<NoMotion, TwistMotion, CartesianMotion, PlanningMotion, JointMotion>;

// The id of the pose goal the motion is for (planned, Cartesian or in joint space), if any.
inline std::optional<int64_t> pose_goal_id(const Motion& m) {
  if (const auto* c = std::get_if<CartesianMotion>(&m)) return c->goal_id;
  if (const auto* p = std::get_if<PlanningMotion>(&m)) return p->cmd.goal_id;
  if (const auto* j = std::get_if<JointMotion>(&m); j && j->pose_goal) return j->goal_id;
  return std::nullopt;
}

// The id of the joint goal the motion is for, if any.
inline std::optional<int64_t> joint_goal_id(const Motion& m) {
  if (const auto* j = std::get_if<JointMotion>(&m); j && !j->pose_goal) return j->goal_id;
  return std::nullopt;
}

}  // namespace harvest::arm
