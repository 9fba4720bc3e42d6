// harvest-calibrate plan hand-eye|extrinsics (docs/calibration.md): finds the
// board in the camera's live view with the arm at rest, plans the arm poses
// around it (calib/pose_plan.hpp), prints them, and with --run moves the arm
// through them via the robot link (calib/plan_runner.hpp) while the operator
// records; the calibration is then computed from the recording.
#pragma once

#include <iosfwd>
#include <string>

#include "calib/board.hpp"
#include "calib/plan_runner.hpp"
#include "calib/pose_plan.hpp"

namespace harvest::calib {

struct PlanRequest {
  std::string procedure;  // "hand-eye" or "extrinsics"
  std::string lcm_url, prefix;
  std::string image_channel;    // default: the procedure's camera
  std::string intrinsics_file;  // that camera's calibration
  std::string hand_eye_file;    // hand-eye: the current camera-in-hand estimate
  std::string extrinsic_file;   // extrinsics: the current fixed-camera estimate
  // The robot link's configuration, to check each pose's reachability before
  // moving and replace a pose it would refuse by a reachable variant (empty: no check).
  std::string robot_link_file = "config/arm/robot_link.yaml";
  BoardSpec board;
  HandEyePlan hand_eye;
  ExtrinsicsPlan extrinsics;
  PlanRunConfig run;  // poses filled in by the plan
  bool move = false;  // --run: move the arm; otherwise print the plan only
  double locate_timeout_s = 10.0;
  std::string key, sender = "servo-controller";
};

// 0: planned (and run to the end with --run); 1: the board was not found,
// the plan is degenerate, or the run stopped (the reason is printed).
int run_plan(const PlanRequest& request, std::ostream& out, std::ostream& err);

}  // namespace harvest::calib
