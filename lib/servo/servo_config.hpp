// Configuration of the servo controller (config/servo/controller.yaml).
// Lengths in metres, angles in radians, times in seconds, unless a key says
// otherwise. Every key has a default taken from the thesis where it gives one.
#pragma once

#include <Eigen/Geometry>
#include <array>
#include <string>

#include "config/config.hpp"
#include "geometry/camera_model.hpp"

namespace harvest::servo {

// The hand camera before a calibration is loaded (ServoConfig{} in unit
// tests); from_yaml() replaces it with geometry::CameraModel::load(), the one
// loader every process uses.
inline const geometry::CameraModel kDefaultHandCamera{833.57, 767.02, 0.0, 319.5, 239.5, {}, 640, 480};

// Axis-aligned box in the base frame plus a reach shell around the base
// origin: a commanded motion never leaves it, a target outside is skipped.
struct Workspace {
  Eigen::Vector3d min{-0.9, 0.3, -1.0};
  Eigen::Vector3d max{0.7, 1.3, 0.3};
  double min_reach = 0.3;
  double max_reach = 1.5;
  bool contains(const Eigen::Vector3d& p, double margin = 0.0) const;
};

struct Gains {
  double kp_lateral = 2.0;         // [1/s] on the metric centring error (eq. 6-25, 6-26)
  double kd_lateral = 0.05;        // [s]
  double kp_depth = 1.0;           // [1/s] on the depth error (eq. 6-27)
  double kd_depth = 0.0;           // [s]
  double derivative_filter = 0.5;  // low-pass weight of the newest error derivative, 0..1
  // [m] advance no faster than the centring can bring the fruit within this
  // of the gripper axis by the time the gripper gets there (0: no bound)
  double centring_tolerance = 0.005;
  // [s] under IR guidance, centre on the fruit's mean position over this long
  // (0: on its newest position). A fruit swaying in the wind keeps moving
  // during the gripper's blind close: from its mean it is at most one sway
  // amplitude away when the fingers meet, from where it was last seen up to
  // nearly two.
  double sway_window = 2.5;
  // orient_law thesis_pd: omega = kp_orient e + kd_orient de/dt on the angles of eq. 6-19, 6-20, 6-23 (eq. 6-24)
  double kp_orient = 2.0;   // [1/s]
  double kd_orient = 0.05;  // [s]
};

struct Timeouts {
  double select = 3.0;        // wait for a fresh fixed-camera view
  double motion = 20.0;       // any pose-goal motion (orient, detach, drop, return, home)
  double stall = 2.0;         // a pose-goal motion that gets no closer to its goal this long is blocked
  double acquire = 3.0;       // fruit must appear in the hand camera after orienting
  double lost = 0.3;          // no hand measurement this long -> hold and re-acquire
  double reacquire = 2.0;     // ... and give the fruit up (LOST) after this long
  double approach = 30.0;     // whole visual approach
  double ir_approach = 8.0;   // one IR-guided attempt
  double grasp = 3.0;         // gripper must report holding / closed
  double release = 3.0;       // gripper must report open
  double robot_state = 0.25;  // robot state watchdog while running
  double ir_stale = 0.3;      // IR reading older than this: do not advance
};

struct ServoConfig {
  double tick_period_s = 0.02;        // command rate (50 Hz)
  double status_period_s = 1.0;       // periodic HARVEST_STATUS
  double validity_s = 0.1;            // validity window of every robot command
  // From the robot's envelope (config/arm/envelope.yaml); the defaults are its values.
  double max_linear_speed = 0.381;    // [m/s] thesis 15 in/s
  double max_angular_speed = 1.5708;  // [rad/s] thesis: PID2 (pi/2) in HarvestStep4/5
  double max_linear_accel = 1.0;      // [m/s^2]
  double max_angular_accel = 3.0;     // [rad/s^2]

  double ir_switch_distance = 0.4572;  // [m] thesis 18 in: switch to IR guidance
  double ir_approach_speed = 0.381;    // [m/s] fastest forward speed under IR guidance ...
  double ir_braking_decel = 0.8;       // [m/s^2] ... braking so it would stop at the grasp range ...
  double ir_min_speed = 0.04;          // [m/s] ... but never below this
  double ir_grasp_range = 0.015;       // [m] IR range at or below which the fruit is inside
  double ir_max_travel = 0.6;          // [m] beyond the switch point before backing off
  double ir_overshoot = 0.05;          // [m] ... or past the estimated fruit centre by this much
  // [m] > 0: an IR grasp reading counts only with the triangulated fruit
  // centre no farther ahead (a leaf in front of it); 0: off
  double ir_vision_agreement = 0.07;
  // [m] a fruit in front of the one aimed at, filling the hand image when the
  // IR reads the grasp range, is closed on only with its centre this near the
  // gripper axis; farther off, the attempt is given up (it would be knocked off)
  double front_fruit_tolerance = 0.015;
  // [m] the arm goes on this far along the tool axis (at ir_min_speed) while
  // the gripper closes, then stops (0: stops at once, as the thesis does)
  double grasp_advance = 0.015;
  // A reading within ir_fold_near above the grasp range followed by one
  // ir_fold_jump farther is the sensor folding back (the fruit is inside).
  double ir_fold_near = 0.02;         // [m]
  double ir_fold_jump = 0.03;         // [m]
  double ir_progress_step = 0.005;    // [m] under IR guidance, less tool motion than this for timeouts.stall: blocked
  int ir_attempts = 2;                // IR approaches per fruit (thesis: retry once)
  double orient_tolerance = 0.02;     // [rad] orientation reached
  double position_tolerance = 0.005;  // [m] pose goal reached
  double retreat_distance = 0.15;     // [m] pull back along the tool axis after a failure
  double pull_distance = 0.10;        // [m] detach: pull back along the tool axis ...
  double twist_angle = 0.5236;        // [rad] ... while twisting about it
  bool release_at_detach = true;      // open the gripper where the pull ended (false: carry it to drop_pose first)
  int max_attempts_per_fruit = 2;     // attempts per fruit in total; a failed one is retried after every untried one
  double association_gate_px = 80.0;  // hand detection must lie this close to the predicted pixel
  double min_ahead_of_home = 0.05;    // [m] a target must lie this far ahead of the tool at home, along its axis
  // A fruit more than max_aim_angle off the gripper axis at home, or one the
  // arm cannot turn to there, is aimed at from a viewpoint view_distance
  // short of it, the home axis turned view_angle toward it: the arm has no
  // joint solution for a wide turn at home.
  double max_aim_angle = 1.15;  // [rad]
  double view_angle = 0.5;      // [rad] 0: always aim from home (the thesis)
  double view_distance = 0.5;   // [m]
  // The camera-in-hand's ray through the fruit crossed with the fixed
  // camera's gives its position without the apparent size, which a leaf
  // cutting the fruit falsifies. Used when the rays pass within
  // triangulation_gap and cross at min_triangulation_angle or more;
  // triangulation_gap 0: the size alone (the thesis's eq. 6-15).
  double triangulation_gap = 0.06;       // [m]
  double min_triangulation_angle = 0.2;  // [rad]
  double same_fruit_distance = 0.05;     // [m] a fixed-camera target this close to a given-up one is that fruit
  double same_sight_angle = 0.02;        // [rad] ... or, with a doubtful depth, its line of sight this close to one
  double reused_id_distance = 0.15;      // [m] a finished id seen this far from where it finished is another fruit
  // A size-based hand estimate agrees with the rays' crossing within
  // size_agreement of the range (at least size_agreement_min): the hand
  // depth's own error is about 10 % rms, a leaf-cut fruit's a factor of 1.5.
  double size_agreement = 0.3;
  double size_agreement_min = 0.1;  // [m]
  // A hand detection at least fills_view of the image height fills the view:
  // no depth from its size; and, front_fruit_size_ratio times the size the
  // current fruit should have and covering the image centre, it is a nearer
  // fruit in front of it.
  double fills_view = 0.8;
  double front_fruit_size_ratio = 1.5;
  int whole_fruit_border_px = 2;  // [px] a detection this near the image border is cut by it: no depth from its size
  // A pose-goal motion progresses by getting goal_progress_step or
  // goal_progress_angle nearer its goal (timeouts.stall without: blocked).
  double goal_progress_step = 0.002;  // [m]
  double goal_progress_angle = 0.01;  // [rad]
  // An ORIENT blocked with the estimate this far (share of each image side)
  // inside the hand image goes on to ACQUIRE from where it stopped.
  double in_view_margin = 0.2;
  double sight_aim_margin = 0.07;  // [rad] aiming along a line of sight: the hand camera's half field of view less this

  Eigen::Isometry3d home_pose = Eigen::Isometry3d::Identity();
  Eigen::Isometry3d drop_pose = Eigen::Isometry3d::Identity();
  Workspace workspace;
  Gains gains;
  Timeouts timeouts;
  geometry::CameraModel hand_camera = kDefaultHandCamera;
  std::string approach_mode = "reconstruction";  // pluggable approach strategy (approach.hpp)
  // approach_mode tbz (servo/tbz_approach.hpp, docs/teach-by-zooming.md).
  struct Tbz {
    double lambda_w = 2.0;                 // [1/s] rotation gain (eq. 5-44)
    double lambda_v = 0.25;                // translation gain (eq. 5-62)
    double desired_depth_estimate = 0.25;  // [m] Z*_1 hat: the sticker's depth at the goal, roughly
    double max_match_age_s = 0.3;          // older FEATURE_MATCHES are not steered by
    double fallback_after_s = 1.5;         // no usable matches this long: 3D-reconstruction approach for the fruit
    double arrived_rotation = 0.0175;      // [rad] |e_w| at or below this ...
    double arrived_translation = 0.01;     // ... and |e_v| at or below this: at the goal, IR guidance from there
  } tbz;
  // ORIENT in place: "pose_goal" (a pose goal the robot link runs along a
  // smooth path) or "thesis_pd" (the thesis's PD law on the aim angles,
  // eq. 6-24, as tool twists, also holding the roll about the gripper axis
  // at the home pose's). Viewpoints are always reached by a pose goal.
  std::string orient_law = "pose_goal";

  // Reads the `servo` section layout documented in docs/servo-controller.md.
  // Throws config::Error (bad value, home/drop pose outside the workspace).
  static ServoConfig from_yaml(const config::Node& node);
};

}  // namespace harvest::servo
