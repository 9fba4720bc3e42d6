// How the robot link executes a pose goal: the Cartesian straight path if
// its dry run (the control law simulated from the current joints) reaches
// the goal; else a joint-space path to a joint solution (the home posture's,
// or an IK search's); else the straight path if it ends near enough; else
// the goal is refused as unreachable. PoseGoalPlanner takes that decision in
// bounded slices, so the link's control loop keeps its period.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cstdint>
#include <optional>
#include <string>

#include "arm/cartesian_control.hpp"
#include "arm/robot_link_config.hpp"
#include "arm/trajectory.hpp"
#include "kinematics/diff_ik.hpp"

namespace harvest::arm {

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

// The decision on a pose goal. `why` is one line for the log (after "pose
// goal N: ") or, for kUnreachable, the refusal.
struct PoseGoalPlan {
  enum class Way { kPending, kCartesian, kJointSpace, kUnreachable };
  Way way = Way::kPending;
  PoseGoalDryRun dry_run;
  std::optional<CartesianTrajectory> cartesian;  // kCartesian
  std::optional<JointTrajectory> joints;         // kJointSpace
  std::string why;
  int ik_iterations = 0;
};

// The decision in slices: each run() does at most one bounded slice, first
// of the dry run (config.dry_run.steps_per_period steps), then, if it falls
// short and the goal is not the home pose, of the IK search
// (config.ik_iterations_per_period iterations, kinematics::PoseSolver seeded
// at the joints of that moment). `q` is where the arm is now (it holds while
// the link plans). `config` must outlive the planner.
class PoseGoalPlanner {
 public:
  PoseGoalPlanner(const RobotLinkConfig& config, CartesianTrajectory straight, const Eigen::VectorXd& q,
                  const Eigen::VectorXd& previous);
  // True once plan() is decided.
  bool run(const Eigen::VectorXd& q) {
    return run(q, config_->dry_run.steps_per_period, config_->ik_iterations_per_period);
  }
  bool run(const Eigen::VectorXd& q, int64_t dry_run_steps, int ik_iterations);
  bool done() const { return plan_.way != PoseGoalPlan::Way::kPending; }
  const PoseGoalPlan& plan() const { return plan_; }
  const Eigen::Isometry3d& goal() const { return dry_run_.trajectory().goal(); }
  const PoseGoalDryRunner& dry_run() const { return dry_run_; }  // its progress so far

 private:
  void decide_after_dry_run(const Eigen::VectorXd& q);
  void decide_after_ik(const Eigen::VectorXd& q);

  const RobotLinkConfig* config_;
  PoseGoalDryRunner dry_run_;
  std::string shortfall_;                         // dry_run_shortfall, once the dry run fell short
  std::optional<kinematics::PoseSolver> solver_;  // the IK, once the dry run fell short
  PoseGoalPlan plan_;
};

// The same decision all at once (tests, benchmark): the planner run without
// slicing, from joints `q` that do not move.
PoseGoalPlan plan_pose_goal(const RobotLinkConfig& config, const CartesianTrajectory& trajectory,
                            const Eigen::VectorXd& q, const Eigen::VectorXd& previous);

}  // namespace harvest::arm
