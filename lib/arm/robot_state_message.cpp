#include "arm/robot_state_message.hpp"

#include "arm/fault_flags.hpp"
#include "geometry/pose_msg.hpp"
#include "kinematics/chain.hpp"

namespace harvest::arm {

using harvest::robot_state_t;

int8_t robot_mode(const MotionSupervisor& supervisor, const LinkSnapshot& link, bool fresh) {
  const bool moving = link.cmd.norm() > 1e-9 || link.qd.norm() > 1e-3;
  if (supervisor.estopped()) return robot_state_t::MODE_ESTOP;
  if (supervisor.faulted()) return robot_state_t::MODE_FAULT;
  if (link.shutting_down && !link.drives_enabled) return robot_state_t::MODE_DISABLED;
  if (!link.drives_enabled) return robot_state_t::MODE_ENABLING;
  if (moving && fresh && link.has_motion) return robot_state_t::MODE_MOVING;
  if (moving) return robot_state_t::MODE_STOPPING;
  return robot_state_t::MODE_IDLE;
}

robot_state_t robot_state_message(const kinematics::ArmModel& model, const MotionSupervisor& supervisor,
                                  const std::vector<canopen::DriveStatus>& drives, const LinkSnapshot& link,
                                  Micros now) {
  const int n = model.dof();
  const bool fresh = supervisor.command_fresh(now);
  robot_state_t s{};
  s.header.utime = link.sampled;
  s.header.frame_id = "base";
  s.header.source_seq = link.last_command_seq;
  s.mode = robot_mode(supervisor, link, fresh);
  s.num_joints = n;
  s.joint_position.assign(link.q.data(), link.q.data() + n);
  s.joint_velocity.assign(link.qd.data(), link.qd.data() + n);
  s.joint_velocity_cmd.assign(link.cmd.data(), link.cmd.data() + n);
  for (const auto& d : drives) {
    s.drive_state.push_back(static_cast<int8_t>(d.state));
    s.drive_error_code.push_back(d.error_code);
  }
  s.tool_pose = geometry::to_pose(kinematics::tool_pose(model, link.q));
  s.camera_pose = geometry::to_pose(kinematics::camera_pose(model, link.q));
  const kinematics::Twist v = kinematics::tool_jacobian(model, link.q) * link.qd;
  for (int i = 0; i < 3; ++i) {
    s.tool_twist.linear[i] = v[i];
    s.tool_twist.angular[i] = v[3 + i];
  }
  s.last_command_seq = link.last_command_seq;
  s.command_stale = supervisor.had_command() && !fresh;
  int32_t flags = link.hardware_flags;
  if (supervisor.estopped()) flags |= kFlagEstop;
  if (s.command_stale) flags |= kFlagCommandStale;
  if (link.limited) flags |= kFlagLimited;
  if (link.joint_limited) flags |= kFlagJointLimit;
  if (link.refused) flags |= kFlagRefused;
  if (link.enable_timed_out) flags |= kFlagEnableTimeout;
  s.fault_flags = flags;
  std::string text = supervisor.estopped() ? supervisor.estop_text() : "";
  if (supervisor.faulted()) text += (text.empty() ? "" : "; ") + supervisor.fault_text();
  if (!link.limit_text.empty()) text += (text.empty() ? "" : "; ") + link.limit_text;
  s.fault_text = text;
  s.num_limit_events = link.limit_events;
  return s;
}

}  // namespace harvest::arm
