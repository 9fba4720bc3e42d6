#include "arm/motion_safety.hpp"

#include <algorithm>
#include <cmath>

namespace harvest::arm {

ClippedTwist clip_twist(const kinematics::Twist& twist, const Eigen::Vector3d& tcp, const Workspace& workspace,
                        const MotionLimits& limits, double dt) {
  ClippedTwist out{twist, false, {}};
  Eigen::Vector3d v = twist.head<3>();
  Eigen::Vector3d w = twist.tail<3>();
  if (!v.allFinite() || !w.allFinite()) {
    out.twist.setZero();
    out.clipped = true;
    out.reason = "non-finite twist refused";
    return out;
  }
  if (v.norm() > limits.linear_speed) {
    v *= limits.linear_speed / v.norm();
    out.clipped = true;
    out.reason = "linear speed limited to " + std::to_string(limits.linear_speed) + " m/s";
  }
  if (w.norm() > limits.angular_speed) {
    w *= limits.angular_speed / w.norm();
    out.clipped = true;
    out.reason = "angular speed limited to " + std::to_string(limits.angular_speed) + " rad/s";
  }
  static const char* kAxis[] = {"x", "y", "z"};
  for (int a = 0; a < 3; ++a) {
    if (v[a] == 0.0) continue;
    // Distance to the face the motion heads for (0 if already on or past it).
    const double room = std::max(0.0, v[a] > 0 ? workspace.max[a] - tcp[a] : tcp[a] - workspace.min[a]);
    // At most reach the face within dt, and no faster than one can still
    // brake to rest at it with the linear acceleration limit.
    const double allowed = std::min(room / dt, std::sqrt(2.0 * limits.linear_acceleration * room));
    if (std::abs(v[a]) > allowed) {
      v[a] = std::copysign(allowed, v[a]);
      out.clipped = true;
      out.reason = std::string("workspace boundary in ") + kAxis[a];
    }
  }
  out.twist.head<3>() = v;
  out.twist.tail<3>() = w;
  return out;
}

void MotionSupervisor::on_emergency_stop(bool engaged, bool clear, const std::string& why) {
  if (engaged) {
    estop_ = true;
    estop_text_ = "emergency stop: " + why;
    has_command_ = false;
  } else if (clear && estop_) {
    estop_ = false;
    estop_text_.clear();
  }
}

void MotionSupervisor::on_fault(const std::string& text) {
  if (fault_ && fault_text_.find(text) != std::string::npos) return;
  fault_ = true;
  fault_text_ = fault_text_.empty() ? text : fault_text_ + "; " + text;
  has_command_ = false;
}

bool MotionSupervisor::reset_fault() {
  if (estop_) return false;
  fault_ = false;
  fault_text_.clear();
  return true;
}

void MotionSupervisor::on_command(Micros now, Micros validity_us) {
  Micros v = validity_us <= 0 ? limits_.default_validity : validity_us;
  v = std::min(v, limits_.max_validity);
  has_command_ = true;
  command_deadline_ = now + v;
}

}  // namespace harvest::arm
