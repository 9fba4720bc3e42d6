// The robot link node: owns the CAN bus of the arm. Every SYNC period it
// reads the drives (ArmHardware), applies motion safety (MotionSupervisor),
// turns the active motion into joint velocities (cartesian_control, joint
// trajectories, all limits applied) and writes them, then publishes
// ROBOT_STATE. New pose goals are planned in slices (PoseGoalPlanner).
// Commands pass the command authority and command_problem first. See
// docs/robot-link.md.
#pragma once

#include <harvest/emergency_stop_t.hpp>
#include <harvest/operator_command_t.hpp>
#include <harvest/robot_command_t.hpp>
#include <harvest/robot_state_t.hpp>
#include <memory>
#include <optional>
#include <string>

#include "arm/arm_hardware.hpp"
#include "arm/cartesian_control.hpp"
#include "arm/fault_flags.hpp"
#include "arm/motion.hpp"
#include "arm/motion_safety.hpp"
#include "arm/pose_goal_planner.hpp"
#include "arm/robot_link_config.hpp"
#include "can/can_bus.hpp"
#include "runtime/log_limiter.hpp"
#include "runtime/node.hpp"
#include "security/authority.hpp"

namespace harvest::arm {

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
  void tick();
  void log_own_stalls(Micros t);
  void on_command(const harvest::robot_command_t& cmd);
  void on_estop(const harvest::emergency_stop_t& msg);
  void on_operator(const harvest::operator_command_t& msg);
  void refuse(const harvest::robot_command_t& cmd, const std::string& why);
  void start_pose_goal(const harvest::robot_command_t& cmd);
  void start_joint_goal(const harvest::robot_command_t& cmd);
  // One slice of the active PlanningMotion; once decided, the motion it leads to.
  void continue_planning();
  void limit_event(const std::string& why);
  // This period's joint velocity command (all limits applied) for the active motion.
  Eigen::VectorXd command_velocity(double dt);
  // The drives' faults and the enable timeout into the supervisor.
  void supervise();
  // At shutdown: ramp to rest, disable the drives, stop them (NMT).
  Eigen::VectorXd shut_down(bool enabled, double dt);
  void publish_state(const Eigen::VectorXd& cmd);
  void restart_drives();

  RobotLinkConfig config_;
  ArmHardware hardware_;
  security::Authority authority_;
  MotionSupervisor supervisor_;
  Eigen::VectorXd q_, qd_, last_cmd_;
  bool have_joints_ = false;

  Motion motion_;
  // The last pose goal refused as unreachable: its resends are refused again without planning.
  std::optional<int64_t> unreachable_goal_id_;
  Eigen::Isometry3d unreachable_goal_ = Eigen::Isometry3d::Identity();
  std::string unreachable_text_;
  int64_t last_command_seq_ = -1;

  int32_t limit_events_ = 0;
  bool limited_now_ = false;
  bool joint_limited_now_ = false;  // ... a joint braking for its position limit (kFlagJointLimit)
  bool refused_ = false;
  std::string limit_text_;
  // Limits that come and go every control period (or two that alternate),
  // and refusals of a stray publisher's commands, are logged at most once a
  // second, with how many events the line stands for, not 50 times a second.
  rt::LogLimiter limit_log_;
  // The link's own stalls (its loop not run for longer than can.own_stall_ms), at most a line every 10 s.
  rt::LogLimiter stall_log_{10 * rt::kSecond};
  int64_t stalls_seen_ = 0;
  Micros enable_started_ = 0;
  bool enable_timed_out_ = false;
  bool shutting_down_ = false;
  bool shutdown_done_ = false;
  int shutdown_wait_ = 0;  // periods waited for the drives to disable while faulted
};

}  // namespace harvest::arm
