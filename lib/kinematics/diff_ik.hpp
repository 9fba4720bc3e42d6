// Differential inverse kinematics and joint limits.
//
// Damped least squares (Nakamura & Hanafusa; damping ramps up only near a
// singularity, so away from one the task is tracked exactly) with the
// redundancy spent on staying near the arm's rest posture (away from joint
// limits and singularities): a gradient step on the distance to it, projected
// into the Jacobian's null space so it never disturbs the tool.
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <optional>
#include <vector>

#include "kinematics/arm_model.hpp"
#include "kinematics/chain.hpp"

namespace harvest::kinematics {

struct IkOptions {
  double max_damping = 0.05;         // lambda at a singularity
  double singular_threshold = 0.04;  // smallest singular value below which damping ramps in
  double null_space_gain = 0.5;      // joint-centring speed at a limit [rad/s]
  // joint_velocity_within_limits: a joint heading for its limit goes on at its
  // stopping speed (motion control), or stops where it is if it would pass the
  // limit within dt (the pose solver's Newton steps: pinned at a limit, a
  // search stalls there).
  bool brake_at_limits = true;
};

// Joint velocities that produce `twist` (TCP linear, tool angular; base frame).
// Joints flagged in `locked` (if given) do not move; the others compensate.
Eigen::VectorXd joint_velocity_for_twist(const ArmModel& model, const Eigen::VectorXd& q, const Twist& twist,
                                         const IkOptions& options = {}, const std::vector<bool>* locked = nullptr);

// The fastest `joint` at `q` may move in `direction` (its sign) for `dt` and
// still stop at the limit it heads for, braking by its acceleration limit
// times dt each period after (braking distance v^2 / 2a + v dt, the drive's
// ramp to each command included, and a dt^2 / 2 kept for the ramp of the
// period in flight), reaching it no sooner than `dt`; 0 at or past that limit.
double stopping_speed(const Joint& joint, double q, double direction, double dt);

// Where the joints will be when a command sent now takes hold: a drive applies
// a command at the next SYNC, so the one `in_flight` (sent last period) moves
// them for one more period first. `q` itself without one.
Eigen::VectorXd where_a_command_takes_hold(const Eigen::VectorXd& q, const Eigen::VectorXd* in_flight, double dt);

// As joint_velocity_for_twist, but a joint that would move toward a position
// limit faster than its stopping_speed is held at that speed and the rest of
// the twist re-solved with the remaining joints (the redundancy takes over),
// so the tool still moves as commanded while the others can make it up.
// Returns the held-joint count in `num_locked`. `in_flight`: the command sent
// last period, the room to a limit measured from where it leaves the joints
// (pass the same `previous` as to limit_joint_velocity, so that the limiter
// after finds nothing more to clip).
Eigen::VectorXd joint_velocity_within_limits(const ArmModel& model, const Eigen::VectorXd& q, const Twist& twist,
                                             double dt, const IkOptions& options = {}, int* num_locked = nullptr,
                                             const Eigen::VectorXd* in_flight = nullptr);

// Result of limiting a joint velocity command.
struct LimitedVelocity {
  Eigen::VectorXd qdot;
  bool velocity_scaled = false;      // a joint speed limit scaled the whole vector
  bool acceleration_scaled = false;  // the change was scaled to respect acceleration limits
  bool position_clipped = false;     // some joint was slowed to stop at its position limit
};

// Makes `desired` respect the joint limits over one control period `dt`
// starting at (q, previous): speed limits and acceleration limits scale the
// whole vector (keeps the direction of motion); near a position limit a joint
// may only move toward it as fast as it can still stop before it, from where
// `previous` (still in flight) leaves it.
LimitedVelocity limit_joint_velocity(const ArmModel& model, const Eigen::VectorXd& q, const Eigen::VectorXd& previous,
                                     const Eigen::VectorXd& desired, double dt);

// Pose error (position, rotation vector) from current to desired, base frame.
Twist pose_error(const Eigen::Isometry3d& desired, const Eigen::Isometry3d& current);

struct PoseSolveOptions {
  IkOptions ik{.null_space_gain = 0.05, .brake_at_limits = false};  // per iteration: small, so the steps converge
  double position_tolerance = 1e-5;                                 // [m]
  double orientation_tolerance = 1e-4;                              // [rad]
  int max_iterations = 1000;                                        // per start
  int restarts = 8;                                                 // further starts if one stalls at a joint limit
};

// Joint configuration placing the tool at `target`, found by iterating the
// differential IK from `seed` while staying inside the joint limits. If that
// stalls (a local minimum against a limit), it restarts from a fixed,
// deterministic spread of configurations, so the answer is reproducible.
std::optional<Eigen::VectorXd> solve_pose(const ArmModel& model, const Eigen::Isometry3d& target,
                                          const Eigen::VectorXd& seed, const PoseSolveOptions& options = {});

// solve_pose in resumable pieces, for a caller that must not block for the
// whole search (the robot link spreads it over its control periods): the same
// starts and iterations, so the same answer. `model` must outlive the solver.
class PoseSolver {
 public:
  PoseSolver(const ArmModel& model, const Eigen::Isometry3d& target, const Eigen::VectorXd& seed,
             const PoseSolveOptions& options = {});
  // Runs at most `iterations` more iterations (one pose error and one Newton
  // step each); returns done().
  bool run(int iterations);
  bool done() const { return done_; }
  // Once done: the joints found, or none if every start ran out of iterations.
  const std::optional<Eigen::VectorXd>& solution() const { return solution_; }
  int iterations() const { return total_; }  // so far, over all starts

 private:
  void next_start();

  const ArmModel* model_;
  Eigen::Isometry3d target_;
  PoseSolveOptions options_;
  Eigen::VectorXd q_, lo_, hi_;
  int restart_ = 0;    // restarts begun
  int iteration_ = 0;  // iterations of the current start
  int total_ = 0;
  uint32_t random_ = 12345u;  // restart seeds: a small linear congruential generator with a constant seed
  bool done_ = false;
  std::optional<Eigen::VectorXd> solution_;
};

}  // namespace harvest::kinematics
