// The robot link node: owns the CAN bus of the arm. Every SYNC period it reads
// the drives, applies motion safety, turns the current command into joint
// velocities (differential IK, limits) and sends them, then publishes
// ROBOT_STATE. See docs/robot-link.md.
#pragma once

#include <harvest/emergency_stop_t.hpp>
#include <harvest/operator_command_t.hpp>
#include <harvest/robot_command_t.hpp>
#include <harvest/robot_state_t.hpp>
#include <map>
#include <memory>
#include <optional>
#include <string>

#include "arm/motion_safety.hpp"
#include "arm/trajectory.hpp"
#include "can/can_bus.hpp"
#include "canopen/master.hpp"
#include "config/config.hpp"
#include "kinematics/diff_ik.hpp"
#include "runtime/log_limiter.hpp"
#include "runtime/node.hpp"
#include "security/authority.hpp"

namespace harvest::arm {

// When a pose goal's Cartesian dry run counts as reaching the goal
// (dry_run_pose_goal): within these tolerances by the trajectory's end plus
// `settle`. A path that lags behind its reference (joint speed limits near a
// wrist singularity) but converges within the settle time is not stuck.
struct DryRunOptions {
  double settle = 1.0;                  // [s] after the trajectory's end
  double position_tolerance = 0.002;    // [m]
  double orientation_tolerance = 0.01;  // [rad]
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
  double min_goal_linear_speed = 0.01;   // [m/s] a pose goal's max_linear_speed, if not 0
  double min_goal_angular_speed = 0.02;  // [rad/s] a pose goal's max_angular_speed, if not 0
  double non_physical_factor = 3.0;      // twists faster than this x the limits are refused
};

struct RobotLinkConfig {
  std::string bus = "udp_multicast:239.74.163.2:43113";
  kinematics::ArmModel model;
  canopen::MasterConfig can;
  MotionLimits limits;
  CommandLimits command_limits;
  Workspace workspace;
  double position_gain = 5.0;
  double orientation_gain = 5.0;
  double joint_gain = 5.0;
  Micros enable_timeout = 3'000'000;
  // SCHED_FIFO priority of the control loop (1..99; 0 = normal scheduling).
  // The drives quick-stop when the link's RPDOs stop for
  // can.drive_rpdo_timeout_ms (25 ms): on a loaded computer a stalled loop
  // would stop the arm. Needs root or CAP_SYS_NICE; refused, it is a warning.
  int realtime_priority = 0;
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
};

// robot_state_t.fault_flags bits.
enum FaultFlag : int32_t {
  kFlagDriveFault = 1 << 0,     // a drive reported Fault / fault reaction
  kFlagEmcy = 1 << 1,           // EMCY with an error code
  kFlagHeartbeatLost = 1 << 2,  // a drive's heartbeat timed out
  kFlagPdoLost = 1 << 3,        // a drive stopped sending PDOs
  kFlagEstop = 1 << 4,          // emergency stop latched
  kFlagCommandStale = 1 << 5,   // the last command expired (controlled stop)
  kFlagLimited = 1 << 6,        // the current command is being clipped
  kFlagRefused = 1 << 7,        // the last command was refused
  kFlagBus = 1 << 8,            // CAN bus / drive configuration failure
  kFlagEnableTimeout = 1 << 9,  // drives did not reach operation enabled in time
  kFlagForeign = 1 << 10,       // frames on the bus we did not send: another master, forged PDOs
  kFlagNmtLeft = 1 << 11,       // a drive's heartbeat says it left operational, or it rebooted
  kFlagUncommanded = 1 << 12,   // a drive's CiA 402 state changed without a command
};

// ---- Control law, shared by the live loop and the pose-goal dry run.

// One SYNC period of the Cartesian control law: the requested tool twist `v`
// clipped to the speed limits and the workspace (clip_twist), mapped to joint
// velocities by the DLS IK with joint-limit locking
// (joint_velocity_within_limits), then limited per joint from the previous
// command (limit_joint_velocity: speed, acceleration, stopping distance).
struct CartesianStep {
  Eigen::VectorXd qdot;           // the joint velocity command [rad/s]
  ClippedTwist clip;              // the twist after clipping, and why it was clipped
  bool position_clipped = false;  // a joint was slowed at its position limit
};
CartesianStep cartesian_step(const RobotLinkConfig& config, const Eigen::VectorXd& q, const Eigen::Isometry3d& tool,
                             const kinematics::Twist& v, const Eigen::VectorXd& previous, double dt);

// The pose-goal law at time `t` of its trajectory: the feed-forward twist plus
// the position and orientation gains on the error from `q`'s tool pose to the
// reference pose, through cartesian_step.
CartesianStep pose_goal_step(const RobotLinkConfig& config, const CartesianTrajectory& trajectory, double t,
                             const Eigen::VectorXd& q, const Eigen::VectorXd& previous, double dt);

// The pose-goal law run offline: from joints `q` and previous command
// `previous`, pose_goal_step every SYNC period (config.can.sync_period) with q
// integrated, for the trajectory's duration and then until the tool is within
// the tolerances of the goal or `settle` more seconds have passed.
struct PoseGoalDryRun {
  Eigen::VectorXd q;               // joints at the end
  double position_error = 0.0;     // tool to goal at the end [m]
  double orientation_error = 0.0;  // [rad]
  double time = 0.0;               // simulated [s]
  int steps = 0;
  int position_clipped_steps = 0;  // steps in which a joint was held at its position limit
  bool reached = false;            // within the tolerances at the end
};
PoseGoalDryRun dry_run_pose_goal(const RobotLinkConfig& config, const CartesianTrajectory& trajectory,
                                 Eigen::VectorXd q, Eigen::VectorXd previous, const DryRunOptions& options = {});

// The same dry run in slices, so no control period does more than a bounded
// share of it: run(n) takes at most n more steps and returns true once the
// result is final. `config` must outlive the runner.
class PoseGoalDryRunner {
 public:
  PoseGoalDryRunner(const RobotLinkConfig& config, CartesianTrajectory trajectory, Eigen::VectorXd q,
                    Eigen::VectorXd previous, const DryRunOptions& options);
  bool run(int64_t max_steps);
  bool done() const { return done_; }
  const PoseGoalDryRun& result() const { return out_; }
  const CartesianTrajectory& trajectory() const { return trajectory_; }

 private:
  void measure();
  const RobotLinkConfig* config_;
  CartesianTrajectory trajectory_;
  Eigen::VectorXd q_, previous_;
  DryRunOptions options_;
  double dt_;
  int64_t end_of_path_ = 0, last_ = 0, k_ = 0;
  bool done_ = false;
  PoseGoalDryRun out_;
};

// "the straight path's dry run stops 12.0 mm, 0.430 rad short (at joint limits)": why a dry run is not enough.
std::string dry_run_shortfall(const PoseGoalDryRun& dry_run);

// The joint-space way from `q` to `solution` (joints for a pose goal): the
// straight joint-space interpolation, sampled at most 0.01 rad of joint motion
// apart, must keep the tool inside config.workspace (else none, and `why`
// says where it leaves). A JointTrajectory within the model's joint speed and
// acceleration limits, as for TYPE_JOINT_GOAL (`why` gives its duration).
std::optional<JointTrajectory> joint_space_path(const RobotLinkConfig& config, const Eigen::VectorXd& q,
                                                const Eigen::VectorXd& solution, std::string* why);
// The joint-space way to the arm's home posture (config.model.home) when
// `goal` is its home pose (1 mm, 0.01 rad), else none: a known joint
// solution, so going home never waits on, or fails in, an IK search.
std::optional<JointTrajectory> home_path(const RobotLinkConfig& config, const Eigen::VectorXd& q,
                                         const Eigen::Isometry3d& goal, std::string* why = nullptr);

// How a new pose goal is executed: the Cartesian trajectory if its dry run
// reaches the goal; else, if kinematics::solve_pose (seeded at the current
// joints) finds joints for it and joint_space_path accepts the way there, that
// JointTrajectory; else it is refused. RobotLinkNode takes the same decision
// without blocking (the IK spread over its control periods); this is the
// all-at-once form (tests, benchmark).
struct PoseGoalPlan {
  enum class Way { kCartesian, kJointSpace, kUnreachable };
  Way way = Way::kUnreachable;
  PoseGoalDryRun dry_run;
  std::optional<JointTrajectory> joints;  // kJointSpace
  std::string why;                        // one line for the log or the refusal
};
PoseGoalPlan plan_pose_goal(const RobotLinkConfig& config, const CartesianTrajectory& trajectory,
                            const Eigen::VectorXd& q, const Eigen::VectorXd& previous);

class RobotLinkNode final : public rt::Node {
 public:
  // `bus` may be injected (tests); otherwise config.bus is opened in on_attach.
  explicit RobotLinkNode(RobotLinkConfig config, std::unique_ptr<can::CanBus> bus = nullptr);
  ~RobotLinkNode() override;

  void begin_shutdown() override;
  bool shutdown_complete() const override { return shutdown_done_; }

 protected:
  void on_attach() override;

 private:
  // kPlanning: a new pose goal whose Cartesian dry run fell short, its IK
  // running (a slice per period) while the arm holds. kPoseGoalInJoints: a
  // pose goal executed on a JointTrajectory.
  enum class Active { kNone, kTwist, kPoseGoal, kPlanning, kPoseGoalInJoints, kJointGoal };
  // First the Cartesian dry run (in slices), then, if it falls short, the IK.
  struct Planning {
    harvest::robot_command_t cmd;
    Eigen::Isometry3d goal;
    PoseGoalDryRunner dry_run;
    std::string shortfall;                           // dry_run_shortfall, once the dry run fell short
    std::optional<kinematics::PoseSolver> solver;    // the IK, once the dry run fell short
    std::optional<CartesianTrajectory> best_effort;  // the straight path, if its dry run ended near enough
  };

  void tick();
  void on_command(const harvest::robot_command_t& cmd);
  void on_estop(const harvest::emergency_stop_t& msg);
  void on_operator(const harvest::operator_command_t& msg);
  void refuse(const harvest::robot_command_t& cmd, const std::string& why);
  void accept_pose_goal(const harvest::robot_command_t& cmd, const Eigen::Isometry3d& goal);
  // Why a command asks for something not physical or not plannable (empty if fine).
  std::string implausible(const harvest::robot_command_t& cmd) const;
  void continue_planning();
  void decide_after_dry_run();
  void pose_goal_unreachable(const harvest::robot_command_t& cmd, const Eigen::Isometry3d& goal,
                             const std::string& why);
  void limit_event(const std::string& why);
  // This period's joint velocity command (all limits applied) for the active command.
  Eigen::VectorXd command_velocity(double dt);
  void supervise();
  void publish_state(const Eigen::VectorXd& cmd, Micros sampled);
  void restart_master();

  RobotLinkConfig config_;
  std::unique_ptr<can::CanBus> bus_;
  security::Authority authority_;
  std::unique_ptr<canopen::Master> master_;
  std::map<std::string, int64_t> mirrored_;  // master_->counters() already counted in the heartbeat
  MotionSupervisor supervisor_;
  Eigen::VectorXd q_, qd_, last_cmd_;
  bool have_joints_ = false;

  Active active_ = Active::kNone;
  kinematics::Twist twist_ = kinematics::Twist::Zero();
  std::optional<CartesianTrajectory> pose_traj_;
  std::optional<JointTrajectory> joint_traj_;
  std::optional<Planning> planning_;
  Micros traj_start_ = 0;
  int64_t goal_id_ = -1;
  // The last pose goal refused as unreachable: its resends are refused again without planning.
  std::optional<int64_t> unreachable_goal_id_;
  Eigen::Isometry3d unreachable_goal_ = Eigen::Isometry3d::Identity();
  std::string unreachable_text_;
  int64_t last_command_seq_ = -1;
  int64_t last_command_utime_ = 0;

  int32_t limit_events_ = 0;
  bool limited_now_ = false;
  bool refused_ = false;
  std::string limit_text_;
  // Limits that come and go every control period (or two that alternate),
  // and refusals of a stray publisher's commands, are logged at most once a
  // second, with how many events the line stands for, not 50 times a second.
  rt::LogLimiter limit_log_;
  Micros enable_started_ = 0;
  bool enable_timed_out_ = false;
  Micros last_sync_ = 0;
  bool shutting_down_ = false;
  bool shutdown_done_ = false;
  int shutdown_wait_ = 0;  // periods waited for the drives to disable while faulted
};

}  // namespace harvest::arm
