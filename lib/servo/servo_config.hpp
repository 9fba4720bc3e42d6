// Configuration of the servo controller (config/servo/controller.yaml).
// Lengths in metres, angles in radians, times in seconds, unless a key says
// otherwise. Every key has a default taken from the thesis where it gives one.
#pragma once

#include <Eigen/Geometry>
#include <array>
#include <string>
#include <vector>

#include "config/config.hpp"
#include "config/schema.hpp"
#include "geometry/camera_model.hpp"

namespace harvest::servo {

// The hand camera before a calibration is loaded (ServoConfig{} in unit
// tests); from_yaml() replaces it with geometry::CameraModel::load(), the one
// loader every process uses.
inline const geometry::CameraModel kDefaultHandCamera{833.57, 767.02, 0.0, 319.5, 239.5, {}, 640, 480};

// The keys of config/servo/controller.yaml, per mapping (docs/configuration.md).
namespace servo_keys {
using config::Key;
using config::Numbers;
inline constexpr Key<double> tick_period_s{"tick_period_s", 0.02, {0.001, 0.5}, "s", "command period (50 Hz)"};
inline constexpr Key<double> status_period_s{"status_period_s", 1.0, {0.05, 60.0}, "s", "period of HARVEST_STATUS"};
inline constexpr Key<double> validity_s{"validity_s", 0.1, {0.01, 2.0}, "s", "validity window of every robot command"};
inline constexpr Key<double> ir_switch_distance{"ir_switch_distance", 0.4572, {1e-6, 1e6}, "m", "switch to IR guidance this far from the fruit (thesis: 18 in)"};
inline constexpr Key<double> ir_approach_speed{"ir_approach_speed", 0.381, {1e-6, 1e6}, "m/s", "fastest forward speed under IR guidance (at most the envelope's speed)"};
inline constexpr Key<double> ir_braking_decel{"ir_braking_decel", 0.8, {1e-6, 1e6}, "m/s^2", "braking so the tool would stop at the grasp range (at most the envelope's acceleration)"};
inline constexpr Key<double> ir_min_speed{"ir_min_speed", 0.04, {1e-6, 1e6}, "m/s", "but never slower than this (at most ir_approach_speed)"};
inline constexpr Key<double> ir_grasp_range{"ir_grasp_range", 0.015, {1e-6, 1e6}, "m", "IR range at or below which the fruit is inside the gripper"};
inline constexpr Key<double> ir_max_travel{"ir_max_travel", 0.6, {1e-6, 1e6}, "m", "travel beyond the switch point before backing off"};
inline constexpr Key<double> ir_overshoot{"ir_overshoot", 0.05, {0.0, 1e6}, "m", "or past the estimated fruit centre by this much"};
inline constexpr Key<double> ir_surface_reach{"ir_surface_reach", 0.12, {0.0, 1.0}, "m", "... or by this much more while the IR reads a surface that stays put ahead (0: off)"};
inline constexpr Key<double> ir_surface_travel{"ir_surface_travel", 0.03, {1e-3, 1.0}, "m", "the IR reads a surface that stays put once the tool has come this far toward it ..."};
inline constexpr Key<double> ir_surface_tolerance{"ir_surface_tolerance", 0.02, {1e-3, 0.2}, "m", "... its readings plus the tool's advance agreeing within this"};
inline constexpr Key<double> ir_vision_agreement{"ir_vision_agreement", 0.05, {0.0, 1e6}, "m", "an IR grasp reading counts only with the triangulated centre no farther ahead (0: off)"};
inline constexpr Key<double> ir_split_close{"ir_split_close", 0.0, {0.0, 0.2}, "m", "an IR grasp reading while a checked estimate lies between ir_vision_agreement and this far ahead: leaf or fruit, go on half the gap between them and close there (0: off, a leaf)"};
inline constexpr Key<double> ir_split_max{"ir_split_max", 0.02, {0.0, 0.1}, "m", "... but no farther than this: farther, the palm runs into a fruit the IR read"};
inline constexpr Key<double> front_fruit_tolerance{"front_fruit_tolerance", 0.015, {0.0, 1e6}, "m", "a fruit in front filling the view is closed on only this near the gripper axis"};
inline constexpr Key<bool> grasp_stop_at_joint_limit{"grasp_stop_at_joint_limit", true, {}, "", "a joint held at its limit (ROBOT_STATE kFlagJointLimit) as the gripper closes stops grasp_advance there: the link clips the twist and the tool goes sideways"};
inline constexpr Key<double> grasp_advance{"grasp_advance", 0.015, {0.0, 0.05}, "m", "the arm goes on this far along the tool axis while the gripper closes"};
inline constexpr Key<double> ir_fold_near{"ir_fold_near", 0.02, {0.0, 0.5}, "m", "a reading this near above the grasp range ..."};
inline constexpr Key<double> ir_fold_jump{"ir_fold_jump", 0.03, {1e-3, 1.0}, "m", "... then one this much farther: the sensor folded back (fruit inside)"};
inline constexpr Key<double> ir_progress_step{"ir_progress_step", 0.005, {1e-4, 0.1}, "m", "under IR guidance, less tool motion than this for timeouts_s.stall: blocked"};
inline constexpr Key<int> ir_attempts{"ir_attempts", 2, {1, 10}, "", "IR approaches per fruit (thesis: retry once)"};
inline constexpr Key<double> orient_tolerance{"orient_tolerance", 0.02, {1e-6, 1e6}, "rad", "orientation reached"};
inline constexpr Key<double> position_tolerance{"position_tolerance", 0.005, {1e-6, 1e6}, "m", "pose goal reached"};
inline constexpr Key<double> retreat_distance{"retreat_distance", 0.15, {0.0, 1e6}, "m", "pull back along the tool axis after a failure"};
inline constexpr Key<double> gone_in_distance{"gone_in_distance", 0.075, {0.0, 1e6}, "m", "a fruit the camera-in-hand measures outside the workspace during APPROACH, with the tool farther than this from home: it has gone into the canopy and backs out along its axis first"};
inline constexpr Key<double> retreat_clearance{"retreat_clearance", 0.0, {0.0, 1.0}, "m", "> 0 (e.g. 0.12): a retreat followed by the straight way to the next aim ends where that way passes this far from every fruit the fixed camera sees (0: always abreast of where the approach began; 0.12 picked fewer on four tree seeds, docs/demo.md)"};
inline constexpr Key<bool> retrace_way_in{"retrace_way_in", false, {}, "", "the way out after a close (RETREAT, and BACKOFF before a retry) goes straight back to where the way in began (the approach's start; the IR approach's for BACKOFF), not along the tool axis, which centring near the fruit sets beside the way in (tried: fewer ways out past a neighbour, but fewer fruit picked over 15 tree seeds; off, docs/demo.md)"};
inline constexpr Key<double> palm_offset{"palm_offset", 0.05, {0.0, 0.5}, "m", "the palm (IR sensor) this far behind the tool point along its axis: the gripper's body that retreat_clearance keeps clear too"};
inline constexpr Key<double> pull_distance{"pull_distance", 0.10, {0.0, 1e6}, "m", "detach: pull back along the tool axis ..."};
inline constexpr Key<double> twist_angle{"twist_angle", 0.5236, {-6.3, 6.3}, "rad", "... while twisting about it"};
inline constexpr Key<bool> release_at_detach{"release_at_detach", true, {}, "", "open the gripper where the pull ended (false: carry the fruit to drop_pose first)"};
inline constexpr Key<bool> release_while_retreating{"release_while_retreating", true, {}, "", "... and with release_at_detach, the gripper opens as the retreat begins, the fruit counted picked then (it is off the tree, in the hand); it must report open within timeouts_s.release or the controller faults (false: RELEASE at rest first)"};
inline constexpr Key<bool> turn_while_retreating{"turn_while_retreating", true, {}, "", "with straight_to_next: the way out after a fruit (a pick's pull and retreat, a failure's retreat) also turns the gripper to the aim from home of the fruit SELECT would choose at its end (the one under way counted done), so ORIENT there has only the rest to do; not toward a viewpoint; the selection at the end decides as before"};
inline constexpr Key<bool> turn_in_wind{"turn_in_wind", false, {}, "", "... also while the fixed camera's gauge does not say the tree is still (sway.tree_*): in wind the turn picked fewer in each of three comparisons (195 against 198 of 223 counted over eight tree_wind seeds; 194 against 200.5 and 198 against 200 of 226 earlier), each within the 7 fruit two runs of one configuration differed by (docs/demo.md); by default the way out turns only on a still tree"};
inline constexpr Key<double> turn_ahead_home_within{"turn_ahead_home_within", 0.1, {0.0, 1.0}, "m", "... and a way out that turns so and would end this near home's position ends there, where ORIENT would go next (the last part of the line home is out of the canopy; 0: abreast of where the approach began, as without it)"};
inline constexpr Key<bool> pull_through{"pull_through", true, {}, "", "... and the pull and the retreat are one motion: the arm does not stop where the pull ends, the gripper opens once the tool has come pull_distance back (the twist spread over the whole way out; false: pull, stop, retreat)"};
inline constexpr Key<bool> straight_to_next{"straight_to_next", true, {}, "", "select the next fruit at the end of a retreat and turn to it from there (false: home first, the thesis)"};
inline constexpr Key<bool> home_after_joint_limit{"home_after_joint_limit", true, {}, "", "after an approach during which the robot link reported a joint at its position limit, go home before the next fruit (the way home resets the arm's posture)"};
inline constexpr Key<double> release_opening{"release_opening", 0.5, {0.0, 1.0}, "", "share of the full opening at which the fruit is let go and RELEASE ends (1: wait for OPEN)"};
inline constexpr Key<int> max_attempts_per_fruit{"max_attempts_per_fruit", 2, {1, 10}, "", "attempts per fruit in all; a failed one is retried after every untried one"};
inline constexpr Key<double> association_gate_px{"association_gate_px", 80.0, {1e-6, 1e6}, "px", "a hand detection must lie this close to the predicted pixel"};
inline constexpr Key<double> association_tie_weight{"association_tie_weight", 0.25, {0.0, 10.0}, "", "among hand detections near the image of the fixed camera's line of sight, the weight of their distance to the predicted pixel beside their distance to the line"};
inline constexpr Key<double> association_tie_weight_doubtful{"association_tie_weight_doubtful", 0.01, {0.0, 10.0}, "", "... while the fixed camera's depth is doubtful (its predicted point means little)"};
inline constexpr Key<double> association_size_ratio{"association_size_ratio", 0.0, {0.0, 100.0}, "", "> 0 (e.g. 1.6): while following a hand detection, the next one's apparent diameter within this factor of its, grown by how far the camera came toward the estimate since (a piece of the fruit, or a nearer fruit merged with it, is not it; 0: off: 1.35 picked fewer on eight wind seeds, docs/demo.md)"};
inline constexpr Key<double> min_ahead_of_home{"min_ahead_of_home", 0.05, {-10.0, 10.0}, "m", "a target must lie this far ahead of the tool at home, along its axis"};
inline constexpr Key<double> max_aim_angle{"max_aim_angle", 1.15, {0.0, 1.6}, "rad", "a fruit farther off the gripper axis at home is aimed at from a viewpoint"};
inline constexpr Key<double> view_angle{"view_angle", 0.5, {0.0, 1.5}, "rad", "the viewpoint turns the home axis this far toward the fruit (0: always aim from home)"};
inline constexpr Key<double> view_distance{"view_distance", 0.5, {0.1, 1.5}, "m", "the viewpoint lies this far short of the fruit"};
inline constexpr Key<double> triangulation_gap{"triangulation_gap", 0.06, {0.0, 0.5}, "m", "the hand and fixed cameras' rays crossing within this give the position (0: size only)"};
inline constexpr Key<double> image_pose_gap{"image_pose_gap", 0.0, {0.0, 1.0}, "s", "> 0: a hand image is seen from the camera pose at its capture time, interpolated between robot states at most this far apart (0: the newest pose; off until the tree_wind loss is understood, docs/servo-controller.md)"};
inline constexpr Key<double> min_triangulation_angle{"min_triangulation_angle", 0.2, {0.01, 1.5}, "rad", "... when they cross at this angle or more"};
inline constexpr Key<double> same_fruit_distance{"same_fruit_distance", 0.05, {0.0, 1e6}, "m", "a fixed-camera target this close to a given-up one is that fruit"};
inline constexpr Key<double> same_sight_angle{"same_sight_angle", 0.02, {0.0, 0.5}, "rad", "or, with a doubtful depth, its line of sight this close to one"};
inline constexpr Key<double> reused_id_distance{"reused_id_distance", 0.15, {0.0, 1e6}, "m", "a finished id seen this far from where it finished is another fruit"};
inline constexpr Key<double> size_agreement{"size_agreement", 0.3, {0.0, 10.0}, "", "a size-based hand estimate agrees with the rays' crossing within this share of the range ..."};
inline constexpr Key<double> size_agreement_min{"size_agreement_min", 0.1, {0.0, 10.0}, "m", "... or at least this"};
inline constexpr Key<double> crossing_beyond{"crossing_beyond", 0.7, {0.0, 10.0}, "m", "... and a crossing that disagrees replaces the size only where the size puts the fruit at least this far from the hand camera; nearer, the size stays, unconfirmed (0: at any range; seven tree runs: of the crossings that replaced a size nearer than 0.55 m, 1-13 % were the nearer to the truth, beyond 0.9 m 99 %; docs/servo-controller.md)"};
inline constexpr Key<double> fixed_depth_gap{"fixed_depth_gap", 0.0, {0.0, 0.5}, "m", "> 0 (e.g. 0.06): a size-based hand estimate outside the workspace: the point of the hand's ray nearest the fixed camera's estimate instead, if the ray passes this near it and the point is inside (0: off, the attempt is given up; 0.06 picked fewer on ten tree seeds, docs/demo.md)"};
inline constexpr Key<double> fills_view{"fills_view", 0.8, {0.1, 1.0}, "", "a hand detection this share of the image height fills the view: no depth from its size"};
inline constexpr Key<double> far_view_ahead{"far_view_ahead", 0.10, {0.0, 1e6}, "m", "an IR grasp reading while the followed fruit is seen whole in a fresh hand image and its estimate lies this far ahead of the tool point or more, whatever the depth's source, is a leaf in front of it (0: off)"};
inline constexpr Key<double> axis_fruit_area{"axis_fruit_area", 0.6, {0.0, 1.0}, "", "an IR grasp reading while a hand detection covers the image centre and at least this share of its area (in an image no older than far_view_age) is a fruit, never passed as a leaf, whatever the estimate says (0: off)"};
inline constexpr Key<double> far_view_age{"far_view_age", 0.15, {0.0, 1.0}, "s", "... a hand image no older than this (the estimate then has a current depth; a swaying fruit moves little meanwhile)"};
inline constexpr Key<double> front_fruit_size_ratio{"front_fruit_size_ratio", 1.5, {1.0, 10.0}, "", "this many times the current fruit's size, covering the image centre: a nearer fruit in front"};
inline constexpr Key<int> whole_fruit_border_px{"whole_fruit_border_px", 2, {0, 100}, "px", "a detection this near the image border is cut by it: no depth from its size"};
inline constexpr Key<double> whole_min_visible{"whole_min_visible", 0.0, {0.0, 1.0}, "", "> 0: a hand detection whose visible fraction is below this is a piece of a fruit, not whole: no depth from its size (0: off; the learned detector sizes the piece it sees, docs/perception.md)"};
inline constexpr Key<double> goal_progress_step{"goal_progress_step", 0.002, {1e-5, 0.1}, "m", "a pose-goal motion progresses by getting this much nearer (timeouts_s.stall without: blocked) ..."};
inline constexpr Key<double> goal_progress_angle{"goal_progress_angle", 0.01, {1e-5, 0.5}, "rad", "... or this much"};
inline constexpr Key<double> goal_progress_joint_speed{"goal_progress_joint_speed", 0.02, {0.0, 10.0}, "rad/s", "... or, on the way home (RETURN, HOMING), while a joint turns faster than this (the joint-space way to the home posture swings the elbow about a tool that stays put; 0: the tool only)"};
inline constexpr Key<double> in_view_margin{"in_view_margin", 0.2, {0.0, 0.49}, "", "an ORIENT blocked with the estimate this far (share of each side) inside the hand image goes on to ACQUIRE"};
inline constexpr Key<double> sight_aim_margin{"sight_aim_margin", 0.07, {0.0, 0.5}, "rad", "aiming along a line of sight: the hand camera's half field of view less this"};
inline constexpr config::Choice approach_mode{"approach_mode", "reconstruction", {"reconstruction", "tbz"}, "approach strategy (approach.hpp)"};
inline constexpr config::Choice fruit_order{"fruit_order", "travel", {"cost", "travel"}, "among fruit of equal standing, the shortest turn from the tool first, or the detector's lowest cost (the thesis)"};
inline constexpr config::Choice orient_law{"orient_law", "pose_goal", {"pose_goal", "thesis_pd"}, "ORIENT in place: a pose goal the link runs, or the thesis PD law on the aim angles (eq. 6-24)"};
inline constexpr Key<config::Path> envelope{"envelope", "config/arm/envelope.yaml", {}, "", "the robot envelope (speed and acceleration limits, the box the workspace must lie in)"};
inline constexpr Key<config::Path> hand_camera_calibration{"hand_camera_calibration", "config/cameras/hand.yaml", {}, "", "the hand camera's intrinsic calibration"};
namespace workspace {
inline constexpr Numbers min{"min", 3, {-0.9, 0.3, -1.0}, "m", "box in the base frame the tool never leaves: lower corner (inside the envelope's)"};
inline constexpr Numbers max{"max", 3, {0.7, 1.3, 0.3}, "m", "upper corner, greater than min"};
inline constexpr Key<double> min_reach{"min_reach", 0.3, {0.0, 1e6}, "m", "reach shell around the base origin: inner radius"};
inline constexpr Key<double> max_reach{"max_reach", 1.5, {1e-6, 1e6}, "m", "outer radius (greater than min_reach)"};
}  // namespace workspace
namespace pose {
inline constexpr Numbers home_position{"position", 3, {-0.655, 0.785, -0.251}, "m", "home: the thesis experiment I start pose (table 6-5), inside the workspace"};
inline constexpr Numbers home_orientation{"orientation_wxyz", 4, {0.5, -0.5, -0.5, -0.5}, "", "unit quaternion (w, x, y, z): gripper axis along base +y"};
inline constexpr Numbers drop_position{"position", 3, {-0.5, 0.72, -0.25}, "m", "where fruit is dropped, inside the workspace"};
inline constexpr Numbers drop_orientation{"orientation_wxyz", 4, {0.5, -0.5, -0.5, -0.5}, "", "unit quaternion (w, x, y, z)"};
}  // namespace pose
namespace gains {
inline constexpr Key<double> kp_lateral{"kp_lateral", 2.0, {0.0, 1e6}, "1/s", "gain on the metric centring error (eq. 6-25, 6-26)"};
inline constexpr Key<double> kd_lateral{"kd_lateral", 0.05, {0.0, 1e6}, "s", "its derivative gain"};
inline constexpr Key<double> kp_depth{"kp_depth", 1.0, {0.0, 1e6}, "1/s", "gain on the depth error (eq. 6-27)"};
inline constexpr Key<double> kd_depth{"kd_depth", 0.0, {0.0, 1e6}, "s", "its derivative gain"};
inline constexpr Key<double> derivative_filter{"derivative_filter", 0.5, {0.0, 1.0}, "", "low-pass weight of the newest error derivative"};
inline constexpr Key<double> centring_tolerance{"centring_tolerance", 0.005, {0.0, 1e6}, "m", "advance no faster than the centring brings the fruit within this of the gripper axis (0: no bound)"};
inline constexpr Key<double> sway_window{"sway_window", 2.5, {0.0, 1e6}, "s", "under IR guidance, centre on the fruit's mean position over this long (0: its newest)"};
inline constexpr Key<bool> whole_views{"whole_views", false, {}, "", "under IR guidance, a view of the fruit cut by the hand image's border or filling it (not whole: its centre is pulled toward the image centre) is not centred on: the mean of the window's whole views stays, the window counted back from the newest whole view (false: every view)"};
inline constexpr Key<double> still_window{"still_window", 0.3, {0.0, 1e6}, "s", "... but while the fixed camera sees the tree still (sway.tree_*), over this long instead (0: its newest; the nearest views are the best, the oldest were taken up to 45 cm away)"};
inline constexpr Key<double> kp_orient{"kp_orient", 2.0, {0.01, 100.0}, "1/s", "orient_law thesis_pd: gain on the aim angles (eq. 6-24)"};
inline constexpr Key<double> kd_orient{"kd_orient", 0.05, {0.0, 1e6}, "s", "its derivative gain"};
}  // namespace gains
namespace timeouts_s {
inline constexpr Key<double> select{"select", 3.0, {0.01, 600.0}, "s", "wait for a fresh fixed-camera view"};
inline constexpr Key<double> motion{"motion", 20.0, {0.01, 600.0}, "s", "any pose-goal motion (orient, detach, drop, return, home)"};
inline constexpr Key<double> stall{"stall", 2.0, {0.01, 600.0}, "s", "a pose-goal motion that gets no closer to its goal this long is blocked"};
inline constexpr Key<double> acquire{"acquire", 3.0, {0.01, 600.0}, "s", "the fruit must appear in the hand camera after orienting"};
inline constexpr Key<double> lost{"lost", 0.3, {0.01, 600.0}, "s", "no hand measurement this long: hold and re-acquire"};
inline constexpr Key<double> reacquire{"reacquire", 2.0, {0.01, 600.0}, "s", "... and give the fruit up (LOST) after this long"};
inline constexpr Key<double> approach{"approach", 30.0, {0.01, 600.0}, "s", "the whole visual approach"};
inline constexpr Key<double> ir_approach{"ir_approach", 8.0, {0.01, 600.0}, "s", "one IR-guided attempt"};
inline constexpr Key<double> grasp{"grasp", 3.0, {0.01, 600.0}, "s", "the gripper must report holding / closed"};
inline constexpr Key<double> release{"release", 3.0, {0.01, 600.0}, "s", "the gripper must report open"};
inline constexpr Key<double> robot_state{"robot_state", 0.25, {0.01, 600.0}, "s", "robot state watchdog while running"};
inline constexpr Key<double> ir_stale{"ir_stale", 0.3, {0.01, 600.0}, "s", "an IR reading older than this: do not advance"};
}  // namespace timeouts_s
namespace sway {  // the sway estimator and the timed close (servo/harvest/sway.hpp)
inline constexpr Key<double> window{"window", 6.0, {0.1, 60.0}, "s", "hand-camera positions of the current fruit kept for the sway fit"};
inline constexpr Key<int> min_samples{"min_samples", 12, {5, 10000}, "", "fewer positions than this: still"};
inline constexpr Key<double> min_span{"min_span", 0.8, {0.0, 60.0}, "s", "positions over less time than this: still"};
inline constexpr Key<double> min_periods_seen{"min_periods_seen", 0.4, {0.05, 10.0}, "", "a frequency is tried only on views spanning at least this many of its periods (a sinusoid seen over less than half its period is a drift with a bend)"};
inline constexpr Key<double> min_frequency_hz{"min_frequency_hz", 0.2, {0.01, 20.0}, "Hz", "sway frequencies tried: from ..."};
inline constexpr Key<double> max_frequency_hz{"max_frequency_hz", 2.0, {0.01, 20.0}, "Hz", "... to (at least min_frequency_hz) ..."};
inline constexpr Key<double> frequency_step_hz{"frequency_step_hz", 0.02, {0.001, 5.0}, "Hz", "... in steps of"};
inline constexpr Key<double> min_amplitude{"min_amplitude", 0.005, {0.0, 1.0}, "m", "a fitted sway smaller than this: still"};
inline constexpr Key<double> max_amplitude{"max_amplitude", 0.06, {0.0, 1.0}, "m", "a fitted sway larger than this is the camera's noise: still"};
inline constexpr Key<double> min_confidence{"min_confidence", 0.6, {0.0, 1.0}, "", "share of the variance about the drift the sinusoid must explain, else still"};
inline constexpr Key<int> learn_fruit{"learn_fruit", 3, {1, 1000}, "", "after this many swaying fruit, the frequency that fitted them best together is the tree's and later fruit are fitted at it"};
inline constexpr Key<double> max_centre_offset{"max_centre_offset", 0.03, {0.0, 1.0}, "m", "a fit whose sway centre lies farther off the gripper axis disagrees with the IR and the centring: closed on at once"};
inline constexpr Key<double> close_delay{"close_delay", 0.6, {0.0, 5.0}, "s", "from the close command to the jaws meeting the fruit"};
inline constexpr Key<double> close_tolerance{"close_tolerance", 0.006, {0.0, 0.1}, "m", "close a swaying fruit when predicted this near the gripper axis at the end of the close ..."};
inline constexpr Key<double> hold_spread{"hold_spread", 0.0025, {0.0, 1.0}, "m", "positions seen under IR guidance spread more than this (rms about their mean): the fruit sways, and the approach holds ..."};
inline constexpr Key<double> hold_standoff{"hold_standoff", 0.2, {0.0, 1.0}, "m", "... this far short of it (its centre ahead of the tool point; 0: never holds) ..."};
inline constexpr Key<double> at_standoff{"at_standoff", 0.01, {0.0, 0.2}, "m", "braking toward the standoff the arm nears it ever more slowly: within this of it, it is there"};
inline constexpr Key<double> hold_time{"hold_time", 2.5, {0.0, 30.0}, "s", "... this long, centring on its mean, before going in (at least gains.sway_window and one sway period)"};
inline constexpr Key<double> hold_check{"hold_check", 0.8, {0.0, 30.0}, "s", "> 0: after this long held, the views since the hold began decide early: spread less than still_spread, the fruit is still after all; no whole view, nothing to watch; either way it goes in (0: always the whole hold_time)"};
inline constexpr Key<double> still_spread{"still_spread", 0.002, {0.0, 1.0}, "m", "... the spread (rms about their mean) below which the held fruit is still"};
inline constexpr Key<double> max_wait{"max_wait", 0.0, {0.0, 10.0}, "s", "... or nearest within this wait, held still at the grasp range (0: close at once, no timing)"};
inline constexpr Key<double> tree_window{"tree_window", 4.0, {0.0, 60.0}, "s", "the tree gauge: the fixed camera (it stands still) watches every fruit's centroid this long (0: no gauge) ..."};
inline constexpr Key<double> tree_min_span{"tree_min_span", 3.0, {0.0, 60.0}, "s", "... a fruit counts once its views span this long (at most tree_window) ..."};
inline constexpr Key<int> tree_min_fruit{"tree_min_fruit", 3, {1, 1000}, "", "... and with fewer fruit counted the gauge cannot tell (the hold runs as without it) ..."};
inline constexpr Key<double> tree_quantile{"tree_quantile", 0.25, {0.0, 1.0}, "", "... the fruit at this quantile of the centroids' spread (rms, in metres at the fruit) stands for the tree: the arm passing in front of a few moves their centroids, wind moves all ..."};
inline constexpr Key<double> tree_still_rms{"tree_still_rms", 0.004, {0.0, 1.0}, "m", "... below this the tree is still: a hold for a sway ends at hold_check whatever the held views spread, and the close is not timed (still trees 0.2-0.8 mm at the quarter, tree_wind 15 mm at 0.4 Hz 8-11 mm)"};
inline constexpr Key<bool> tree_still_skips_hold{"tree_still_skips_hold", true, {}, "", "... and while it reads still, a fruit that spreads more than hold_spread is not held at all: it is centred on its newest views (gains.still_window) on the way in (false: held until hold_check)"};
}  // namespace sway
namespace tbz {  // approach_mode tbz
inline constexpr Key<double> lambda_w{"lambda_w", 2.0, {0.0, 100.0}, "1/s", "rotation gain (eq. 5-44)"};
inline constexpr Key<double> lambda_v{"lambda_v", 0.25, {0.0, 1000.0}, "", "translation gain (eq. 5-62)"};
inline constexpr Key<double> desired_depth_estimate{"desired_depth_estimate", 0.25, {0.01, 10.0}, "m", "Z*_1 hat: the sticker's depth at the goal, roughly"};
inline constexpr Key<double> max_match_age_s{"max_match_age_s", 0.3, {0.01, 10.0}, "s", "older FEATURE_MATCHES do not steer"};
inline constexpr Key<double> fallback_after_s{"fallback_after_s", 1.5, {0.0, 60.0}, "s", "no usable matches this long: the 3D-reconstruction approach for this fruit"};
inline constexpr Key<double> min_verified_share{"min_verified_share", 0.5, {0.0, 1.0}, "", "fewer verified FEATURE_MATCHES than this share of those in the last fallback_after_s: the same (spurious matches verify now and then)"};
inline constexpr Key<double> desired_wait_s{"desired_wait_s", 5.0, {0.0, 60.0}, "s", "no desired (zoomed) image yet this long: the 3D-reconstruction approach for this fruit (the zoomed view comes at the zoom camera's rate)"};
inline constexpr Key<double> arrived_rotation{"arrived_rotation", 0.0175, {0.0, 1.0}, "rad", "|e_w| at or below this ..."};
inline constexpr Key<double> arrived_translation{"arrived_translation", 0.01, {0.0, 1.0}, "", "... and |e_v| at or below this: at the goal, IR guidance from there"};
}  // namespace tbz
}  // namespace servo_keys

// Axis-aligned box in the base frame plus a reach shell around the base
// origin: a commanded motion never leaves it, a target outside is skipped.
struct Workspace {
  Eigen::Vector3d min{servo_keys::workspace::min.fallback.data()};
  Eigen::Vector3d max{servo_keys::workspace::max.fallback.data()};
  double min_reach = servo_keys::workspace::min_reach.fallback;
  double max_reach = servo_keys::workspace::max_reach.fallback;
  bool contains(const Eigen::Vector3d& p, double margin = 0.0) const;
};

struct Gains {
  double kp_lateral = servo_keys::gains::kp_lateral.fallback;         // [1/s] on the metric centring error (eq. 6-25, 6-26)
  double kd_lateral = servo_keys::gains::kd_lateral.fallback;        // [s]
  double kp_depth = servo_keys::gains::kp_depth.fallback;           // [1/s] on the depth error (eq. 6-27)
  double kd_depth = servo_keys::gains::kd_depth.fallback;           // [s]
  double derivative_filter = servo_keys::gains::derivative_filter.fallback;  // low-pass weight of the newest error derivative, 0..1
  // [m] advance no faster than the centring can bring the fruit within this
  // of the gripper axis by the time the gripper gets there (0: no bound)
  double centring_tolerance = servo_keys::gains::centring_tolerance.fallback;
  // [s] under IR guidance, centre on the fruit's mean position over this long
  // (0: on its newest position). A fruit swaying in the wind keeps moving
  // during the gripper's blind close: from its mean it is at most one sway
  // amplitude away when the fingers meet, from where it was last seen up to
  // nearly two.
  double sway_window = servo_keys::gains::sway_window.fallback;
  double still_window = servo_keys::gains::still_window.fallback;
  bool whole_views = servo_keys::gains::whole_views.fallback;
  // orient_law thesis_pd: omega = kp_orient e + kd_orient de/dt on the angles of eq. 6-19, 6-20, 6-23 (eq. 6-24)
  double kp_orient = servo_keys::gains::kp_orient.fallback;   // [1/s]
  double kd_orient = servo_keys::gains::kd_orient.fallback;  // [s]
};

struct Timeouts {
  double select = servo_keys::timeouts_s::select.fallback;        // wait for a fresh fixed-camera view
  double motion = servo_keys::timeouts_s::motion.fallback;       // any pose-goal motion (orient, detach, drop, return, home)
  double stall = servo_keys::timeouts_s::stall.fallback;         // a pose-goal motion that gets no closer to its goal this long is blocked
  double acquire = servo_keys::timeouts_s::acquire.fallback;       // fruit must appear in the hand camera after orienting
  double lost = servo_keys::timeouts_s::lost.fallback;          // no hand measurement this long -> hold and re-acquire
  double reacquire = servo_keys::timeouts_s::reacquire.fallback;     // ... and give the fruit up (LOST) after this long
  double approach = servo_keys::timeouts_s::approach.fallback;     // whole visual approach
  double ir_approach = servo_keys::timeouts_s::ir_approach.fallback;   // one IR-guided attempt
  double grasp = servo_keys::timeouts_s::grasp.fallback;         // gripper must report holding / closed
  double release = servo_keys::timeouts_s::release.fallback;       // gripper must report open
  double robot_state = servo_keys::timeouts_s::robot_state.fallback;  // robot state watchdog while running
  double ir_stale = servo_keys::timeouts_s::ir_stale.fallback;      // IR reading older than this: do not advance
};

struct ServoConfig {
  double tick_period_s = servo_keys::tick_period_s.fallback;        // command rate (50 Hz)
  double status_period_s = servo_keys::status_period_s.fallback;       // periodic HARVEST_STATUS
  double validity_s = servo_keys::validity_s.fallback;            // validity window of every robot command
  // From the robot's envelope (config/arm/envelope.yaml); the defaults are its values.
  double max_linear_speed = 0.381;    // [m/s] thesis 15 in/s
  double max_angular_speed = 1.5708;  // [rad/s] thesis: PID2 (pi/2) in HarvestStep4/5
  double max_linear_accel = 1.0;      // [m/s^2]
  double max_angular_accel = 3.0;     // [rad/s^2]

  double ir_switch_distance = servo_keys::ir_switch_distance.fallback;  // [m] thesis 18 in: switch to IR guidance
  double ir_approach_speed = servo_keys::ir_approach_speed.fallback;    // [m/s] fastest forward speed under IR guidance ...
  double ir_braking_decel = servo_keys::ir_braking_decel.fallback;       // [m/s^2] ... braking so it would stop at the grasp range ...
  double ir_min_speed = servo_keys::ir_min_speed.fallback;          // [m/s] ... but never below this
  double ir_grasp_range = servo_keys::ir_grasp_range.fallback;       // [m] IR range at or below which the fruit is inside
  double ir_max_travel = servo_keys::ir_max_travel.fallback;          // [m] beyond the switch point before backing off
  double ir_overshoot = servo_keys::ir_overshoot.fallback;          // [m] ... or past the estimated fruit centre by this much
  // [m] ... or by this much more while the IR reads a surface that stays put ahead: the estimate's depth (from the
  // apparent size) was short; 0: off
  double ir_surface_reach = servo_keys::ir_surface_reach.fallback;
  double ir_surface_travel = servo_keys::ir_surface_travel.fallback;        // [m] a surface stays put over this advance ...
  double ir_surface_tolerance = servo_keys::ir_surface_tolerance.fallback;  // [m] ... its position agreeing within this
  // [m] > 0: an IR grasp reading counts only with the triangulated fruit
  // centre no farther ahead (a leaf in front of it); 0: off
  double ir_vision_agreement = servo_keys::ir_vision_agreement.fallback;
  // [m] > ir_vision_agreement: an IR grasp reading while a checked estimate
  // lies between the two this far ahead cannot be told from a leaf in front of
  // the fruit: the arm goes on half the gap between the two centres and closes
  // there, the fingers' reach holding either (0: off, such a reading is a leaf)
  double ir_split_close = servo_keys::ir_split_close.fallback;
  // [m] ... going on no farther than this: past it, with grasp_advance, the
  // palm runs into a fruit the IR read (25 mm did in the simulator)
  double ir_split_max = servo_keys::ir_split_max.fallback;
  // [m] a fruit in front of the one aimed at, filling the hand image when the
  // IR reads the grasp range, is closed on only with its centre this near the
  // gripper axis; farther off, the attempt is given up (it would be knocked off)
  double front_fruit_tolerance = servo_keys::front_fruit_tolerance.fallback;
  // [m] the arm goes on this far along the tool axis (at ir_min_speed) while
  // the gripper closes, then stops (0: stops at once, as the thesis does)
  double grasp_advance = servo_keys::grasp_advance.fallback;
  bool grasp_stop_at_joint_limit = servo_keys::grasp_stop_at_joint_limit.fallback;
  // A reading within ir_fold_near above the grasp range followed by one
  // ir_fold_jump farther is the sensor folding back (the fruit is inside).
  double ir_fold_near = servo_keys::ir_fold_near.fallback;         // [m]
  double ir_fold_jump = servo_keys::ir_fold_jump.fallback;         // [m]
  double ir_progress_step = servo_keys::ir_progress_step.fallback;    // [m] under IR guidance, less tool motion than this for timeouts.stall: blocked
  int ir_attempts = servo_keys::ir_attempts.fallback;                // IR approaches per fruit (thesis: retry once)
  double orient_tolerance = servo_keys::orient_tolerance.fallback;     // [rad] orientation reached
  double position_tolerance = servo_keys::position_tolerance.fallback;  // [m] pose goal reached
  double retreat_distance = servo_keys::retreat_distance.fallback;     // [m] pull back along the tool axis after a failure
  double gone_in_distance = servo_keys::gone_in_distance.fallback;     // [m] a tool this far from home has gone in
  // A retreat followed by the straight way to the next fruit's aim (turning
  // on the way) ends, short of abreast of where the approach began, at the
  // first place from where that way passes retreat_clearance from every fruit
  // the fixed camera sees, for the tool point and the palm palm_offset behind
  // it (0: always abreast).
  double retreat_clearance = servo_keys::retreat_clearance.fallback;  // [m]
  bool retrace_way_in = servo_keys::retrace_way_in.fallback;  // the way out goes straight back to where the way in began
  double palm_offset = servo_keys::palm_offset.fallback;              // [m]
  double pull_distance = servo_keys::pull_distance.fallback;        // [m] detach: pull back along the tool axis ...
  double twist_angle = servo_keys::twist_angle.fallback;        // [rad] ... while twisting about it
  bool release_at_detach = servo_keys::release_at_detach.fallback;      // open the gripper where the pull ended (false: carry it to drop_pose first)
  bool release_while_retreating = servo_keys::release_while_retreating.fallback;  // let go on the way out, not at rest
  bool pull_through = servo_keys::pull_through.fallback;  // ... without stopping where the pull ends
  bool turn_while_retreating = servo_keys::turn_while_retreating.fallback;  // the way out turns to the next fruit's aim
  bool turn_in_wind = servo_keys::turn_in_wind.fallback;  // ... also when the tree is not seen still
  double turn_ahead_home_within = servo_keys::turn_ahead_home_within.fallback;  // [m] ... and ends at home if this near
  // After a pick (or a failure that retreats) the next fruit is selected at
  // the end of the retreat, out of the canopy, and ORIENT goes straight there
  // to its aim from home: no stop at home in between. A fruit aimed at from a
  // viewpoint, and orient_law thesis_pd, still go home first. false: RETURN
  // home, then SELECT (the thesis's sequence).
  bool straight_to_next = servo_keys::straight_to_next.fallback;
  // ... except after an approach during which a joint met its position limit
  // (ROBOT_STATE kFlagJointLimit): then home first, where the robot link
  // returns to the home posture (its redundancy had drifted; on the tree into
  // a branch with the shoulder roll at its limit, stalling approach after
  // approach).
  bool home_after_joint_limit = servo_keys::home_after_joint_limit.fallback;
  // RELEASE ends once the gripper reports OPENING at least this share of its
  // full opening (the fruit is free), or OPEN; 1: wait for OPEN.
  double release_opening = servo_keys::release_opening.fallback;
  // "travel": among fruit of equal standing (attempts, plausible depth) the
  // one whose aim from home is the smallest turn from the tool's orientation
  // first; "cost": the detector's cost (the thesis).
  std::string fruit_order{servo_keys::fruit_order.fallback};
  int max_attempts_per_fruit = servo_keys::max_attempts_per_fruit.fallback;     // attempts per fruit in total; a failed one is retried after every untried one
  double association_gate_px = servo_keys::association_gate_px.fallback;  // hand detection must lie this close to the predicted pixel
  double association_tie_weight = servo_keys::association_tie_weight.fallback;  // near the line of sight: weight of the point
  double association_tie_weight_doubtful = servo_keys::association_tie_weight_doubtful.fallback;  // ... for a doubtful depth
  double association_size_ratio = servo_keys::association_size_ratio.fallback;  // ... and, while followed, keep its size within this factor
  double min_ahead_of_home = servo_keys::min_ahead_of_home.fallback;    // [m] a target must lie this far ahead of the tool at home, along its axis
  // A fruit more than max_aim_angle off the gripper axis at home, or one the
  // arm cannot turn to there, is aimed at from a viewpoint view_distance
  // short of it, the home axis turned view_angle toward it: the arm has no
  // joint solution for a wide turn at home.
  double max_aim_angle = servo_keys::max_aim_angle.fallback;  // [rad]
  double view_angle = servo_keys::view_angle.fallback;      // [rad] 0: always aim from home (the thesis)
  double view_distance = servo_keys::view_distance.fallback;   // [m]
  // The camera-in-hand's ray through the fruit crossed with the fixed
  // camera's gives its position without the apparent size, which a leaf
  // cutting the fruit falsifies. Used when the rays pass within
  // triangulation_gap and cross at min_triangulation_angle or more;
  // triangulation_gap 0: the size alone (the thesis's eq. 6-15).
  double triangulation_gap = servo_keys::triangulation_gap.fallback;       // [m]
  double min_triangulation_angle = servo_keys::min_triangulation_angle.fallback;  // [rad]
  // A hand image is seen from where the camera was when it took the image
  // (ROBOT_STATE camera poses interpolated at its utime, states at most this
  // far apart), not from where the camera is when the detections arrive:
  // the arm moves on meanwhile. 0: the newest pose (the default: with 0.1 s
  // three tree_wind runs picked far fewer fruit, not understood yet).
  double image_pose_gap = servo_keys::image_pose_gap.fallback;  // [s]
  double same_fruit_distance = servo_keys::same_fruit_distance.fallback;     // [m] a fixed-camera target this close to a given-up one is that fruit
  double same_sight_angle = servo_keys::same_sight_angle.fallback;        // [rad] ... or, with a doubtful depth, its line of sight this close to one
  double reused_id_distance = servo_keys::reused_id_distance.fallback;      // [m] a finished id seen this far from where it finished is another fruit
  // A size-based hand estimate agrees with the rays' crossing within
  // size_agreement of the range (at least size_agreement_min): the hand
  // depth's own error is about 10 % rms, a leaf-cut fruit's a factor of 1.5.
  double size_agreement = servo_keys::size_agreement.fallback;
  double size_agreement_min = servo_keys::size_agreement_min.fallback;  // [m]
  // ... and only where the size puts the fruit at least crossing_beyond from
  // the hand camera does the crossing replace a size it disagrees with:
  // nearer, the size's error is centimetres and a disagreeing crossing (the
  // fixed camera's line of sight, taken once at the selection) was nearly
  // always the wrong one.
  double crossing_beyond = servo_keys::crossing_beyond.fallback;  // [m]
  // A size-based hand estimate outside the workspace (a leaf cut the fruit:
  // it looks small and far, 10-15 cm beyond the truth on the tree) whose ray
  // passes within fixed_depth_gap of the fixed camera's estimate is that
  // fruit at the fixed camera's depth: the point of the ray nearest it, if
  // inside (the IR finds the surface; 0: off, the attempt is given up).
  double fixed_depth_gap = servo_keys::fixed_depth_gap.fallback;  // [m]
  // A hand detection at least fills_view of the image height fills the view:
  // no depth from its size; and, front_fruit_size_ratio times the size the
  // current fruit should have and covering the image centre, it is a nearer
  // fruit in front of it.
  double fills_view = servo_keys::fills_view.fallback;
  double front_fruit_size_ratio = servo_keys::front_fruit_size_ratio.fallback;
  // An IR grasp reading while the followed fruit is whole in a hand image no
  // older than far_view_age and its estimate (from that image's apparent
  // size, or the rays' crossing) lies far_view_ahead or more ahead of the
  // tool point: the IR reads a leaf in front of it, whatever the depth's source.
  double far_view_ahead = servo_keys::far_view_ahead.fallback;  // [m]
  double far_view_age = servo_keys::far_view_age.fallback;  // [s]
  // An IR grasp reading while a fruit fills this share of a fresh hand image
  // over its centre is that fruit: on ten tree runs the detection there
  // covered 0.54 or more at 95 % of the closes, at most 0.41 before the
  // "leaves" passed that knocked nothing off (docs/servo-controller.md).
  double axis_fruit_area = servo_keys::axis_fruit_area.fallback;  // [share of the image]
  int whole_fruit_border_px = servo_keys::whole_fruit_border_px.fallback;  // [px] a detection this near the image border is cut by it: no depth from its size
  double whole_min_visible = servo_keys::whole_min_visible.fallback;  // ... nor one less visible than this (0: off)
  // A pose-goal motion progresses by getting goal_progress_step or
  // goal_progress_angle nearer its goal (timeouts.stall without: blocked).
  double goal_progress_step = servo_keys::goal_progress_step.fallback;  // [m]
  double goal_progress_angle = servo_keys::goal_progress_angle.fallback;  // [rad]
  double goal_progress_joint_speed = servo_keys::goal_progress_joint_speed.fallback;  // [rad/s] a turning joint: progress
  // An ORIENT blocked with the estimate this far (share of each image side)
  // inside the hand image goes on to ACQUIRE from where it stopped.
  double in_view_margin = servo_keys::in_view_margin.fallback;
  double sight_aim_margin = servo_keys::sight_aim_margin.fallback;  // [rad] aiming along a line of sight: the hand camera's half field of view less this

  Eigen::Isometry3d home_pose = Eigen::Isometry3d::Identity();
  Eigen::Isometry3d drop_pose = Eigen::Isometry3d::Identity();
  Workspace workspace;
  Gains gains;
  Timeouts timeouts;
  geometry::CameraModel hand_camera = kDefaultHandCamera;
  std::string approach_mode{servo_keys::approach_mode.fallback};  // pluggable approach strategy (approach.hpp)
  // The sway estimator and the timed close (servo/harvest/sway.hpp,
  // docs/servo-controller.md "A fruit in the wind").
  struct Sway {
    double window = servo_keys::sway::window.fallback;                    // [s]
    int min_samples = servo_keys::sway::min_samples.fallback;
    double min_span = servo_keys::sway::min_span.fallback;                // [s]
    double min_periods_seen = servo_keys::sway::min_periods_seen.fallback;
    double min_frequency_hz = servo_keys::sway::min_frequency_hz.fallback;
    double max_frequency_hz = servo_keys::sway::max_frequency_hz.fallback;
    double frequency_step_hz = servo_keys::sway::frequency_step_hz.fallback;
    double min_amplitude = servo_keys::sway::min_amplitude.fallback;      // [m]
    double max_amplitude = servo_keys::sway::max_amplitude.fallback;      // [m]
    double min_confidence = servo_keys::sway::min_confidence.fallback;    // 0..1
    int learn_fruit = servo_keys::sway::learn_fruit.fallback;
    double max_centre_offset = servo_keys::sway::max_centre_offset.fallback;  // [m]
    double close_delay = servo_keys::sway::close_delay.fallback;          // [s]
    double close_tolerance = servo_keys::sway::close_tolerance.fallback;  // [m]
    double hold_spread = servo_keys::sway::hold_spread.fallback;          // [m]
    double hold_standoff = servo_keys::sway::hold_standoff.fallback;      // [m]
    double at_standoff = servo_keys::sway::at_standoff.fallback;          // [m]
    double hold_time = servo_keys::sway::hold_time.fallback;              // [s]
    double hold_check = servo_keys::sway::hold_check.fallback;            // [s]
    double still_spread = servo_keys::sway::still_spread.fallback;        // [m]
    double max_wait = servo_keys::sway::max_wait.fallback;                // [s]
    double tree_window = servo_keys::sway::tree_window.fallback;          // [s]
    double tree_min_span = servo_keys::sway::tree_min_span.fallback;      // [s]
    int tree_min_fruit = servo_keys::sway::tree_min_fruit.fallback;
    double tree_quantile = servo_keys::sway::tree_quantile.fallback;      // 0..1
    double tree_still_rms = servo_keys::sway::tree_still_rms.fallback;    // [m]
    bool tree_still_skips_hold = servo_keys::sway::tree_still_skips_hold.fallback;
  } sway;
  // approach_mode tbz (servo/tbz_approach.hpp, docs/teach-by-zooming.md).
  struct Tbz {
    double lambda_w = servo_keys::tbz::lambda_w.fallback;
    double lambda_v = servo_keys::tbz::lambda_v.fallback;
    double desired_depth_estimate = servo_keys::tbz::desired_depth_estimate.fallback;
    double max_match_age_s = servo_keys::tbz::max_match_age_s.fallback;
    double fallback_after_s = servo_keys::tbz::fallback_after_s.fallback;
    double min_verified_share = servo_keys::tbz::min_verified_share.fallback;
    double desired_wait_s = servo_keys::tbz::desired_wait_s.fallback;
    double arrived_rotation = servo_keys::tbz::arrived_rotation.fallback;
    double arrived_translation = servo_keys::tbz::arrived_translation.fallback;
  } tbz;
  // ORIENT in place: "pose_goal" (a pose goal the robot link runs along a
  // smooth path) or "thesis_pd" (the thesis's PD law on the aim angles,
  // eq. 6-24, as tool twists, also holding the roll about the gripper axis
  // at the home pose's). Viewpoints are always reached by a pose goal.
  std::string orient_law{servo_keys::orient_law.fallback};

  // Reads the `servo` section layout documented in docs/servo-controller.md.
  // Throws config::Error (bad value, home/drop pose outside the workspace).
  static ServoConfig from_yaml(const config::Node& node);
  static std::vector<config::Section> schema();
};

}  // namespace harvest::servo
