// Closed-loop test harness for the servo controller, all in one process on a
// manual clock: rt::SimRunner (the replay runner's delivery order), a
// kinematic arm double (integrates twists and pose goals, publishes
// ROBOT_STATE) and a world double (true fruit; synthetic fixed-camera
// targets, hand-camera detections and targets, IR range and gripper state
// generated from the truth with injected calibration errors and faults).
#pragma once

#include <Eigen/Geometry>
#include <deque>
#include <optional>
#include <random>
#include <string>
#include <vector>

#include "harvest/gripper_command_t.hpp"
#include "harvest/robot_command_t.hpp"
#include "harvest/robot_state_t.hpp"
#include "runtime/log_io.hpp"
#include "runtime/node.hpp"
#include "runtime/sim_runner.hpp"
#include "servo/servo_config.hpp"

namespace harvest::servo::testing {

struct FruitTruth {
  int id = 0;
  Eigen::Vector3d position = Eigen::Vector3d::Zero();  // base frame [m]
  double diameter = 0.075;
  // Wind: the fruit sways about `position` by sway sin(2 pi sway_hz t + sway_phase), t from the start.
  Eigen::Vector3d sway = Eigen::Vector3d::Zero();  // [m] amplitude and direction
  double sway_hz = 0.0;
  double sway_phase = 0.0;  // [rad]
};

struct WorldSpec {
  std::vector<FruitTruth> fruits;
  Eigen::Isometry3d start_tool = Eigen::Isometry3d::Identity();
  double camera_behind_tcp = 0.06;                        // camera-in-hand optical centre behind the tool point [m]
  double ir_behind_tcp = 0.05;                            // IR sensor behind the tool point [m]
  geometry::CameraModel true_hand;                        // the real camera
  geometry::CameraModel assumed_hand;                     // the reconstructor's calibration
  Eigen::Vector3d fixed_error = Eigen::Vector3d::Zero();  // fixed-camera estimate minus truth [m]
  // The fixed camera's optical centre (thesis eq. 4-1 translation) and a
  // depth error along its line of sight: estimate = C + scale (truth + error - C).
  Eigen::Vector3d fixed_camera = Eigen::Vector3d(-0.2413, 0.2286, -0.4005);
  double fixed_depth_scale = 1.0;
  double fixed_depth_jitter = 0.0;     // the scale varies by up to +- this from image to image
  bool fixed_camera_unknown = false;   // TARGETS without the camera's position (logs from before the field)
  bool hand_ids_unassociated = false;  // the reconstructor matched no hand detection to a fixed-camera fruit
  double hand_depth_scale = 1.0;       // estimated / true depth in the hand camera
  // [m] added to the hand depth when the fruit fills most of the image (a
  // depth from size there is meaningless; the controller must not use it)
  std::optional<double> hand_depth_error_when_filling;
  bool hand_reports_filling = false;  // a fruit filling the image is still detected (bbox clipped to the image)
  double pixel_noise = 0.5;           // uniform +- [px]
  // The hand camera's images reach the controller this long after they were
  // taken (exposure, transfer, detection); their utime is when they were taken.
  double hand_latency_s = 0.0;
  uint32_t seed = 1;
  // Fault injection (times relative to the start).
  std::optional<double> hide_hand_after_s;  // fruit disappears from the hand camera for good
  std::optional<double> hide_hand_for_s;    // ... only for this long
  bool ir_dead = false;                     // IR always reports TOO_FAR
  // A leaf this far in front of the first fruit, across the line from the
  // start pose to it (a 3 cm disc the IR sees until the sensor passes it).
  std::optional<double> leaf_before_fruit_m;
  // Below this true range the IR folds back: it reports VALID but far (0.3 m),
  // as a triangulating sensor does nearer than its peak.
  std::optional<double> ir_fold_back_below_m;
  bool gripper_misses = false;                      // closes on nothing
  int gripper_misses_first = 0;                     // ... the first this many closures only
  bool gripper_stuck = false;                       // never finishes closing (no HOLDING/CLOSED report)
  std::optional<double> arm_ignores_goals_after_s;  // pose goals are then acknowledged but never executed
  std::optional<double> arm_blocked_after_s;        // no command moves the arm any more (it reports MOVING)
  bool arm_joint_limit_in_twists = false;           // every twist it follows reports kFlagJointLimit (as the robot link
                                                    // does while a joint brakes for its limit)
  // A pose goal that keeps the tool where it is and turns it more than this
  // is acknowledged but never executed (no joint solution for that turn).
  std::optional<double> arm_max_turn_in_place;
  // The first pose goal (the first ORIENT) stops this far short of its
  // position (a joint limit just before it) and is never reached.
  std::optional<double> arm_first_goal_stops_short_m;
  // The next this many new pose goals (counted from when it is raised) are refused, as the robot link refuses a goal
  // it finds unreachable: no motion, kFlagRefused in every state while that goal is resent.
  int arm_refuses_next_goals = 0;
  bool fruit_slips = false;          // a held fruit falls out of the gripper 0.2 s after the grasp
  bool fixed_camera_silent = false;  // no fixed-camera TARGETS at all
  bool fixed_ids_follow_order =
      false;  // the k-th fruit still on the tree has the k-th id (a picked fruit's id moves on)
  std::optional<double> fixed_ids_change_after_s;  // the fixed camera's tracker renumbers every fruit (id + 1000)
  std::optional<double> gripper_fault_after_s;
  std::optional<double> robot_fault_after_s;
  std::optional<double> robot_estop_after_s;         // the robot link reports MODE_ESTOP (and stops)
  std::optional<double> gripper_disconnect_after_s;  // the end-effector board goes away
  bool gripper_wont_open = false;                    // an OPEN command is never carried out
  // > 0: the gripper opens over this long, reporting OPENING and its opening
  // (0..1) on the way, OPEN at the end; a held fruit drops at once. 0: OPEN at once.
  double gripper_open_s = 0.0;
  std::optional<double> robot_silent_after_s;
};

// The arm: integrates the last valid command every 10 ms and publishes its state.
class ArmDouble final : public rt::Node {
 public:
  explicit ArmDouble(const WorldSpec& spec);
  const Eigen::Isometry3d& tool() const { return tool_; }
  Eigen::Isometry3d camera() const;
  // The camera pose at time t (the newest step at or before it, within the last second).
  Eigen::Isometry3d camera_at(rt::Micros t) const;
  bool fault() const { return fault_; }

 protected:
  void on_attach() override;

 private:
  void step();
  bool wide_turn_in_place(const Eigen::Isometry3d& goal) const;
  const WorldSpec& spec_;
  Eigen::Isometry3d tool_;
  std::optional<robot_command_t> cmd_;
  rt::Micros cmd_rx_ = 0;
  rt::Micros start_ = 0;
  bool fault_ = false;
  std::optional<int64_t> first_goal_id_;
  int64_t last_goal_id_ = 0;                                      // the newest pose goal id seen
  int refused_goals_ = 0;                                         // how many have been refused (arm_refuses_next_goals)
  bool goal_refused_ = false;                                     // ... and whether the newest was
  std::deque<std::pair<rt::Micros, Eigen::Isometry3d>> cameras_;  // camera poses of the last second's steps
};

// The world: sensors derived from the truth and the arm's true pose.
class WorldDouble final : public rt::Node {
 public:
  WorldDouble(const WorldSpec& spec, const ArmDouble& arm);
  bool fruit_picked(int id) const;
  // Tool position when the gripper was last told to close, if ever.
  const std::optional<Eigen::Vector3d>& close_position() const { return close_position_; }
  // The first fruit's centre minus the tool point, in the tool frame, when the gripper last finished closing.
  const std::optional<Eigen::Vector3d>& closed_offset() const { return closed_offset_; }

 protected:
  void on_attach() override;

 private:
  enum class Where { kTree, kGripper, kDropped, kFallen };
  int fixed_id(std::size_t i) const;                                            // the fixed camera's id of fruit i
  Eigen::Vector3d position(std::size_t i) const { return position(i, now()); }  // fruit i now (swaying)
  Eigen::Vector3d position(std::size_t i, rt::Micros t) const;                  // ... at time t
  void publish_fixed();
  void publish_hand();
  void publish_ir();
  void publish_gripper();
  double since_start() const { return rt::to_seconds(now() - start_); }

  const WorldSpec& spec_;
  const ArmDouble& arm_;
  std::vector<Where> where_;
  std::mt19937 rng_;
  rt::Micros start_ = 0;
  int8_t gripper_ = 1;  // gripper_state_t::STATE_OPEN
  rt::Micros closing_since_ = 0;
  int closures_ = 0;
  rt::Micros holding_since_ = 0;
  rt::Micros opening_since_ = 0;
  std::optional<Eigen::Vector3d> close_position_;
  std::optional<Eigen::Vector3d> closed_offset_;
};

// Experiment I of the thesis (tables 6-3, 6-5): the truth uses the
// table-consistent extrinsic, the fixed-camera estimate carries the error
// of table 6-4, the hand camera's calibration is off.
WorldSpec experiment_one();

// The thesis start pose: tool at (-655, 785, -251) mm, gripper axis along base +y.
Eigen::Isometry3d thesis_start_pose();

// A controller configuration for the tests (config/cameras/hand.yaml
// intrinsics), one attempt per fruit.
ServoConfig test_config();

}  // namespace harvest::servo::testing
