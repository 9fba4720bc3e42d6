// Motion safety of the robot link, independent of the controller: command
// limits and workspace clipping, command freshness (watchdog), and the
// latched fault and emergency-stop states. Pure logic, time passed in.
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <string>

#include "kinematics/chain.hpp"

namespace harvest::arm {

using Micros = int64_t;

// Axis-aligned box the tool centre point must stay in (base frame, metres).
struct Workspace {
  Eigen::Vector3d min = Eigen::Vector3d::Constant(-2.0);
  Eigen::Vector3d max = Eigen::Vector3d::Constant(2.0);
  bool contains(const Eigen::Vector3d& p) const {
    return (p.array() >= min.array()).all() && (p.array() <= max.array()).all();
  }
};

struct MotionLimits {
  double linear_speed = 0.381;  // [m/s] thesis: 15 in/s
  double angular_speed = 1.0;   // [rad/s]
  double linear_acceleration = 0.5;
  double angular_acceleration = 2.0;
  Micros default_validity = 100'000;  // command validity when the command says 0
  Micros max_validity = 1'000'000;    // longer validities are cut to this
};

struct ClippedTwist {
  kinematics::Twist twist;
  bool clipped = false;
  std::string reason;  // why, for the log and robot_state_t.fault_text
};

// Scales a twist down to the speed limits (direction kept) and slows the
// linear velocity components heading for a workspace face so the tool
// reaches it within `dt` at most and can still brake to rest at it with
// `limits.linear_acceleration` (motion along or back into the workspace
// stays allowed).
ClippedTwist clip_twist(const kinematics::Twist& twist, const Eigen::Vector3d& tcp, const Workspace& workspace,
                        const MotionLimits& limits, double dt);

// Latches faults and emergency stops and watches command freshness.
class MotionSupervisor {
 public:
  explicit MotionSupervisor(MotionLimits limits) : limits_(limits) {}

  // Emergency stop: engaged latches; only engaged = false with clear = true releases.
  void on_emergency_stop(bool engaged, bool clear, const std::string& why);
  void on_fault(const std::string& text);  // latches; texts accumulate
  // Operator RESET_FAULT. Returns false (and keeps the latch) while an
  // emergency stop is engaged: that needs its own clear.
  bool reset_fault();

  // A command was accepted at `now` with validity `validity_us` (0 = default).
  void on_command(Micros now, Micros validity_us);
  void cancel_command() { has_command_ = false; }
  bool command_fresh(Micros now) const { return has_command_ && now <= command_deadline_; }
  bool had_command() const { return has_command_; }

  bool estopped() const { return estop_; }
  bool faulted() const { return fault_; }
  bool may_move() const { return !estop_ && !fault_; }
  const std::string& fault_text() const { return fault_text_; }
  const std::string& estop_text() const { return estop_text_; }
  const MotionLimits& limits() const { return limits_; }

 private:
  MotionLimits limits_;
  bool estop_ = false;
  bool fault_ = false;
  std::string fault_text_, estop_text_;
  bool has_command_ = false;
  Micros command_deadline_ = 0;
};

}  // namespace harvest::arm
