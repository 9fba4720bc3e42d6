// A stand-in arm for "direct" hardware mode: the tool centre point follows
// robot_command_t (twist, pose goal, stop) in Cartesian space with speed and
// acceleration limits and the command validity window, with no joints. It
// lets the simulator replace the robot link and its drives on the bus when a
// run does not need the CAN path (quick tests, controller development).
#pragma once

#include <cstdint>

#include "harvest/robot_command_t.hpp"
#include "harvest/robot_state_t.hpp"
#include "sim/scenario.hpp"

namespace harvest::sim {

class CartesianArm {
 public:
  // `reported_hand_eye` is the software's camera-in-hand calibration (camera
  // in the tool frame): ROBOT_STATE's camera pose is computed with it, as the
  // robot link computes it, while hand_camera() is the truth (setup.hand_eye).
  CartesianArm(const ArmSetup& setup, const Placement& start, const Placement& reported_hand_eye);

  // Accepts a command received at time t [s]. Returns false (and ignores it)
  // for command types this arm cannot follow (joint goals).
  bool command(const robot_command_t& cmd, double t);
  // Integrates the motion up to time t [s].
  void step(double t);

  const Placement& tool() const { return tool_; }
  Placement hand_camera() const;  // the true camera-in-hand pose
  const Vec3& linear_velocity() const { return v_; }
  const Vec3& angular_velocity() const { return w_; }
  bool moving() const { return v_.norm() > 1e-6 || w_.norm() > 1e-6; }
  bool command_stale(double t) const { return t > valid_until_; }
  int64_t last_command_seq() const { return last_seq_; }
  int32_t refused() const { return refused_; }

  // Fills the kinematic part of a robot state (poses, twist, mode).
  void fill_state(robot_state_t& state, double t) const;

 private:
  ArmSetup setup_;
  Placement reported_hand_eye_;
  Placement tool_;
  Vec3 v_ = Vec3::Zero(), w_ = Vec3::Zero();
  int8_t type_ = robot_command_t::TYPE_STOP;
  Vec3 cmd_v_ = Vec3::Zero(), cmd_w_ = Vec3::Zero();
  Placement goal_;
  double goal_speed_ = 0.0, goal_angular_speed_ = 0.0;
  double valid_until_ = -1.0, last_t_ = 0.0;
  int64_t last_seq_ = -1;
  int32_t refused_ = 0;
};

// pose_t <-> Placement (the rotation must be proper to become a quaternion).
void to_pose(const Placement& p, pose_t& out);

}  // namespace harvest::sim
