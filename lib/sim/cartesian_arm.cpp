#include "sim/cartesian_arm.hpp"

#include <algorithm>
#include <cmath>

namespace harvest::sim {
namespace {

constexpr double kDefaultValidity = 0.1;  // [s] when a command leaves validity_us at 0

Vec3 clamp_norm(const Vec3& v, double max) {
  const double n = v.norm();
  return n > max ? Vec3(v * (max / n)) : v;
}

Vec3 from_array(const double a[3]) { return Vec3(a[0], a[1], a[2]); }

// Rotation vector taking `from` to `to` (base frame).
Vec3 rotation_error(const Mat3& to, const Mat3& from) {
  const Eigen::AngleAxisd aa(to * from.transpose());
  return aa.angle() * aa.axis();
}

}  // namespace

void to_pose(const Placement& p, pose_t& out) {
  const Eigen::Quaterniond q(p.rotation);
  for (int i = 0; i < 3; ++i) out.position[i] = p.position[i];
  out.orientation[0] = q.w();
  out.orientation[1] = q.x();
  out.orientation[2] = q.y();
  out.orientation[3] = q.z();
}

CartesianArm::CartesianArm(const ArmSetup& setup, const Placement& start, const Placement& reported_hand_eye)
    : setup_(setup), reported_hand_eye_(reported_hand_eye), tool_(start) {}

Placement CartesianArm::hand_camera() const { return compose(tool_, setup_.hand_eye); }

bool CartesianArm::command(const robot_command_t& cmd, double t) {
  if (cmd.type == robot_command_t::TYPE_JOINT_GOAL || cmd.type < 0 || cmd.type > robot_command_t::TYPE_JOINT_GOAL) {
    ++refused_;
    return false;
  }
  type_ = cmd.type;
  last_seq_ = cmd.header.seq;
  valid_until_ = t + (cmd.validity_us > 0 ? cmd.validity_us * 1e-6 : kDefaultValidity);
  if (type_ == robot_command_t::TYPE_TWIST) {
    cmd_v_ = clamp_norm(from_array(cmd.twist.linear), setup_.max_linear_speed);
    cmd_w_ = clamp_norm(from_array(cmd.twist.angular), setup_.max_angular_speed);
  } else if (type_ == robot_command_t::TYPE_POSE_GOAL) {
    const auto& o = cmd.pose_goal.orientation;
    Eigen::Quaterniond q(o[0], o[1], o[2], o[3]);
    if (q.norm() < 1e-9) {
      ++refused_;
      type_ = robot_command_t::TYPE_STOP;
      return false;
    }
    goal_ = {q.normalized().toRotationMatrix(), from_array(cmd.pose_goal.position)};
    goal_speed_ =
        cmd.max_linear_speed > 0 ? std::min(cmd.max_linear_speed, setup_.max_linear_speed) : setup_.max_linear_speed;
    goal_angular_speed_ = cmd.max_angular_speed > 0 ? std::min(cmd.max_angular_speed, setup_.max_angular_speed)
                                                    : setup_.max_angular_speed;
    // A goal motion runs to completion; it does not need refreshing.
    valid_until_ = std::numeric_limits<double>::infinity();
  }
  return true;
}

void CartesianArm::step(double t) {
  const double dt = std::max(0.0, t - last_t_);
  last_t_ = t;
  if (dt == 0.0) return;
  Vec3 want_v = Vec3::Zero(), want_w = Vec3::Zero();
  if (t <= valid_until_) {
    if (type_ == robot_command_t::TYPE_TWIST) {
      want_v = cmd_v_;
      want_w = cmd_w_;
    } else if (type_ == robot_command_t::TYPE_POSE_GOAL) {
      // Approach with the speed that still lets the arm stop within the acceleration limit.
      const Vec3 e = goal_.position - tool_.position;
      const double stop_speed = std::sqrt(2.0 * setup_.max_linear_accel * e.norm());
      want_v = clamp_norm(e / std::max(dt, 1e-3), std::min(goal_speed_, stop_speed));
      // The wrist is light (angular rate follows at once, see below): turn at
      // the speed limit and land on the goal orientation in the last step.
      want_w = clamp_norm(rotation_error(goal_.rotation, tool_.rotation) / std::max(dt, 1e-3), goal_angular_speed_);
    }
  }
  v_ += clamp_norm(want_v - v_, setup_.max_linear_accel * dt);
  w_ = want_w;  // the wrist is light: angular rate follows at once
  tool_.position += v_ * dt;
  const double angle = w_.norm() * dt;
  if (angle > 0.0) tool_.rotation = Eigen::AngleAxisd(angle, w_.normalized()).toRotationMatrix() * tool_.rotation;
}

void CartesianArm::fill_state(robot_state_t& s, double t) const {
  s.mode = moving() ? robot_state_t::MODE_MOVING : robot_state_t::MODE_IDLE;
  s.num_joints = 0;
  s.joint_position.clear();
  s.joint_velocity.clear();
  s.joint_velocity_cmd.clear();
  s.drive_state.clear();
  s.drive_error_code.clear();
  to_pose(tool_, s.tool_pose);
  // As the robot link reports it: the tool pose times the software's hand-eye.
  to_pose(compose(tool_, reported_hand_eye_), s.camera_pose);
  for (int i = 0; i < 3; ++i) {
    s.tool_twist.linear[i] = v_[i];
    s.tool_twist.angular[i] = w_[i];
  }
  s.last_command_seq = last_seq_;
  s.command_stale = command_stale(t);
  s.fault_flags = 0;
  s.fault_text.clear();
  s.num_limit_events = refused_;
}

}  // namespace harvest::sim
