// The robot link node: owns the CAN bus of the arm. Every SYNC period it reads
// the drives, applies motion safety, turns the current command into joint
// velocities (differential IK, limits) and sends them, then publishes
// ROBOT_STATE. See docs/robot-link.md.
#pragma once

#include <harvest/emergency_stop_t.hpp>
#include <harvest/operator_command_t.hpp>
#include <harvest/robot_command_t.hpp>
#include <harvest/robot_state_t.hpp>
#include <memory>
#include <optional>
#include <string>

#include "arm/motion_safety.hpp"
#include "arm/trajectory.hpp"
#include "can/can_bus.hpp"
#include "canopen/master.hpp"
#include "config/config.hpp"
#include "kinematics/diff_ik.hpp"
#include "runtime/node.hpp"

namespace harvest::arm {

struct RobotLinkConfig {
  std::string bus = "udp_multicast:239.74.163.2:43113";
  kinematics::ArmModel model;
  canopen::MasterConfig can;
  MotionLimits limits;
  Workspace workspace;
  double position_gain = 5.0;
  double orientation_gain = 5.0;
  double joint_gain = 5.0;
  Micros enable_timeout = 3'000'000;

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
};

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
  enum class Active { kNone, kTwist, kPoseGoal, kJointGoal };

  void tick();
  void on_command(const harvest::robot_command_t& cmd);
  void on_estop(const harvest::emergency_stop_t& msg);
  void on_operator(const harvest::operator_command_t& msg);
  void refuse(const harvest::robot_command_t& cmd, const std::string& why);
  void limit_event(const std::string& why);
  Eigen::VectorXd desired_velocity(double dt);
  void supervise();
  void publish_state(const Eigen::VectorXd& cmd, Micros sampled);
  void restart_master();

  RobotLinkConfig config_;
  std::unique_ptr<can::CanBus> bus_;
  std::unique_ptr<canopen::Master> master_;
  MotionSupervisor supervisor_;
  Eigen::VectorXd q_, qd_, last_cmd_;
  bool have_joints_ = false;

  Active active_ = Active::kNone;
  kinematics::Twist twist_ = kinematics::Twist::Zero();
  std::optional<CartesianTrajectory> pose_traj_;
  std::optional<JointTrajectory> joint_traj_;
  Micros traj_start_ = 0;
  int64_t goal_id_ = -1;
  int64_t last_command_seq_ = -1;
  int64_t last_command_utime_ = 0;

  int32_t limit_events_ = 0;
  bool limited_now_ = false;
  bool refused_ = false;
  std::string limit_text_;
  Micros enable_started_ = 0;
  bool enable_timed_out_ = false;
  Micros last_sync_ = 0;
  bool shutting_down_ = false;
  bool shutdown_done_ = false;
  int shutdown_wait_ = 0;  // periods waited for the drives to disable while faulted
};

}  // namespace harvest::arm
