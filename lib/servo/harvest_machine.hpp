// The harvest sequence (thesis section 4.4, appendix D HarvestStep1..6) as a
// pure state machine: messages and ticks in, commands out. No LCM, no clock,
// no logging: ServoControllerNode wires it to the bus.
//
//   IDLE -START-> ([RETREAT ->] RETURN, if not at home) -> SELECT -> ORIENT -> ACQUIRE -> APPROACH
//     -> IR_APPROACH -> GRASP -> DETACH [-> DROP] -> RELEASE [-> RETREAT] -> RETURN -> SELECT ... -> DONE (no reachable
//     fruit left)
//   failures: APPROACH <-> REACQUIRE -> LOST; IR_APPROACH -> BACKOFF -> IR_APPROACH
//     -> FAILED_GRASP; each then RETREAT -> RETURN -> SELECT. Faults -> FAULT
//     (until RESET_FAULT), emergency stop -> ESTOP (latched until cleared).
#pragma once

#include <map>
#include <memory>
#include <optional>
#include <set>
#include <string>
#include <vector>

#include "harvest/emergency_stop_t.hpp"
#include "harvest/fruit_detections_t.hpp"
#include "harvest/fruit_outcome_t.hpp"
#include "harvest/gripper_command_t.hpp"
#include "harvest/gripper_state_t.hpp"
#include "harvest/harvest_status_t.hpp"
#include "harvest/ir_range_t.hpp"
#include "harvest/operator_command_t.hpp"
#include "harvest/robot_command_t.hpp"
#include "harvest/robot_state_t.hpp"
#include "harvest/targets_t.hpp"
#include "runtime/clock.hpp"
#include "servo/approach.hpp"
#include "servo/motion_limits.hpp"
#include "servo/servo_config.hpp"

namespace harvest::servo {

enum class State {
  kIdle,
  kSelect,
  kOrient,
  kAcquire,
  kApproach,
  kReacquire,
  kIrApproach,
  kBackoff,
  kGrasp,
  kDetach,
  kDrop,
  kRelease,
  kRetreat,
  kReturn,
  kHoming,
  kDone,
  kFault,
  kEstop,
};
const char* state_name(State s);

// What to publish after one input or tick.
struct MachineOutput {
  std::optional<robot_command_t> robot;
  std::optional<gripper_command_t> gripper;
  bool status_changed = false;
  std::string log;  // a line worth logging (refused command, fault), empty if none
};

class HarvestMachine {
 public:
  HarvestMachine(ServoConfig config, std::unique_ptr<ApproachStrategy> approach);

  MachineOutput on_targets(const targets_t& msg, rt::Micros now);
  MachineOutput on_hand_fruit(const fruit_detections_t& msg, rt::Micros now);
  MachineOutput on_robot_state(const robot_state_t& msg, rt::Micros now);
  MachineOutput on_ir(const ir_range_t& msg, rt::Micros now);
  MachineOutput on_gripper(const gripper_state_t& msg, rt::Micros now);
  MachineOutput on_operator(const operator_command_t& msg, rt::Micros now);
  MachineOutput on_estop(const emergency_stop_t& msg, rt::Micros now);
  // The control step, called at config.tick_period_s.
  MachineOutput tick(rt::Micros now);

  State state() const { return state_; }
  bool paused() const { return paused_; }
  bool estop() const { return estop_; }
  int current_fruit() const { return current_ ? current_->id : -1; }
  const std::vector<fruit_outcome_t>& outcomes() const { return outcomes_; }
  // HARVEST_STATUS content (the node fills seq and publish time).
  harvest_status_t status() const;
  std::string summary() const;
  int64_t workspace_clips() const { return limiter_.workspace_clips(); }
  // The approach strategy, for the node to feed strategy-specific inputs (FEATURE_MATCHES for tbz).
  ApproachStrategy& approach() { return *approach_; }
  std::string approach_name() const { return approach_->name(); }

 private:
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
    Eigen::Vector3d selected_from = Eigen::Vector3d::Zero();  // the fixed camera's position when selected
    std::optional<SightLine> sight;                           // where the fixed camera saw it
    // The fixed camera's depth put it where no fruit can be picked (a piece
    // of a fruit seen as a small, far one; fruit seen together as one large,
    // near one): aimed at its line of sight instead, until the camera-in-hand
    // measures it.
    bool depth_doubtful = false;
    bool from_viewpoint = false;  // ORIENT goes to the viewpoint (the turn at home is too wide or was blocked)
    double diameter = 0.07;       // [m] the diameter the fixed camera assumed (the statistical size)
    // Where the estimate's depth comes from: the apparent size alone, the
    // size confirmed by where the two cameras' rays cross, or that crossing
    // (the size disagreed with it: a leaf cutting the fruit).
    enum class Depth { kSize, kConfirmed, kCrossing } depth = Depth::kSize;
  };
  struct Timed {
    rt::Micros rx = 0;  // receive time on our clock
  };

  bool running() const;
  bool robot_fresh(rt::Micros now) const;
  Eigen::Isometry3d tool() const;
  Eigen::Isometry3d camera() const;
  std::optional<PixelMeasurement> fresh_pixel(rt::Micros now) const;

  void enter(State s, rt::Micros now, MachineOutput& out);
  void start_goal(const Eigen::Isometry3d& goal, State s, rt::Micros now, MachineOutput& out);
  bool goal_reached() const;
  // The current fruit's estimate projects well inside the hand camera's image.
  bool estimate_in_hand_view() const;
  // A pose-goal motion that gets no closer to its goal for timeouts.stall
  // (the arm is blocked, e.g. at a joint limit) is not waited out.
  bool goal_stalled(rt::Micros now);
  // A pose-goal motion that stalled or timed out: the fruit is unreachable if
  // the arm cannot turn to it, a blocked retreat returns home directly, any
  // other blocked motion is a fault.
  void motion_blocked(const std::string& why, rt::Micros now, MachineOutput& out);
  // GRASP: forward along the tool axis at ir_min_speed until grasp_advance
  // past where the gripper was told to close, then STOP.
  void grasp_step(MachineOutput& out);
  // Forward speed under IR guidance for the range still to go (IR if it sees the fruit, else the estimate).
  double ir_forward_speed(bool ir_sees_fruit) const;
  Eigen::Isometry3d inside_workspace(const Eigen::Isometry3d& goal) const;
  bool at_home() const;
  // A position a fruit can be picked at: inside the workspace and ahead of
  // the gripper at home (every fruit is aimed at from there).
  bool pickable(const Eigen::Vector3d& p) const;
  // The pickable part of the fixed camera's line of sight through `t`;
  // nullopt if the view carries no camera pose or no part is pickable.
  std::optional<SightLine> sight_line(const targets_t& view, const target_t& t) const;
  // The current fruit where the camera-in-hand's ray through `pixel` crosses
  // the fixed camera's line of sight; nullopt if they do not cross closely
  // at a useful angle (another fruit, or a line of sight too poor).
  std::optional<Eigen::Vector3d> triangulate(const PixelMeasurement& pixel) const;
  // Where to aim, from `from`, at a fruit somewhere on a sight line: the
  // stretch of line the camera-in-hand sees at once, starting at parameter
  // `s_start` (the end nearest the fixed camera's estimate), aimed at its
  // middle direction. Returns a point of the line.
  Eigen::Vector3d sight_aim(const SightLine& line, double s_start, const Eigen::Vector3d& from) const;
  // The ORIENT goals for a fruit at `target`, from the tool at home: the
  // gripper axis turned to it in place (eq. 6-19..6-22); or, from a viewpoint
  // view_distance short of it, the home axis turned view_angle toward it
  // (nullopt if the viewpoint is off or outside the workspace).
  Eigen::Isometry3d aim_in_place(const Eigen::Vector3d& target) const;
  std::optional<Eigen::Isometry3d> aim_from_viewpoint(const Eigen::Vector3d& target) const;
  // ORIENT: aim at the current fruit from home, or from its viewpoint if it
  // lies more than max_aim_angle off the home axis.
  void orient(rt::Micros now, MachineOutput& out);
  // The tool moved straight back along its axis, in its orientation: to
  // abreast of `abreast_of` (if given) or by `at_least`, whichever is
  // farther. The palm retraces the way the gripper came in; a straight line
  // to an earlier point cuts sideways through neighbouring fruit.
  Eigen::Isometry3d back_along_axis(const std::optional<Eigen::Vector3d>& abreast_of, double at_least) const;
  // RETREAT goal: back by retreat_distance, or out of the canopy to abreast
  // of where the approach began, whichever is farther.
  Eigen::Isometry3d retreat_goal() const { return back_along_axis(approach_from_, cfg_.retreat_distance); }
  // START: SELECT from the home pose, else retreat and return home first.
  void begin_from_home(rt::Micros now, MachineOutput& out);
  void select(rt::Micros now, MachineOutput& out);
  void on_timeout(rt::Micros now, MachineOutput& out);
  void step(rt::Micros now, MachineOutput& out);
  // Ends the current fruit with an outcome; `retreat` pulls back along the
  // tool axis before returning home.
  void fail_fruit(int8_t outcome, const std::string& detail, bool retreat, rt::Micros now, MachineOutput& out);
  void record(int8_t outcome, int fruit_id, const Eigen::Vector3d& target, const std::string& detail, rt::Micros since,
              rt::Micros now, MachineOutput& out);
  void fault(const std::string& detail, rt::Micros now, MachineOutput& out);
  std::optional<std::string> gripper_fault() const;

  robot_command_t command(int8_t type) const;
  robot_command_t stop_command() const { return command(robot_command_t::TYPE_STOP); }
  robot_command_t twist_command(const Twist& desired);
  robot_command_t goal_command() const;
  gripper_command_t gripper_command(int8_t action) const;

  ServoConfig cfg_;
  std::unique_ptr<ApproachStrategy> approach_;
  TwistLimiter limiter_;

  State state_ = State::kIdle;
  bool paused_ = false;
  bool estop_ = false;
  bool stop_pending_ = false;  // publish one STOP on the next tick (entering a resting state)
  rt::Micros entered_at_ = 0;
  rt::Micros deadline_ = 0;  // 0: none
  rt::Micros paused_at_ = 0;
  std::string note_;

  std::optional<robot_state_t> robot_;
  rt::Micros robot_rx_ = 0;
  std::optional<targets_t> fixed_;
  rt::Micros fixed_rx_ = 0;
  std::optional<gripper_state_t> gripper_;
  std::optional<ir_range_t> ir_;
  rt::Micros ir_rx_ = 0;
  std::optional<PixelMeasurement> pixel_;  // associated centroid of the current fruit
  rt::Micros pixel_rx_ = 0;
  bool pixel_whole_ = false;                       // ... the whole fruit, inside the image: its size gives a depth
  std::optional<Eigen::Vector3d> pixel_crossing_;  // ... where its ray crosses the fixed camera's line of sight
  rt::Micros fruit_fills_view_rx_ = 0;  // last hand image with a fruit filling it on the gripper axis (0: none)
  double fruit_in_front_offset_ = 0.0;  // ... its centre's distance from the gripper axis [m]
  std::optional<Eigen::Vector2d> hand_target_px_;  // pixel of the hand target the reconstructor gave the current id
  rt::Micros hand_target_rx_ = 0;

  std::optional<Fruit> current_;
  std::map<int, int> attempts_;
  std::set<int> finished_;
  // Fixed-camera positions of fruit given up (not picked): the fixed camera's
  // tracker gives a fruit a new id after the arm has hidden it, and the same
  // fruit must not be tried again under its new id.
  std::vector<Eigen::Vector3d> given_up_;
  // Lines of sight (unit directions from the fixed camera) of fruit given up,
  // and of each finished id: a doubtful depth jumps from image to image by
  // far more than same_fruit_distance, the direction does not.
  std::vector<Eigen::Vector3d> given_up_sights_;
  std::map<int, Eigen::Vector3d> finished_sight_;
  // Where each finished id was (fixed camera, at selection): the tracker may
  // hand a finished fruit's id on to another fruit (a neighbour once the fruit
  // is picked), which is then a new fruit, not a finished one.
  std::map<int, Eigen::Vector3d> finished_at_;
  std::vector<fruit_outcome_t> outcomes_;
  int picked_ = 0, lost_ = 0, unreachable_ = 0, failed_grasp_ = 0, aborted_ = 0;

  Eigen::Isometry3d goal_ = Eigen::Isometry3d::Identity();
  int64_t goal_id_ = 0;
  double goal_best_position_ = 0.0;  // closest the tool has come to the goal [m] ...
  double goal_best_rotation_ = 0.0;  // ... and its orientation [rad]
  rt::Micros goal_progress_at_ = 0;  // when it last got measurably closer
  int ir_attempt_ = 0;
  bool ir_passing_leaf_ = false;        // this IR attempt has gone past a leaf (noted once)
  std::optional<double> ir_last_near_;  // last IR range just above the grasp range in this attempt [m]
  bool ir_folded_ = false;              // ... followed by a jump far beyond it: the sensor folded back
  rt::Micros ir_progress_at_ = 0;       // when the tool last moved 5 mm under IR guidance ...
  Eigen::Vector3d ir_progress_from_ = Eigen::Vector3d::Zero();  // ... from here
  Eigen::Vector3d ir_start_ = Eigen::Vector3d::Zero();
  Eigen::Vector3d grasp_from_ = Eigen::Vector3d::Zero();  // the tool when the gripper was told to close
  // Where the approach into the canopy began (the tool at the end of ORIENT):
  // a retreat goes back along the tool axis at least that far.
  std::optional<Eigen::Vector3d> approach_from_;
};

}  // namespace harvest::servo
