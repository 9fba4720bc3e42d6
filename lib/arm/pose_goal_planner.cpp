#include "arm/pose_goal_planner.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>

#include "runtime/clock.hpp"

namespace harvest::arm {

PoseGoalDryRunner::PoseGoalDryRunner(const RobotLinkConfig& config, CartesianTrajectory trajectory, Eigen::VectorXd q,
                                     Eigen::VectorXd previous, const DryRunOptions& options)
    : config_(&config),
      trajectory_(std::move(trajectory)),
      q_(std::move(q)),
      previous_(std::move(previous)),
      options_(options),
      dt_(rt::to_seconds(config.can.sync_period)) {
  // Step counts in doubles first: a goal that would take forever must not
  // overflow them (callers refuse goals longer than options.max_duration).
  const double path = std::min(std::ceil(trajectory_.duration() / dt_), 1e12);
  end_of_path_ = std::isfinite(path) ? static_cast<int64_t>(path) : int64_t{1'000'000'000'000};
  last_ = end_of_path_ + static_cast<int64_t>(std::ceil(options_.settle / dt_));
}

void PoseGoalDryRunner::measure() {
  const kinematics::Twist e = kinematics::pose_error(trajectory_.goal(), kinematics::tool_pose(config_->model, q_));
  out_.position_error = e.head<3>().norm();
  out_.orientation_error = e.tail<3>().norm();
  // A path that ends with a joint pressed against its limit is not one to count on: the arm's drives lag the
  // dry run's ideal joints, and at the edge of reach, with joints held at their limits, the rig stopped 10 mm short
  // of a goal this dry run reached (RobotLinkNode.ReorientationsFromHomeOverAGrid).
  out_.reached = out_.position_error <= options_.position_tolerance &&
                 out_.orientation_error <= options_.orientation_tolerance &&
                 config_->model.within_limits(q_, options_.end_joint_margin);
}

bool PoseGoalDryRunner::run(int64_t max_steps) {
  if (done_) return true;
  for (int64_t budget = max_steps; k_ < last_; ++k_) {
    if (budget-- <= 0) return false;
    if (k_ >= end_of_path_) {
      measure();
      if (out_.reached) break;
    }
    const CartesianStep step = pose_goal_step(*config_, trajectory_, static_cast<double>(k_) * dt_, q_, previous_, dt_);
    if (step.position_clipped) ++out_.position_clipped_steps;
    q_ += step.qdot * dt_;
    previous_ = step.qdot;
    ++out_.steps;
  }
  measure();
  out_.time = out_.steps * dt_;
  out_.q = q_;
  done_ = true;
  return true;
}

PoseGoalDryRun dry_run_pose_goal(const RobotLinkConfig& config, const CartesianTrajectory& trajectory,
                                 Eigen::VectorXd q, Eigen::VectorXd previous, const DryRunOptions& options) {
  PoseGoalDryRunner runner(config, trajectory, std::move(q), std::move(previous), options);
  runner.run(std::numeric_limits<int64_t>::max());
  return runner.result();
}

std::string dry_run_shortfall(const PoseGoalDryRun& d) {
  return fmt::format("the straight path's dry run stops {:.1f} mm, {:.3f} rad short{}", 1000.0 * d.position_error,
                     d.orientation_error, d.position_clipped_steps > 0 ? " at joint limits" : "");
}

std::optional<JointTrajectory> joint_space_path(const RobotLinkConfig& config, const Eigen::VectorXd& q,
                                                const Eigen::VectorXd& solution, std::string* why) {
  const Eigen::VectorXd delta = solution - q;
  const int samples = std::max(20, static_cast<int>(std::ceil(delta.cwiseAbs().maxCoeff() / 0.01)));
  // The tool's speed along the path per unit of the path parameter (linear,
  // angular), largest over the samples: what the joint speed limits alone
  // would let the tool point reach.
  double dp_ds = 0.0, dr_ds = 0.0;
  Eigen::Isometry3d previous = kinematics::tool_pose(config.model, q);
  for (int i = 0; i <= samples; ++i) {
    const Eigen::VectorXd qi = q + (static_cast<double>(i) / samples) * delta;
    const Eigen::Isometry3d pose = kinematics::tool_pose(config.model, qi);
    const Eigen::Vector3d p = pose.translation();
    dp_ds = std::max(dp_ds, (p - previous.translation()).norm() * samples);
    dr_ds = std::max(dr_ds, Eigen::AngleAxisd(pose.linear() * previous.linear().transpose()).angle() * samples);
    previous = pose;
    if (!config.workspace.contains(p)) {
      if (why != nullptr)
        *why =
            fmt::format("the joint-space path to its joint solution leaves the workspace at ({:.3f}, {:.3f}, {:.3f}) m",
                        p.x(), p.y(), p.z());
      return std::nullopt;
    }
  }
  JointTrajectory path(q, solution, config.model.max_velocity(), config.model.max_acceleration());
  // The tool's speed limits hold in joint space too: slow the whole motion
  // down (speeds by f, accelerations by f^2: the same profile, 1/f longer)
  // until neither the tool point's nor the tool's turning speed exceeds them.
  const double peak = path.scaling().peak_ds();
  const double f = std::min({1.0, dp_ds * peak > 0 ? config.limits.linear_speed / (dp_ds * peak) : 1.0,
                             dr_ds * peak > 0 ? config.limits.angular_speed / (dr_ds * peak) : 1.0});
  if (f < 1.0)
    path = JointTrajectory(q, solution, f * config.model.max_velocity(), f * f * config.model.max_acceleration());
  if (why != nullptr)
    *why = fmt::format("joint space, {:.2f} s{}, largest joint move {:.2f} rad", path.duration(),
                       f < 1.0 ? fmt::format(" (x{:.2f} for the tool's speed limits)", 1.0 / f) : std::string(),
                       delta.cwiseAbs().maxCoeff());
  return path;
}

std::optional<JointTrajectory> home_path(const RobotLinkConfig& config, const Eigen::VectorXd& q,
                                         const Eigen::Isometry3d& goal, std::string* why) {
  // The arm's home posture is a known joint solution of the home pose: going
  // home must not depend on what an IK search from wherever the arm is finds.
  const kinematics::Twist e = kinematics::pose_error(goal, kinematics::tool_pose(config.model, config.model.home));
  if (e.head<3>().norm() > 1e-3 || e.tail<3>().norm() > 1e-2) return std::nullopt;
  std::string how;
  auto path = joint_space_path(config, q, config.model.home, &how);
  if (path && why != nullptr) *why = "to the home posture, " + how;
  return path;
}

PoseGoalPlanner::PoseGoalPlanner(const RobotLinkConfig& config, CartesianTrajectory straight, const Eigen::VectorXd& q,
                                 const Eigen::VectorXd& previous)
    : config_(&config), dry_run_(config, std::move(straight), q, previous, config.dry_run) {}

bool PoseGoalPlanner::run(const Eigen::VectorXd& q, int64_t dry_run_steps, int ik_iterations) {
  if (done()) return true;
  if (!solver_) {
    if (dry_run_.run(dry_run_steps)) decide_after_dry_run(q);
  } else if (solver_->run(ik_iterations)) {
    decide_after_ik(q);
  }
  return done();
}

void PoseGoalPlanner::decide_after_dry_run(const Eigen::VectorXd& q) {
  const PoseGoalDryRun& dry = dry_run_.result();
  plan_.dry_run = dry;
  if (dry.reached) {
    const double tol = config_->dry_run.home_posture_tolerance;
    Eigen::Index joint = 0;
    const double off = (dry.q - config_->model.home).cwiseAbs().maxCoeff(&joint);
    std::string home_why;
    if (tol > 0.0 && off > tol && (plan_.joints = home_path(*config_, q, goal(), &home_why))) {
      plan_.way = PoseGoalPlan::Way::kJointSpace;
      plan_.why = fmt::format("the straight path home ends in another posture (joint {} {:.0f} deg from home's); {}",
                              joint + 1, off * 180.0 / std::numbers::pi, home_why);
      return;
    }
    plan_.way = PoseGoalPlan::Way::kCartesian;
    plan_.cartesian.emplace(dry_run_.trajectory());
    plan_.why = fmt::format("Cartesian (the straight path's dry run ends {:.1f} mm, {:.3f} rad from it)",
                            1000.0 * dry.position_error, dry.orientation_error);
    return;
  }
  shortfall_ = dry_run_shortfall(dry);
  std::string home_why;
  if ((plan_.joints = home_path(*config_, q, goal(), &home_why))) {
    plan_.way = PoseGoalPlan::Way::kJointSpace;
    plan_.why = shortfall_ + "; " + home_why;
    return;
  }
  solver_.emplace(config_->model, goal(), q);  // the IK goes on in the next slices
}

void PoseGoalPlanner::decide_after_ik(const Eigen::VectorXd& q) {
  plan_.ik_iterations = solver_->iterations();
  std::string why = fmt::format("no joint solution was found ({} IK iterations)", plan_.ik_iterations);
  if (solver_->solution()) plan_.joints = joint_space_path(*config_, q, *solver_->solution(), &why);
  if (plan_.joints) {
    plan_.way = PoseGoalPlan::Way::kJointSpace;
    plan_.why = fmt::format("{}; {} ({} IK iterations)", shortfall_, why, plan_.ik_iterations);
  } else if (config_->dry_run.near_enough(plan_.dry_run.position_error, plan_.dry_run.orientation_error)) {
    // No joint-space way either: the straight path gets the arm as close as it can.
    plan_.way = PoseGoalPlan::Way::kCartesian;
    plan_.cartesian.emplace(dry_run_.trajectory());
    plan_.why = shortfall_ + ", and " + why + ": the straight path, as near as it gets";
  } else {
    plan_.way = PoseGoalPlan::Way::kUnreachable;
    plan_.why = shortfall_ + ", and " + why;
  }
}

PoseGoalPlan plan_pose_goal(const RobotLinkConfig& config, const CartesianTrajectory& trajectory,
                            const Eigen::VectorXd& q, const Eigen::VectorXd& previous) {
  PoseGoalPlanner planner(config, trajectory, q, previous);
  while (!planner.run(q, std::numeric_limits<int64_t>::max(), std::numeric_limits<int>::max())) {
  }
  return planner.plan();
}

}  // namespace harvest::arm
