// The robot link's configuration (config/arm/robot_link.yaml): the arm model,
// its CANopen drives, the motion envelope shared with the controller, the
// limits on what a command may ask, the control gains, the pose-goal
// planner's budgets and whom the link obeys. See docs/robot-link.md.
#pragma once

#include <string>
#include <vector>

#include "arm/motion_safety.hpp"
#include "canopen/master.hpp"
#include "config/config.hpp"
#include "config/schema.hpp"
#include "kinematics/arm_model.hpp"
#include "security/authority.hpp"

namespace harvest::arm {

// The keys of config/arm/robot_link.yaml (the `can` mapping's others are
// canopen::master_keys, `authority` security::authority_keys).
namespace link_keys {
using config::Key;
using config::Path;
inline constexpr Key<Path> arm_model{
    "arm_model", "k1207i.yaml", {}, "", "the arm model: DH parameters, joint limits, tool and camera offsets, home"};
inline constexpr Key<Path> hand_eye{"hand_eye",
                                    "",
                                    {},
                                    "",
                                    "this robot's camera-in-hand in the tool frame as harvest-calibrate hand-eye wrote "
                                    "it, instead of the arm model's camera (empty: the arm model's)"};
inline constexpr Key<Path> envelope{
    "envelope", "envelope.yaml", {}, "", "the robot envelope: workspace box, speed and acceleration limits"};
inline constexpr Key<double> quick_stop_deceleration_factor{
    "quick_stop_deceleration_factor",
    10.0,
    {0.5, 50.0},
    "",
    "the drives' quick-stop ramp (0x6085) = this x the joint's acceleration limit"};
// limits
inline constexpr Key<int> default_validity_ms{
    "default_validity_ms", 100, {10, 1000}, "ms", "a command's validity when it says 0 (at most max_validity_ms)"};
inline constexpr Key<int> max_validity_ms{
    "max_validity_ms", 1000, {10, 10000}, "ms", "longer validities are cut to this"};
inline constexpr Key<double> min_goal_linear_speed{
    "min_goal_linear_speed",
    0.01,
    {1e-4, 0.1},
    "m/s",
    "pose goals capped slower are refused (their dry run would never end); at most the envelope's speed"};
inline constexpr Key<double> min_goal_angular_speed{
    "min_goal_angular_speed", 0.02, {1e-4, 0.5}, "rad/s", "the same for the angular speed cap"};
inline constexpr Key<double> non_physical_factor{
    "non_physical_factor",
    3.0,
    {1.0, 100.0},
    "",
    "twists faster than this x the speed limits are garbage: refused, not clipped"};
// control
inline constexpr Key<double> position_gain{
    "position_gain", 5.0, {0.0, 100.0}, "1/s", "feedback gain on the goal trajectory's position"};
inline constexpr Key<double> orientation_gain{
    "orientation_gain", 5.0, {0.0, 100.0}, "1/s", "feedback gain on its orientation"};
inline constexpr Key<double> joint_gain{
    "joint_gain", 5.0, {0.0, 100.0}, "1/s", "feedback gain of joint-space trajectories"};
inline constexpr Key<int> enable_timeout_ms{
    "enable_timeout_ms", 3000, {100, 60000}, "ms", "the drives must reach operation enabled within this"};
inline constexpr Key<int> realtime_priority{
    "realtime_priority",
    0,
    {0, 99},
    "",
    "SCHED_FIFO priority of the control loop (0: normal; needs root or CAP_SYS_NICE, refused: a warning)"};
}  // namespace link_keys

// When a pose goal's Cartesian dry run counts as reaching the goal
// (dry_run_pose_goal): within these tolerances by the trajectory's end plus
// `settle`. A path that lags behind its reference (joint speed limits near a
// wrist singularity) but converges within the settle time is not stuck.
struct DryRunOptions {
  double settle = 1.0;                  // [s] after the trajectory's end
  double position_tolerance = 0.002;    // [m]
  double orientation_tolerance = 0.01;  // [rad]
  double end_joint_margin = 0.005;      // [rad] and every joint at least this far inside its limits at the end
  // A goal at the home pose whose straight path ends with a joint farther than
  // this from the home posture goes to the home posture in joint space: the
  // way home resets the arm's redundancy (a straight path keeps whatever branch
  // the arm drifted into; on the tree one with the shoulder roll at its 170 deg
  // limit stalled IR approaches for minutes). 0: off.
  double home_posture_tolerance = 0.35;  // [rad]
  // A straight path that stops this near the goal, when the joint space has
  // no way either, runs anyway (the arm gets as close as it can; the
  // controller decides what short means) rather than being refused.
  double near_enough_position = 0.02;     // [m]
  double near_enough_orientation = 0.05;  // [rad]
  bool near_enough(double position_error, double orientation_error) const {
    return position_error <= near_enough_position && orientation_error <= near_enough_orientation;
  }
  // Bounded work per control period: the link runs at most this many dry-run
  // steps (about 10 us each) in the handler of a new goal and then after each
  // SYNC, while the arm holds; a typical goal (under 2 s of path) is decided
  // at once, a long slow one over a few periods.
  int steps_per_period = 200;
  // Pose goals whose trajectory would take longer are refused (the dry run
  // would cover max_duration + settle of control steps).
  double max_duration = 300.0;  // [s]
};

// Limits on what a command may ask, beyond MotionLimits: below the minimum
// goal speeds a goal would take forever (and its dry run with it); a twist
// beyond `non_physical_factor` times the speed limits is garbage, refused
// rather than clipped and obeyed at full speed.
struct CommandLimits {
  double min_goal_linear_speed = link_keys::min_goal_linear_speed.fallback;    // a pose goal's, if not 0
  double min_goal_angular_speed = link_keys::min_goal_angular_speed.fallback;  // a pose goal's, if not 0
  double non_physical_factor = link_keys::non_physical_factor.fallback;        // faster twists are refused
};

struct RobotLinkConfig {
  std::string bus{canopen::kBusKey.fallback};
  kinematics::ArmModel model;
  canopen::MasterConfig can;
  MotionLimits limits;
  CommandLimits command_limits;
  Workspace workspace;
  double position_gain = link_keys::position_gain.fallback;
  double orientation_gain = link_keys::orientation_gain.fallback;
  double joint_gain = link_keys::joint_gain.fallback;
  Micros enable_timeout = link_keys::enable_timeout_ms.fallback * Micros{1000};
  // SCHED_FIFO priority of the control loop (1..99; 0 = normal scheduling).
  // The drives quick-stop when the link's RPDOs stop for
  // can.drive_rpdo_timeout_ms (25 ms): on a loaded computer a stalled loop
  // would stop the arm. Needs root or CAP_SYS_NICE; refused, it is a warning.
  int realtime_priority = link_keys::realtime_priority.fallback;
  // A new pose goal whose Cartesian path the dry run finds stuck is solved
  // by IK and run in joint space (plan_pose_goal). Off: always Cartesian, as
  // before (tests compare the two).
  bool pose_goal_joint_fallback = true;
  DryRunOptions dry_run;
  // Iterations of that IK (kinematics::PoseSolver) per control period (15-30
  // us each on the shared 2-core machine), run after the period's SYNC: the
  // search (at most 9000 iterations) is spread over periods so SYNC stays on
  // time.
  int ik_iterations_per_period = 150;
  // Whom the link obeys (docs/security.md): ROBOT_COMMAND from the one bound
  // controller, RESET_FAULT and an e-stop clear from the operators; all
  // signed with the robot's key (a sim key is refused on socketcan).
  security::AuthorityConfig authority;

  static RobotLinkConfig from_config(const config::Node& root);
  static std::vector<config::Section> schema();
};

}  // namespace harvest::arm
