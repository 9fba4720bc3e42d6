#include "kinematics/diff_ik.hpp"

#include <Eigen/SVD>
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>

namespace harvest::kinematics {

Eigen::VectorXd joint_velocity_for_twist(const ArmModel& model, const Eigen::VectorXd& q, const Twist& twist,
                                         const IkOptions& options, const std::vector<bool>* locked) {
  const int n = model.dof();
  Jacobian j = tool_jacobian(model, q);
  const auto is_locked = [&](int i) { return locked != nullptr && (*locked)[i]; };
  for (int i = 0; i < n; ++i)
    if (is_locked(i)) j.col(i).setZero();
  const Eigen::JacobiSVD<Eigen::MatrixXd> svd(j, Eigen::ComputeThinU | Eigen::ComputeThinV);
  const Eigen::VectorXd& s = svd.singularValues();
  const double s_min = s[s.size() - 1];
  double lambda2 = 0.0;
  if (s_min < options.singular_threshold) {
    const double r = s_min / options.singular_threshold;
    lambda2 = options.max_damping * options.max_damping * (1.0 - r * r);
  }
  Eigen::VectorXd inv(s.size());
  for (int i = 0; i < s.size(); ++i) inv[i] = s[i] / (s[i] * s[i] + lambda2);
  const Eigen::MatrixXd& v = svd.matrixV();
  Eigen::VectorXd qdot = v * inv.asDiagonal() * svd.matrixU().transpose() * twist;

  // Null-space motion toward the rest posture, scaled by each joint's range.
  // Not toward the middle of each range: for a pitch joint that is the
  // straight, singular configuration (a straight elbow cannot pull the tool
  // back; a straight wrist swings its two rolls against their limits). A
  // locked joint's column is zero, so its component passes the projector
  // unchanged: it must be zero here.
  Eigen::VectorXd centring(n);
  for (int i = 0; i < n; ++i) {
    const auto& jt = model.joints[i];
    centring[i] = is_locked(i) ? 0.0 : -options.null_space_gain * (q[i] - model.rest[i]) / (0.5 * (jt.max - jt.min));
  }
  // Projector onto the null space of the full-rank part of J.
  Eigen::MatrixXd projector = Eigen::MatrixXd::Identity(n, n);
  for (int i = 0; i < s.size(); ++i)
    if (s[i] > 1e-9) projector -= v.col(i) * v.col(i).transpose();
  qdot += projector * centring;
  return qdot;
}

double stopping_speed(const Joint& joint, double q, double direction, double dt) {
  const double a = joint.max_acceleration;
  if (!(a > 0.0)) return 0.0;  // cannot brake: nothing toward the limit (as sqrt(2 a room) gave)
  // The period in flight ramps from the speed before it, up to a dt^2 / 2 further than its command alone goes.
  const double room = std::max(0.0, (direction > 0 ? joint.max - q : q - joint.min) - 0.5 * a * dt * dt);
  // Braking in steps of a dt from v covers v dt + (v - a dt) dt + ... = v^2 / 2a + v dt / 2 for commands held over
  // whole periods; a drive ramps to each new command within the period, which adds up to another v dt / 2. From
  // v^2 / 2a + v dt = room: each period's allowed speed is at most a dt below the last (the continuous
  // sqrt(2 a room) braked faster than a in the last steps, and joints passed their limits by up to 1.7 mrad).
  return std::min(a * (std::sqrt(dt * dt + 2.0 * room / a) - dt), room / dt);
}

Eigen::VectorXd where_a_command_takes_hold(const Eigen::VectorXd& q, const Eigen::VectorXd* in_flight, double dt) {
  return in_flight != nullptr ? Eigen::VectorXd(q + *in_flight * dt) : q;
}

Eigen::VectorXd joint_velocity_within_limits(const ArmModel& model, const Eigen::VectorXd& q, const Twist& twist,
                                             double dt, const IkOptions& options, int* num_locked,
                                             const Eigen::VectorXd* in_flight) {
  const int n = model.dof();
  const Eigen::VectorXd from = where_a_command_takes_hold(q, in_flight, dt);
  std::vector<bool> locked(static_cast<std::size_t>(n), false);
  Eigen::VectorXd fixed = Eigen::VectorXd::Zero(n);  // the locked joints' velocities
  Eigen::VectorXd qdot = joint_velocity_for_twist(model, q, twist, options);
  int count = 0;
  for (int pass = 0; pass < n; ++pass) {
    bool changed = false;
    for (int i = 0; i < n; ++i) {
      // Only motion further out is limited: a joint that overshot its limit
      // (by its deceleration) must stay free to come back inside. A joint
      // braking for its limit goes on at the speed it may still have, and the
      // others make up the rest of the twist: braked after the solution
      // instead, the tool would swerve off the commanded motion (seen on the
      // tree: the shoulder roll braking at 170 deg during an IR approach moved
      // the tool 150 mm sideways, its axis off the fruit).
      const auto& jt = model.joints[i];
      const double next = from[i] + qdot[i] * dt;
      const bool passes = (qdot[i] > 0 && next > jt.max) || (qdot[i] < 0 && next < jt.min);
      const double allowed =
          options.brake_at_limits ? stopping_speed(jt, from[i], qdot[i], dt) : (passes ? 0.0 : INFINITY);
      if (!locked[i] && std::abs(qdot[i]) > allowed) {
        locked[i] = true;
        fixed[i] = std::copysign(allowed, qdot[i]);
        changed = true;
        ++count;
      }
    }
    if (!changed) break;
    const Twist rest_of_twist = twist - tool_jacobian(model, q) * fixed;
    qdot = joint_velocity_for_twist(model, q, rest_of_twist, options, &locked);
    for (int i = 0; i < n; ++i)
      if (locked[i]) qdot[i] = fixed[i];
  }
  if (num_locked != nullptr) *num_locked = count;
  return qdot;
}

LimitedVelocity limit_joint_velocity(const ArmModel& model, const Eigen::VectorXd& q, const Eigen::VectorXd& previous,
                                     const Eigen::VectorXd& desired, double dt) {
  const int n = model.dof();
  LimitedVelocity out;
  Eigen::VectorXd qd = desired;

  double speed_scale = 1.0;
  for (int i = 0; i < n; ++i) {
    const double v = std::abs(qd[i]);
    if (v > model.joints[i].max_velocity) speed_scale = std::min(speed_scale, model.joints[i].max_velocity / v);
  }
  if (speed_scale < 1.0) {
    qd *= speed_scale;
    out.velocity_scaled = true;
  }

  double accel_scale = 1.0;
  const Eigen::VectorXd change = qd - previous;
  for (int i = 0; i < n; ++i) {
    const double max_change = model.joints[i].max_acceleration * dt;
    if (std::abs(change[i]) > max_change) accel_scale = std::min(accel_scale, max_change / std::abs(change[i]));
  }
  if (accel_scale < 1.0) {
    qd = previous + accel_scale * change;
    out.acceleration_scaled = true;
  }
  // Position limits last, so they win over the acceleration limit: moving toward a limit at most as fast as it can
  // still stop there with the joint's deceleration (and reach it within dt), from where `previous` leaves it.
  const Eigen::VectorXd from = where_a_command_takes_hold(q, &previous, dt);
  for (int i = 0; i < n; ++i) {
    const auto& jt = model.joints[i];
    const double allowed = stopping_speed(jt, from[i], qd[i], dt);
    if (std::abs(qd[i]) > allowed) {
      qd[i] = std::copysign(allowed, qd[i]);
      out.position_clipped = true;
    }
  }

  out.qdot = qd;
  return out;
}

Twist pose_error(const Eigen::Isometry3d& desired, const Eigen::Isometry3d& current) {
  Twist e;
  e.head<3>() = desired.translation() - current.translation();
  e.tail<3>() = orientation_error(desired.linear(), current.linear());
  return e;
}

PoseSolver::PoseSolver(const ArmModel& model, const Eigen::Isometry3d& target, const Eigen::VectorXd& seed,
                       const PoseSolveOptions& options)
    : model_(&model), target_(target), options_(options), q_(seed), lo_(model.lower()), hi_(model.upper()) {}

void PoseSolver::next_start() {
  if (restart_ >= options_.restarts) {
    done_ = true;
    return;
  }
  // Restart seeds: the joint-range centres perturbed by a fixed sequence.
  const auto uniform = [this] {
    random_ = random_ * 1664525u + 1013904223u;
    return static_cast<double>(random_ >> 8) / static_cast<double>(1u << 24);
  };
  for (int i = 0; i < model_->dof(); ++i) {
    const auto& jt = model_->joints[i];
    q_[i] = jt.min + (0.25 + 0.5 * uniform()) * (jt.max - jt.min);
  }
  ++restart_;
  iteration_ = 0;
}

bool PoseSolver::run(int iterations) {
  while (!done_ && iterations > 0) {
    if (iteration_ >= options_.max_iterations) {  // this start stalled (a local minimum against a limit)
      next_start();
      continue;
    }
    --iterations;
    ++iteration_;
    ++total_;
    const Twist e = pose_error(target_, tool_pose(*model_, q_));
    if (e.head<3>().norm() < options_.position_tolerance && e.tail<3>().norm() < options_.orientation_tolerance) {
      solution_ = q_;
      done_ = true;
      break;
    }
    // A Newton step on the pose error, bounded so the linearisation holds.
    Eigen::VectorXd step = joint_velocity_within_limits(*model_, q_, e, 1.0, options_.ik);
    const double norm = step.norm();
    if (norm > 0.2) step *= 0.2 / norm;
    q_ = (q_ + step).cwiseMax(lo_).cwiseMin(hi_);
  }
  return done_;
}

std::optional<Eigen::VectorXd> solve_pose(const ArmModel& model, const Eigen::Isometry3d& target,
                                          const Eigen::VectorXd& seed, const PoseSolveOptions& options) {
  PoseSolver solver(model, target, seed, options);
  solver.run(std::numeric_limits<int>::max());
  return solver.solution();
}

}  // namespace harvest::kinematics
