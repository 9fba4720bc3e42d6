#include "arm/robot_link_node.hpp"

#include <fmt/format.h>
#include <sched.h>
#include <spdlog/spdlog.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstring>
#include <limits>

#include "geometry/envelope.hpp"
#include "geometry/pose_msg.hpp"
#include "runtime/channels.hpp"

namespace harvest::arm {
namespace {

using canopen::Cia402State;
using canopen::DriveGoal;
using canopen::MasterPhase;

}  // namespace

RobotLinkConfig RobotLinkConfig::from_config(const config::Node& root) {
  RobotLinkConfig c;
  c.bus = canopen::bus_from_config(root, "bus", c.bus);
  c.model = kinematics::ArmModel::load(root.file_path("arm_model", "k1207i.yaml").string());
  c.can = canopen::MasterConfig::from_config(root.child("can"));
  if (static_cast<int>(c.can.drives.size()) != c.model.dof())
    root.child("can").fail("drives", "one drive per joint of the arm model (" + std::to_string(c.model.dof()) + ")");
  // The drives' own quick-stop ramp (written as 0x6085): what stops the arm
  // when the link is gone, so it is ours to set, not the drive vendor's.
  const double quick_stop = root.child("can").get<double>("quick_stop_deceleration_factor", 10.0, {0.5, 50.0});
  for (std::size_t i = 0; i < c.can.drives.size(); ++i)
    c.can.drives[i].quick_stop_deceleration = quick_stop * c.model.joints[i].max_acceleration;
  // Workspace and speed/acceleration limits: the envelope the controller also reads.
  const auto envelope = geometry::Envelope::from_config(root, "envelope", "envelope.yaml");
  c.limits.linear_speed = envelope.max_linear_speed;
  c.limits.angular_speed = envelope.max_angular_speed;
  c.limits.linear_acceleration = envelope.max_linear_acceleration;
  c.limits.angular_acceleration = envelope.max_angular_acceleration;
  c.workspace.min = envelope.min;
  c.workspace.max = envelope.max;
  const auto lim = root.child("limits");
  c.limits.default_validity = lim.get<int>("default_validity_ms", 100, {10, 1000}) * 1000;
  c.limits.max_validity = lim.get<int>("max_validity_ms", 1000, {10, 10000}) * 1000;
  if (c.limits.default_validity > c.limits.max_validity)
    lim.fail("default_validity_ms",
             "a validity no longer than max_validity_ms (" + std::to_string(c.limits.max_validity / 1000) + " ms)");
  c.command_limits.min_goal_linear_speed =
      lim.get<double>("min_goal_linear_speed", c.command_limits.min_goal_linear_speed, {1e-4, 0.1});
  c.command_limits.min_goal_angular_speed =
      lim.get<double>("min_goal_angular_speed", c.command_limits.min_goal_angular_speed, {1e-4, 0.5});
  c.command_limits.non_physical_factor =
      lim.get<double>("non_physical_factor", c.command_limits.non_physical_factor, {1.0, 100.0});
  if (c.command_limits.min_goal_linear_speed > c.limits.linear_speed)
    lim.fail("min_goal_linear_speed", "a speed no greater than the envelope's max_linear_speed");
  if (c.command_limits.min_goal_angular_speed > c.limits.angular_speed)
    lim.fail("min_goal_angular_speed", "a speed no greater than the envelope's max_angular_speed");
  const auto ctl = root.child("control");
  c.position_gain = ctl.get<double>("position_gain", 5.0, {0.0, 100.0});
  c.orientation_gain = ctl.get<double>("orientation_gain", 5.0, {0.0, 100.0});
  c.joint_gain = ctl.get<double>("joint_gain", 5.0, {0.0, 100.0});
  c.enable_timeout = ctl.get<int>("enable_timeout_ms", 3000, {100, 60000}) * 1000;
  c.realtime_priority = ctl.get<int>("realtime_priority", 0, {0, 99});
  c.authority = security::AuthorityConfig::from_config(root.child("authority"), security::AuthorityConfig::kController);
  return c;
}

CartesianStep cartesian_step(const RobotLinkConfig& config, const Eigen::VectorXd& q, const Eigen::Isometry3d& tool,
                             const kinematics::Twist& v, const Eigen::VectorXd& previous, double dt) {
  CartesianStep out;
  out.clip = clip_twist(v, tool.translation(), config.workspace, config.limits, dt);
  const Eigen::VectorXd want = kinematics::joint_velocity_within_limits(config.model, q, out.clip.twist, dt);
  const auto lim = kinematics::limit_joint_velocity(config.model, q, previous, want, dt);
  out.qdot = lim.qdot;
  out.position_clipped = lim.position_clipped;
  return out;
}

CartesianStep pose_goal_step(const RobotLinkConfig& config, const CartesianTrajectory& trajectory, double t,
                             const Eigen::VectorXd& q, const Eigen::VectorXd& previous, double dt) {
  const Eigen::Isometry3d tool = kinematics::tool_pose(config.model, q);
  const kinematics::Twist e = kinematics::pose_error(trajectory.pose(t), tool);
  kinematics::Twist v = trajectory.twist(t);
  v.head<3>() += config.position_gain * e.head<3>();
  v.tail<3>() += config.orientation_gain * e.tail<3>();
  return cartesian_step(config, q, tool, v, previous, dt);
}

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
  out_.reached =
      out_.position_error <= options_.position_tolerance && out_.orientation_error <= options_.orientation_tolerance;
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

PoseGoalPlan plan_pose_goal(const RobotLinkConfig& config, const CartesianTrajectory& trajectory,
                            const Eigen::VectorXd& q, const Eigen::VectorXd& previous) {
  PoseGoalPlan plan;
  plan.dry_run = dry_run_pose_goal(config, trajectory, q, previous, config.dry_run);
  if (plan.dry_run.reached) {
    plan.way = PoseGoalPlan::Way::kCartesian;
    plan.why = fmt::format("the straight path's dry run ends {:.1f} mm, {:.3f} rad from it",
                           1000.0 * plan.dry_run.position_error, plan.dry_run.orientation_error);
    return plan;
  }
  const std::string shortfall = dry_run_shortfall(plan.dry_run);
  std::string home_why;
  if ((plan.joints = home_path(config, q, trajectory.goal(), &home_why))) {
    plan.way = PoseGoalPlan::Way::kJointSpace;
    plan.why = shortfall + "; " + home_why;
    return plan;
  }
  const auto solution = kinematics::solve_pose(config.model, trajectory.goal(), q);
  std::string why = "no joint solution was found";
  if (solution) plan.joints = joint_space_path(config, q, *solution, &why);
  if (plan.joints) {
    plan.way = PoseGoalPlan::Way::kJointSpace;
    plan.why = shortfall + "; " + why;
  } else if (config.dry_run.near_enough(plan.dry_run.position_error, plan.dry_run.orientation_error)) {
    plan.way = PoseGoalPlan::Way::kCartesian;
    plan.why = shortfall + ", and " + why + ": the straight path, as near as it gets";
  } else {
    plan.why = shortfall + ", and " + why;
  }
  return plan;
}

RobotLinkNode::RobotLinkNode(RobotLinkConfig config, std::unique_ptr<can::CanBus> bus)
    : rt::Node("robot_link"),
      config_(std::move(config)),
      bus_(std::move(bus)),
      authority_(config_.authority, config_.authority.load(config_.bus), clock(),
                 [this](const std::string& counter, int64_t n) { count(counter, n); }),
      supervisor_(config_.limits) {
  const int n = config_.model.dof();
  q_ = config_.model.home;
  qd_ = Eigen::VectorXd::Zero(n);
  last_cmd_ = Eigen::VectorXd::Zero(n);
}

RobotLinkNode::~RobotLinkNode() = default;

void RobotLinkNode::on_attach() {
  if (config_.realtime_priority > 0) {
    sched_param p{};
    p.sched_priority = config_.realtime_priority;
    if (::sched_setscheduler(0, SCHED_FIFO, &p) == 0)
      spdlog::info("control loop at SCHED_FIFO priority {}", config_.realtime_priority);
    else
      spdlog::warn(
          "control loop at normal priority: SCHED_FIFO {} refused ({}); a loaded computer may stall it "
          "past the drives' RPDO deadline",
          config_.realtime_priority, std::strerror(errno));
  }
  if (!bus_) bus_ = can::open_bus(config_.bus);  // throws CanError with the reason
  restart_master();
  if (bus_->fd() >= 0) ctx().watch_fd(bus_->fd(), [this] { master_->drain(now()); });
  subscribe<harvest::robot_command_t>(channels::kRobotCommand, [this](const auto& m) { on_command(m); });
  subscribe<harvest::emergency_stop_t>(channels::kEmergencyStop, [this](const auto& m) { on_estop(m); });
  subscribe<harvest::operator_command_t>(channels::kOperatorCommand, [this](const auto& m) { on_operator(m); });
  advertise(channels::kRobotState);
  every(config_.can.sync_period, [this] { tick(); });
  spdlog::info("robot link on {}: {} drives, SYNC every {} us", bus_->describe(), config_.can.drives.size(),
               config_.can.sync_period);
  spdlog::info("robot link: {}", authority_.describe());
}

void RobotLinkNode::restart_master() {
  master_ = std::make_unique<canopen::Master>(*bus_, config_.can);
  mirrored_.clear();
  master_->start(now());
  master_->set_goal(DriveGoal::kEnabled);
  enable_started_ = now();
  enable_timed_out_ = false;
  set_health(rt::Health::kStarting, "configuring drives");
}

void RobotLinkNode::begin_shutdown() {
  shutting_down_ = true;
  active_ = Active::kNone;
  supervisor_.cancel_command();
  if (!master_ || master_->phase() != MasterPhase::kRunning) shutdown_done_ = true;
  spdlog::info("stopping the arm and disabling the drives");
}

void RobotLinkNode::limit_event(const std::string& why) {
  ++limit_events_;
  limit_text_ = why;
  count("limit_events");
  int64_t unlogged = 0;
  Micros since = 0;
  if (!limit_log_.admit(now(), unlogged, since)) return;
  if (unlogged > 0)
    spdlog::warn("command limited: {} (and {} limit events not logged in the {:.1f} s before)", why, unlogged,
                 rt::to_seconds(since));
  else
    spdlog::warn("command limited: {}", why);
}

void RobotLinkNode::refuse(const harvest::robot_command_t& cmd, const std::string& why) {
  refused_ = true;
  limit_event("command seq " + std::to_string(cmd.header.seq) + " refused: " + why);
  count("commands_refused");
}

std::string RobotLinkNode::implausible(const harvest::robot_command_t& cmd) const {
  const CommandLimits& c = config_.command_limits;
  if (cmd.type == harvest::robot_command_t::TYPE_TWIST) {
    const Eigen::Vector3d v(cmd.twist.linear[0], cmd.twist.linear[1], cmd.twist.linear[2]);
    const Eigen::Vector3d w(cmd.twist.angular[0], cmd.twist.angular[1], cmd.twist.angular[2]);
    if (!v.allFinite() || !w.allFinite()) return "twist is not finite";
    if (v.norm() > c.non_physical_factor * config_.limits.linear_speed ||
        w.norm() > c.non_physical_factor * config_.limits.angular_speed)
      return fmt::format(
          "twist of {:.4g} m/s, {:.4g} rad/s is not physical: more than {:g}x the limits ({:g} m/s, {:g} rad/s; "
          "limits.non_physical_factor)",
          v.norm(), w.norm(), c.non_physical_factor, config_.limits.linear_speed, config_.limits.angular_speed);
  }
  if (cmd.type == harvest::robot_command_t::TYPE_POSE_GOAL) {
    const double vmax = cmd.max_linear_speed, wmax = cmd.max_angular_speed;
    if (!std::isfinite(vmax) || vmax < 0.0 || !std::isfinite(wmax) || wmax < 0.0)
      return "max_linear_speed and max_angular_speed must be 0 (the link's limits) or a positive speed";
    if (vmax > 0.0 && vmax < c.min_goal_linear_speed)
      return fmt::format("max_linear_speed {:g} m/s is below the minimum {:g} m/s (limits.min_goal_linear_speed)", vmax,
                         c.min_goal_linear_speed);
    if (wmax > 0.0 && wmax < c.min_goal_angular_speed)
      return fmt::format("max_angular_speed {:g} rad/s is below the minimum {:g} rad/s (limits.min_goal_angular_speed)",
                         wmax, c.min_goal_angular_speed);
  }
  return {};
}

void RobotLinkNode::on_command(const harvest::robot_command_t& cmd) {
  if (shutting_down_) return;
  if (!authority_.admit_from_controller("ROBOT_COMMAND", cmd)) return;  // counted and logged by the gate
  if (!supervisor_.may_move()) {
    count("commands_while_stopped");
    return;  // not a limit event: the state already says why nothing moves
  }
  const Micros t = now();
  const int n = config_.model.dof();
  refused_ = false;
  switch (cmd.type) {
    case harvest::robot_command_t::TYPE_STOP:
      active_ = Active::kNone;
      supervisor_.cancel_command();
      break;
    case harvest::robot_command_t::TYPE_TWIST: {
      if (const std::string why = implausible(cmd); !why.empty()) return refuse(cmd, why);
      kinematics::Twist v;
      v << cmd.twist.linear[0], cmd.twist.linear[1], cmd.twist.linear[2], cmd.twist.angular[0], cmd.twist.angular[1],
          cmd.twist.angular[2];
      active_ = Active::kTwist;
      twist_ = v;
      break;
    }
    case harvest::robot_command_t::TYPE_POSE_GOAL: {
      const auto& p = cmd.pose_goal;
      const Eigen::Vector3d pos(p.position[0], p.position[1], p.position[2]);
      Eigen::Quaterniond q(p.orientation[0], p.orientation[1], p.orientation[2], p.orientation[3]);
      if (!pos.allFinite() || !q.coeffs().allFinite() || std::abs(q.norm() - 1.0) > 1e-3)
        return refuse(cmd, "pose goal is not a position and a unit quaternion");
      if (!config_.workspace.contains(pos)) return refuse(cmd, "pose goal outside the workspace");
      if (const std::string why = implausible(cmd); !why.empty()) return refuse(cmd, why);
      if ((active_ == Active::kPoseGoal || active_ == Active::kPlanning || active_ == Active::kPoseGoalInJoints) &&
          cmd.goal_id == goal_id_)
        break;  // same goal, refreshed
      Eigen::Isometry3d goal = Eigen::Isometry3d::Identity();
      goal.translation() = pos;
      goal.linear() = q.normalized().toRotationMatrix();
      if (unreachable_goal_id_ == cmd.goal_id && goal.isApprox(unreachable_goal_, 1e-12)) {
        // A resend of a goal found unreachable: still refused, not planned
        // again, and the same refusal (no new limit event).
        refused_ = true;
        limit_text_ = unreachable_text_;
        count("commands_refused");
        return;
      }
      accept_pose_goal(cmd, goal);
      break;
    }
    case harvest::robot_command_t::TYPE_JOINT_GOAL: {
      if (cmd.num_joints != n) return refuse(cmd, "joint goal has " + std::to_string(cmd.num_joints) + " joints");
      const Eigen::VectorXd goal = Eigen::Map<const Eigen::VectorXd>(cmd.joint_goal.data(), n);
      if (!goal.allFinite() || !config_.model.within_limits(goal))
        return refuse(cmd, "joint goal outside joint limits");
      if (!config_.workspace.contains(kinematics::tool_pose(config_.model, goal).translation()))
        return refuse(cmd, "joint goal puts the tool outside the workspace");
      if (active_ == Active::kJointGoal && cmd.goal_id == goal_id_) break;
      Eigen::VectorXd vmax = config_.model.max_velocity();
      joint_traj_.emplace(q_, goal, vmax, config_.model.max_acceleration());
      traj_start_ = t;
      goal_id_ = cmd.goal_id;
      active_ = Active::kJointGoal;
      break;
    }
    default:
      return refuse(cmd, "unknown command type " + std::to_string(cmd.type));
  }
  if (cmd.type != harvest::robot_command_t::TYPE_STOP) supervisor_.on_command(t, cmd.validity_us);
  last_command_seq_ = cmd.header.seq;
  last_command_utime_ = cmd.header.utime;
}

void RobotLinkNode::accept_pose_goal(const harvest::robot_command_t& cmd, const Eigen::Isometry3d& goal) {
  CartesianTrajectory::Limits lim{config_.limits.linear_speed, config_.limits.angular_speed,
                                  config_.limits.linear_acceleration, config_.limits.angular_acceleration};
  if (cmd.max_linear_speed > 0) lim.linear_speed = std::min(lim.linear_speed, cmd.max_linear_speed);
  if (cmd.max_angular_speed > 0) lim.angular_speed = std::min(lim.angular_speed, cmd.max_angular_speed);
  CartesianTrajectory path(kinematics::tool_pose(config_.model, q_), goal, lim);
  if (!(path.duration() <= config_.dry_run.max_duration))
    return refuse(cmd, fmt::format("the pose goal would take {:.0f} s, more than the {:.0f} s a goal may take",
                                   path.duration(), config_.dry_run.max_duration));
  goal_id_ = cmd.goal_id;
  traj_start_ = now();
  planning_.reset();
  if (!config_.pose_goal_joint_fallback) {  // no dry run: Cartesian, as before
    pose_traj_.emplace(path);
    active_ = Active::kPoseGoal;
    return;
  }
  // The dry run runs a bounded slice here (a typical goal's whole dry run) and
  // goes on after each SYNC (continue_planning) while the arm holds.
  planning_.emplace(Planning{
      cmd, goal, PoseGoalDryRunner(config_, path, q_, last_cmd_, config_.dry_run), {}, std::nullopt, std::nullopt});
  active_ = Active::kPlanning;
  if (planning_->dry_run.run(config_.dry_run.steps_per_period)) decide_after_dry_run();
}

void RobotLinkNode::decide_after_dry_run() {
  Planning& p = *planning_;
  const PoseGoalDryRun& dry = p.dry_run.result();
  const int64_t goal_id = p.cmd.goal_id;
  if (dry.reached) {
    pose_traj_.emplace(p.dry_run.trajectory());
    active_ = Active::kPoseGoal;
    traj_start_ = now();
    count("pose_goals_cartesian");
    spdlog::info("pose goal {}: Cartesian (the straight path's dry run ends {:.1f} mm, {:.3f} rad from it)", goal_id,
                 1000.0 * dry.position_error, dry.orientation_error);
    planning_.reset();
    return;
  }
  p.shortfall = dry_run_shortfall(dry);
  std::string home_why;
  if ((joint_traj_ = home_path(config_, q_, p.goal, &home_why))) {
    active_ = Active::kPoseGoalInJoints;
    traj_start_ = now();
    count("pose_goals_joint_space");
    spdlog::info("pose goal {}: {}; {}", goal_id, p.shortfall, home_why);
    planning_.reset();
    return;
  }
  // The IK runs a slice per control period (continue_planning) while the arm holds.
  p.solver.emplace(config_.model, p.goal, q_);
  if (config_.dry_run.near_enough(dry.position_error, dry.orientation_error))
    p.best_effort.emplace(p.dry_run.trajectory());
}

void RobotLinkNode::continue_planning() {
  // It goes on through a stale command (a loaded machine may delay the
  // resends): the motion it leads to moves only while the command is fresh.
  Planning& p = *planning_;
  if (!p.solver) {
    if (p.dry_run.run(config_.dry_run.steps_per_period)) decide_after_dry_run();
    return;
  }
  if (!p.solver->run(config_.ik_iterations_per_period)) return;
  const Planning done = std::move(p);
  planning_.reset();
  std::string why = fmt::format("no joint solution was found ({} IK iterations)", done.solver->iterations());
  joint_traj_.reset();
  if (done.solver->solution()) joint_traj_ = joint_space_path(config_, q_, *done.solver->solution(), &why);
  if (!joint_traj_ && done.best_effort) {
    pose_traj_.emplace(*done.best_effort);
    active_ = Active::kPoseGoal;
    traj_start_ = now();
    count("pose_goals_cartesian");
    spdlog::info("pose goal {}: {}, and {}: the straight path, as near as it gets", done.cmd.goal_id, done.shortfall,
                 why);
    return;
  }
  if (!joint_traj_) {
    pose_goal_unreachable(done.cmd, done.goal, done.shortfall + ", and " + why);
    return;
  }
  active_ = Active::kPoseGoalInJoints;
  traj_start_ = now();
  count("pose_goals_joint_space");
  spdlog::info("pose goal {}: {}; {} ({} IK iterations)", done.cmd.goal_id, done.shortfall, why,
               done.solver->iterations());
}

void RobotLinkNode::pose_goal_unreachable(const harvest::robot_command_t& cmd, const Eigen::Isometry3d& goal,
                                          const std::string& why) {
  unreachable_goal_id_ = cmd.goal_id;
  unreachable_goal_ = goal;
  active_ = Active::kNone;
  count("pose_goals_unreachable");
  refuse(cmd, "pose goal not reachable: " + why);
  unreachable_text_ = limit_text_;
}

void RobotLinkNode::on_estop(const harvest::emergency_stop_t& msg) {
  if (!authority_.admit_estop(msg)) return;  // a clear nobody may give; an engage always passes
  const bool was = supervisor_.estopped();
  supervisor_.on_emergency_stop(msg.engaged, msg.clear, msg.source + ": " + msg.reason);
  if (supervisor_.estopped() && !was) {
    active_ = Active::kNone;
    master_->set_goal(DriveGoal::kQuickStop);
    spdlog::error("EMERGENCY STOP from {}: {}", msg.source, msg.reason);
  } else if (was && !supervisor_.estopped()) {
    spdlog::warn("emergency stop cleared by {}", msg.source);
  }
}

void RobotLinkNode::on_operator(const harvest::operator_command_t& msg) {
  if (msg.command != harvest::operator_command_t::RESET_FAULT) return;
  if (!authority_.admit_from_operator("RESET_FAULT", msg)) return;
  if (!supervisor_.reset_fault()) {
    spdlog::warn("fault reset from {} refused: emergency stop engaged", msg.source);
    return;
  }
  spdlog::warn("faults reset by {}", msg.source);
  limit_text_.clear();
  refused_ = false;
  if (master_->phase() == MasterPhase::kFailed) {
    restart_master();
  } else {
    master_->clear_faults();
    enable_started_ = now();
    enable_timed_out_ = false;
  }
}

void RobotLinkNode::supervise() {
  for (const auto& e : master_->take_events()) spdlog::error("drive: {}", e);
  for (const auto& [name, value] : master_->counters()) {
    count(name, value - mirrored_[name]);
    mirrored_[name] = value;
  }
  if (master_->phase() == MasterPhase::kFailed) supervisor_.on_fault(master_->error());
  if (master_->any_fault()) {
    // One entry per latched cause (the drive's text accumulates them), so the
    // supervisor's text lists each cause once.
    for (const auto& d : master_->drives()) {
      if (!d.faulted()) continue;
      std::size_t begin = 0;
      while (begin <= d.fault_text.size()) {
        const std::size_t end = std::min(d.fault_text.find("; ", begin), d.fault_text.size());
        if (end > begin) supervisor_.on_fault(d.fault_text.substr(begin, end - begin));
        begin = end + 2;
      }
    }
  }
  if (!master_->bus_fault().empty()) supervisor_.on_fault(master_->bus_fault());
  if (bus_->state() == can::BusState::kBusOff) supervisor_.on_fault("CAN bus off");
  const bool enabled = master_->all_in(Cia402State::kOperationEnabled);
  if (!enabled && supervisor_.may_move() && !shutting_down_ && !enable_timed_out_ &&
      now() - enable_started_ > config_.enable_timeout) {
    enable_timed_out_ = true;
    supervisor_.on_fault("drives did not reach operation enabled within " +
                         std::to_string(config_.enable_timeout / 1000) + " ms");
  }
  if (enabled) enable_started_ = now();  // the timeout counts from the last time all were enabled
}

Eigen::VectorXd RobotLinkNode::command_velocity(double dt) {
  limited_now_ = false;
  const bool fresh = supervisor_.command_fresh(now());  // stale or no command: controlled stop
  const double t = rt::to_seconds(now() - traj_start_);
  CartesianStep step;
  if (fresh && active_ == Active::kTwist) {
    step = cartesian_step(config_, q_, kinematics::tool_pose(config_.model, q_), twist_, last_cmd_, dt);
  } else if (fresh && active_ == Active::kPoseGoal) {
    step = pose_goal_step(config_, *pose_traj_, t, q_, last_cmd_, dt);
  } else {
    // Joint-space motions, and the ramp to rest (no command, a stale one, a pose goal being planned).
    Eigen::VectorXd want = Eigen::VectorXd::Zero(config_.model.dof());
    if (fresh && (active_ == Active::kJointGoal || active_ == Active::kPoseGoalInJoints))
      want = joint_traj_->velocity(t) + config_.joint_gain * (joint_traj_->position(t) - q_);
    const auto lim = kinematics::limit_joint_velocity(config_.model, q_, last_cmd_, want, dt);
    step.qdot = lim.qdot;
    step.position_clipped = lim.position_clipped;
  }
  if (step.clip.clipped) {
    limited_now_ = true;
    if (limit_text_ != step.clip.reason) limit_event(step.clip.reason);  // one event per episode, not per cycle
  }
  if (step.position_clipped && !limited_now_) {
    limited_now_ = true;
    if (limit_text_ != "joint position limit") limit_event("joint position limit");
  }
  return step.qdot;
}

void RobotLinkNode::tick() {
  const Micros t = now();
  master_->drain(t);
  master_->check_timeouts(t);  // a lost drive stops this period's commands, not the next one's
  const double dt = rt::to_seconds(config_.can.sync_period);
  const int n = config_.model.dof();

  const auto& drives = master_->drives();
  have_joints_ = true;
  for (int i = 0; i < n; ++i) {
    have_joints_ = have_joints_ && drives[static_cast<std::size_t>(i)].seen_pdo;
    q_[i] = drives[static_cast<std::size_t>(i)].position;
    qd_[i] = drives[static_cast<std::size_t>(i)].velocity;
  }
  supervise();

  Eigen::VectorXd cmd = Eigen::VectorXd::Zero(n);
  const bool enabled = have_joints_ && master_->all_in(Cia402State::kOperationEnabled);
  if (!supervisor_.may_move()) {
    active_ = Active::kNone;
    if (shutting_down_ && qd_.norm() < 1e-3) {
      // Exit while stopped by a fault or e-stop: at rest, disable what can be
      // disabled (a faulted drive stays in Fault, a lost one cannot answer).
      master_->set_goal(DriveGoal::kDisabled);
      if (master_->all_in(Cia402State::kSwitchOnDisabled) || master_->phase() != MasterPhase::kRunning ||
          ++shutdown_wait_ > 20) {
        master_->stop_nodes();
        shutdown_done_ = true;
      }
    } else {
      master_->set_goal(DriveGoal::kQuickStop);
    }
  } else if (shutting_down_) {
    // Ramp to rest at the joint acceleration limits, then disable.
    if (enabled) cmd = kinematics::limit_joint_velocity(config_.model, q_, last_cmd_, cmd, dt).qdot;
    const bool at_rest = cmd.norm() < 1e-6 && qd_.norm() < 1e-3;
    if (at_rest || !enabled) master_->set_goal(DriveGoal::kDisabled);
    if (master_->all_in(Cia402State::kSwitchOnDisabled) || master_->any_fault() ||
        master_->phase() != MasterPhase::kRunning) {
      master_->stop_nodes();
      shutdown_done_ = true;
    }
  } else {
    master_->set_goal(DriveGoal::kEnabled);
    if (enabled) cmd = command_velocity(dt);
  }
  if (!limited_now_ && !refused_) limit_text_.clear();
  master_->set_velocities(std::vector<double>(cmd.data(), cmd.data() + n));
  last_cmd_ = cmd;
  const Micros sampled = last_sync_;
  master_->sync(t);
  last_sync_ = t;
  // After the SYNC, so a slice of pose-goal IK never delays it.
  if (active_ == Active::kPlanning && supervisor_.may_move() && !shutting_down_) continue_planning();

  if (supervisor_.estopped() || supervisor_.faulted())
    set_health(rt::Health::kError, supervisor_.estopped() ? supervisor_.estop_text() : supervisor_.fault_text());
  else if (enabled)
    set_health(rt::Health::kOk);
  else
    set_health(rt::Health::kStarting, "enabling drives");
  if (have_joints_) publish_state(cmd, sampled);
}

void RobotLinkNode::publish_state(const Eigen::VectorXd& cmd, Micros sampled) {
  const int n = config_.model.dof();
  harvest::robot_state_t s{};
  s.header.utime = sampled;  // the TPDOs answer the previous SYNC
  s.header.frame_id = "base";
  s.header.source_seq = last_command_seq_;
  const auto& drives = master_->drives();
  const bool enabled = master_->all_in(Cia402State::kOperationEnabled);
  const bool moving = cmd.norm() > 1e-9 || qd_.norm() > 1e-3;
  const bool fresh = supervisor_.command_fresh(now());
  if (supervisor_.estopped())
    s.mode = harvest::robot_state_t::MODE_ESTOP;
  else if (supervisor_.faulted())
    s.mode = harvest::robot_state_t::MODE_FAULT;
  else if (shutting_down_ && !enabled)
    s.mode = harvest::robot_state_t::MODE_DISABLED;
  else if (!enabled)
    s.mode = harvest::robot_state_t::MODE_ENABLING;
  else if (moving && fresh && active_ != Active::kNone)
    s.mode = harvest::robot_state_t::MODE_MOVING;
  else if (moving)
    s.mode = harvest::robot_state_t::MODE_STOPPING;
  else
    s.mode = harvest::robot_state_t::MODE_IDLE;

  s.num_joints = n;
  s.joint_position.assign(q_.data(), q_.data() + n);
  s.joint_velocity.assign(qd_.data(), qd_.data() + n);
  s.joint_velocity_cmd.assign(cmd.data(), cmd.data() + n);
  int32_t flags = 0;
  for (const auto& d : drives) {
    s.drive_state.push_back(static_cast<int8_t>(d.state));
    s.drive_error_code.push_back(d.error_code);
    if (d.fault) flags |= kFlagDriveFault;
    if (d.emcy) flags |= kFlagEmcy;
    if (d.heartbeat_lost) flags |= kFlagHeartbeatLost;
    if (d.pdo_lost) flags |= kFlagPdoLost;
    if (d.foreign) flags |= kFlagForeign;
    if (d.nmt_left) flags |= kFlagNmtLeft;
    if (d.uncommanded) flags |= kFlagUncommanded;
  }
  if (!master_->bus_fault().empty()) flags |= kFlagForeign;
  s.tool_pose = geometry::to_pose(kinematics::tool_pose(config_.model, q_));
  s.camera_pose = geometry::to_pose(kinematics::camera_pose(config_.model, q_));
  const kinematics::Twist v = kinematics::tool_jacobian(config_.model, q_) * qd_;
  for (int i = 0; i < 3; ++i) {
    s.tool_twist.linear[i] = v[i];
    s.tool_twist.angular[i] = v[3 + i];
  }
  s.last_command_seq = last_command_seq_;
  s.command_stale = supervisor_.had_command() && !fresh;
  if (supervisor_.estopped()) flags |= kFlagEstop;
  if (s.command_stale) flags |= kFlagCommandStale;
  if (limited_now_) flags |= kFlagLimited;
  if (refused_) flags |= kFlagRefused;
  if (master_->phase() == MasterPhase::kFailed || bus_->state() == can::BusState::kBusOff) flags |= kFlagBus;
  if (enable_timed_out_) flags |= kFlagEnableTimeout;
  s.fault_flags = flags;
  std::string text = supervisor_.estopped() ? supervisor_.estop_text() : "";
  if (supervisor_.faulted()) text += (text.empty() ? "" : "; ") + supervisor_.fault_text();
  if (!limit_text_.empty()) text += (text.empty() ? "" : "; ") + limit_text_;
  s.fault_text = text;
  s.num_limit_events = limit_events_;
  publish(channels::kRobotState, s);
}

}  // namespace harvest::arm
