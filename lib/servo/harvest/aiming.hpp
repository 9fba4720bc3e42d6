// Where the gripper goes to see and reach a fruit: the pickable set, the
// fixed camera's line of sight through a target, the ORIENT goals (turn in
// place, eq. 6-19..6-22, or a viewpoint), the way back out of the canopy.
#pragma once

#include <Eigen/Geometry>
#include <optional>
#include <vector>

#include "harvest/targets_t.hpp"
#include "servo/harvest/fruit.hpp"
#include "servo/servo_config.hpp"

namespace harvest::servo {

// A position a fruit can be picked at: inside the workspace and
// min_ahead_of_home ahead of the gripper at home (every fruit is aimed at
// from there).
bool pickable(const ServoConfig& cfg, const Eigen::Vector3d& p);

// The pickable part of the fixed camera's line of sight through `t`;
// nullopt if the view carries no camera pose or no part is pickable.
std::optional<SightLine> sight_line(const ServoConfig& cfg, const targets_t& view, const target_t& t);

// Where to aim, from `from`, at a fruit somewhere on a sight line: the
// stretch of line the camera-in-hand sees at once (its narrower half field
// of view less sight_aim_margin, on each side), starting at parameter
// `s_start` (the end nearest the fixed camera's estimate), aimed at its
// middle direction. Returns a point of the line.
Eigen::Vector3d sight_aim(const ServoConfig& cfg, const SightLine& line, double s_start, const Eigen::Vector3d& from);

// ORIENT in place: the tool where it is, its axis turned to `target` (eq. 6-19..6-22).
Eigen::Isometry3d aim_in_place(const Eigen::Isometry3d& tool, const Eigen::Vector3d& target);

// ORIENT's goal for a fruit at `target` with the tool (at home) at `tool`:
// from its viewpoint if it lies more than max_aim_angle off the gripper axis
// or `from_viewpoint` asks for it (the turn in place was blocked), where
// there is one; else the turn in place. `from_viewpoint` says which.
struct OrientGoal {
  Eigen::Isometry3d goal = Eigen::Isometry3d::Identity();
  bool from_viewpoint = false;
};
OrientGoal orient_goal(const ServoConfig& cfg, const Eigen::Isometry3d& tool, const Eigen::Vector3d& target,
                       bool from_viewpoint);

// ORIENT from a viewpoint: view_distance short of `target`, along the home
// axis turned view_angle toward it, aimed at it; nullopt if viewpoints are
// off, the target is straight ahead, or the viewpoint lies outside the workspace.
std::optional<Eigen::Isometry3d> aim_from_viewpoint(const ServoConfig& cfg, const Eigen::Vector3d& target);

// The tool moved straight back along its axis, in its orientation: to
// abreast of `abreast_of` (if given) or by `at_least`, whichever is
// farther. The default way out: the palm retraces the way in as far as that
// way was straight along the final axis (back_toward when centring bent it).
Eigen::Isometry3d back_along_axis(const Eigen::Isometry3d& tool, const std::optional<Eigen::Vector3d>& abreast_of,
                                  double at_least);

// The tool moved straight back to `began` (where its way in began), in its
// orientation, or on along that line to `at_least` back, whichever is
// farther. Centring bends the way in near the fruit: the chord stays within
// that bend of it, where the axis line at the end passes up to the whole bend
// beside its start (by the simulator's truth over 30 tree runs the axis line
// passed the palm within a knock of a fruit on 13 of 1191 ways out, the chord
// on 5; yet the runs with it picked fewer: retrace_way_in, off, docs/demo.md).
// Along the axis (back_along_axis) when `began` is unknown, or not behind the
// tool.
Eigen::Isometry3d back_toward(const Eigen::Isometry3d& tool, const std::optional<Eigen::Vector3d>& began,
                              double at_least);

// The way out to `began` (RETREAT: where the approach began; BACKOFF: where IR guidance began): back_toward with
// `retrace` (retrace_way_in), else back_along_axis.
inline Eigen::Isometry3d way_back(const Eigen::Isometry3d& tool, const std::optional<Eigen::Vector3d>& began,
                                  double at_least, bool retrace) {
  return retrace ? back_toward(tool, began, at_least) : back_along_axis(tool, began, at_least);
}

// RETREAT's end when the way on is a straight line to `to` (the next aim
// from home, turning on the way): on the straight way from the tool to
// `farthest` (the full retreat: back_along_axis's or back_toward's goal),
// at least `at_least` back, then further in `step`s up to `farthest`, the
// first place from where that line, for the tool point and for the point
// `palm` behind it on the axis, passes at least `clearance` from every fruit
// in `fruit`. A fruit beside the way keeps the retreat going to `farthest`:
// the gripper leaves the canopy the way it came in.
Eigen::Isometry3d clear_retreat(const Eigen::Isometry3d& tool, const Eigen::Isometry3d& farthest, double at_least,
                                const Eigen::Isometry3d& to, const std::vector<Eigen::Vector3d>& fruit,
                                double clearance, double palm, double step = 0.02);

// The tool within `retreat_distance` of `home` is out of the canopy: the straight way home, or to an aim from
// home, crosses no fruit (a start there returns straight home; a turn to a viewpoint, or to the next fruit after
// one given up before going in, starts from there).
inline bool out_of_canopy(const Eigen::Isometry3d& home, double retreat_distance, const Eigen::Vector3d& tool) {
  return (tool - home.translation()).norm() <= retreat_distance;
}

// DETACH: the tool pulled `pull` back along its axis while turned `twist` about it.
Eigen::Isometry3d detach_goal(const Eigen::Isometry3d& tool, double pull, double twist);

// A goal outside the workspace pulled back along the straight line from
// `from` to the furthest point still inside (the goal itself if inside).
Eigen::Isometry3d inside_workspace(const Workspace& ws, const Eigen::Vector3d& from, const Eigen::Isometry3d& goal);

// `point` projects into the hand camera at `camera` with a margin of
// `margin` (a share of the image side) left on every side.
bool in_hand_view(const geometry::CameraModel& k, const Eigen::Isometry3d& camera, const Eigen::Vector3d& point,
                  double margin);

}  // namespace harvest::servo
