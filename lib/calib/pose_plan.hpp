// Arm poses for the two arm-moved calibrations (harvest-calibrate plan,
// docs/calibration.md): where the tool goes so that the camera sees the board
// from around it, tilted about both board axes and rolled, which is what
// cv::calibrateHandEye and cv::calibrateRobotWorldHandEye need (rotations about
// one axis leave the answer undetermined along it).
#pragma once

#include <Eigen/Geometry>
#include <functional>
#include <vector>

#include "calib/board.hpp"

namespace harvest::calib {

// The board in a proper camera frame: its centre at (ox, oy, depth) [m],
// turned by rx, ry, rz [deg] (about x, then y, then z) about its centre.
Eigen::Isometry3d board_facing_camera(const BoardSpec& board, double depth, double ox, double oy, double rx_deg,
                                      double ry_deg, double rz_deg);

// A variant of every pose of a plan, for a pose the arm cannot take: the
// same view direction (the tilt's axis, the board's place in the image) with
// the tilt scaled, the roll scaled (-1: turned the other way) and the
// distance changed, so the plan keeps its coverage of rotation axes and of
// the image.
struct PoseVariant {
  double tilt_scale = 1.0, roll_scale = 1.0;
  double distance_change_m = 0.0;
};
// The variants tried in turn after the nominal plan: the roll the other way,
// then smaller tilts, then nearer and farther.
const std::vector<PoseVariant>& fallback_variants();

// Hand-eye: the board stands still, the hand camera looks at it from a ring
// of directions around its normal.
struct HandEyePlan {
  int poses = 12;
  double distance_m = 0.45;     // camera to board centre at the nearest pose
  double depth_step_m = 0.015;  // distance grows by this from pose to pose, in cycles of five
  double offset_m = 0.03;       // board centre off the optical axis
  double tilt_deg = 25.0;       // view direction off the board normal (about both board axes around the ring)
  double roll_deg = 15.0;       // about the optical axis
};
// Tool poses in the base frame; `camera_in_tool` is the current hand-eye
// estimate (the camera frame must be proper).
std::vector<Eigen::Isometry3d> plan_hand_eye(const Eigen::Isometry3d& board_in_base, const BoardSpec& board,
                                             const Eigen::Isometry3d& camera_in_tool, const HandEyePlan& plan = {},
                                             const PoseVariant& variant = {});

// Extrinsics: the board carried by the tool is shown to the fixed camera
// across a 3 x 3 grid of its image, tilted about different axes.
struct ExtrinsicsPlan {
  double distance_m = 0.6;                     // camera to board centre at the nearest pose
  double depth_step_m = 0.05;                  // in cycles of three
  double spread_x_m = 0.1, spread_y_m = 0.08;  // grid offsets from the optical axis at that distance
  double tilt_deg = 25.0;                      // alternately +tilt and -0.8 tilt about each board axis
  double roll_step_deg = 10.0;                 // roll -1.5, -0.5, 0.5, 1.5 steps in turn
};
// Tool poses in the base frame; `camera_in_base` is the current extrinsic
// estimate (improper for the thesis's fixed camera frame: the board is then
// placed in its proper mirror twin), `board_in_tool` where the board is
// clamped on the tool.
std::vector<Eigen::Isometry3d> plan_extrinsics(const Eigen::Isometry3d& camera_in_base, const BoardSpec& board,
                                               const Eigen::Isometry3d& board_in_tool, const ExtrinsicsPlan& plan = {},
                                               const PoseVariant& variant = {});

// Each pose of a plan, or the first of its fallback variants `reachable`
// takes (called once per candidate, pose after pose, in the order of the
// plan: it may keep state, e.g. the arm's joints after the poses taken).
// `make` gives the whole plan in a variant. A pose with no reachable variant
// keeps its nominal form and variant -1 (the run will skip it).
struct ReachablePlan {
  std::vector<Eigen::Isometry3d> poses;
  std::vector<int> variant;  // per pose: 0 nominal, k the (k-1)th fallback variant, -1 none reachable
  int held() const;          // poses with a reachable form
  int nominal() const;       // of them, in their nominal form
};
ReachablePlan choose_reachable(const std::function<std::vector<Eigen::Isometry3d>(const PoseVariant&)>& make,
                               const std::function<bool(const Eigen::Isometry3d&)>& reachable);

// The proper frame of a camera frame: itself, or its mirror twin (x flipped)
// when the frame is improper (determinant -1, the thesis's fixed camera).
Eigen::Isometry3d proper_twin(const Eigen::Isometry3d& camera);

}  // namespace harvest::calib
