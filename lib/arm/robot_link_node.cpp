#include "arm/robot_link_node.hpp"

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include "arm/command_check.hpp"
#include "arm/robot_state_message.hpp"
#include "runtime/channels.hpp"
#include "runtime/realtime.hpp"

namespace harvest::arm {
namespace {

using canopen::Cia402State;
using canopen::DriveGoal;
using canopen::MasterPhase;
using harvest::robot_command_t;

}  // namespace

RobotLinkNode::RobotLinkNode(RobotLinkConfig config, std::unique_ptr<can::CanBus> bus)
    : rt::Node("robot_link"),
      config_(std::move(config)),
      hardware_(config_.bus, config_.can, std::move(bus)),
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
  rt::request_realtime_priority(config_.realtime_priority,
                                "a loaded computer may stall it past the drives' RPDO deadline");
  hardware_.open();
  restart_drives();
  if (hardware_.bus().fd() >= 0) ctx().watch_fd(hardware_.bus().fd(), [this] { hardware_.master().drain(now()); });
  subscribe<robot_command_t>(channels::kRobotCommand, [this](const auto& m) { on_command(m); });
  subscribe<harvest::emergency_stop_t>(channels::kEmergencyStop, [this](const auto& m) { on_estop(m); });
  subscribe<harvest::operator_command_t>(channels::kOperatorCommand, [this](const auto& m) { on_operator(m); });
  advertise(channels::kRobotState);
  every(config_.can.sync_period, [this] { tick(); });
  spdlog::info("robot link on {}: {} drives, SYNC every {} us", hardware_.bus().describe(), config_.can.drives.size(),
               config_.can.sync_period);
  spdlog::info("robot link: {}", authority_.describe());
}

void RobotLinkNode::restart_drives() {
  hardware_.restart(now());
  enable_started_ = now();
  enable_timed_out_ = false;
  set_health(rt::Health::kStarting, "configuring drives");
}

void RobotLinkNode::begin_shutdown() {
  shutting_down_ = true;
  motion_ = NoMotion{};
  supervisor_.cancel_command();
  if (!hardware_.running()) shutdown_done_ = true;
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

void RobotLinkNode::refuse(const robot_command_t& cmd, const std::string& why) {
  refused_ = true;
  limit_event("command seq " + std::to_string(cmd.header.seq) + " refused: " + why);
  count("commands_refused");
}

void RobotLinkNode::on_command(const robot_command_t& cmd) {
  if (shutting_down_) return;
  if (!authority_.admit_from_controller("ROBOT_COMMAND", cmd)) return;  // counted and logged by the gate
  if (!supervisor_.may_move()) {
    count("commands_while_stopped");
    return;  // not a limit event: the state already says why nothing moves
  }
  refused_ = false;
  if (const std::string why = command_problem(config_, cmd); !why.empty()) return refuse(cmd, why);
  switch (cmd.type) {
    case robot_command_t::TYPE_STOP:
      motion_ = NoMotion{};
      supervisor_.cancel_command();
      break;
    case robot_command_t::TYPE_TWIST:
      motion_ = TwistMotion{twist_of(cmd)};
      break;
    case robot_command_t::TYPE_POSE_GOAL:
      if (pose_goal_id(motion_) == cmd.goal_id) break;  // same goal, refreshed
      if (unreachable_goal_id_ == cmd.goal_id && pose_goal_of(cmd).isApprox(unreachable_goal_, 1e-12)) {
        // A resend of a goal found unreachable: still refused, not planned
        // again, and the same refusal (no new limit event).
        refused_ = true;
        limit_text_ = unreachable_text_;
        count("commands_refused");
        return;
      }
      if (start_pose_goal(cmd), refused_) return;
      break;
    case robot_command_t::TYPE_JOINT_GOAL:
      if (joint_goal_id(motion_) != cmd.goal_id)
        motion_ = JointMotion{
            JointTrajectory(q_, joint_goal_of(cmd), config_.model.max_velocity(), config_.model.max_acceleration()),
            now(), cmd.goal_id, false};
      break;
  }
  if (cmd.type != robot_command_t::TYPE_STOP) supervisor_.on_command(now(), cmd.validity_us);
  last_command_seq_ = cmd.header.seq;
}

void RobotLinkNode::start_pose_goal(const robot_command_t& cmd) {
  CartesianTrajectory::Limits lim{config_.limits.linear_speed, config_.limits.angular_speed,
                                  config_.limits.linear_acceleration, config_.limits.angular_acceleration};
  if (cmd.max_linear_speed > 0) lim.linear_speed = std::min(lim.linear_speed, cmd.max_linear_speed);
  if (cmd.max_angular_speed > 0) lim.angular_speed = std::min(lim.angular_speed, cmd.max_angular_speed);
  CartesianTrajectory path(kinematics::tool_pose(config_.model, q_), pose_goal_of(cmd), lim);
  if (!(path.duration() <= config_.dry_run.max_duration))
    return refuse(cmd, fmt::format("the pose goal would take {:.0f} s, more than the {:.0f} s a goal may take",
                                   path.duration(), config_.dry_run.max_duration));
  if (!config_.pose_goal_joint_fallback) {  // no dry run: Cartesian, as before
    motion_ = CartesianMotion{std::move(path), now(), cmd.goal_id};
    return;
  }
  // A first slice here (a typical goal's whole dry run); the rest after each
  // SYNC (continue_planning) while the arm holds.
  motion_.emplace<PlanningMotion>(PlanningMotion{cmd, PoseGoalPlanner(config_, std::move(path), q_, last_cmd_)});
  continue_planning();
}

void RobotLinkNode::continue_planning() {
  // It goes on through a stale command (a loaded machine may delay the
  // resends): the motion it leads to moves only while the command is fresh.
  auto& planning = std::get<PlanningMotion>(motion_);
  if (!planning.planner.run(q_)) return;
  const PoseGoalPlan& plan = planning.planner.plan();
  const int64_t goal_id = planning.cmd.goal_id;
  switch (plan.way) {
    case PoseGoalPlan::Way::kCartesian:
      count("pose_goals_cartesian");
      spdlog::info("pose goal {}: {}", goal_id, plan.why);
      motion_ = CartesianMotion{*plan.cartesian, now(), goal_id};
      break;
    case PoseGoalPlan::Way::kJointSpace:
      count("pose_goals_joint_space");
      spdlog::info("pose goal {}: {}", goal_id, plan.why);
      motion_ = JointMotion{*plan.joints, now(), goal_id, true};
      break;
    case PoseGoalPlan::Way::kUnreachable: {
      const PlanningMotion done = std::move(planning);
      unreachable_goal_id_ = goal_id;
      unreachable_goal_ = done.planner.goal();
      motion_ = NoMotion{};
      count("pose_goals_unreachable");
      refuse(done.cmd, "pose goal not reachable: " + done.planner.plan().why);
      unreachable_text_ = limit_text_;
      break;
    }
    case PoseGoalPlan::Way::kPending:
      break;
  }
}

void RobotLinkNode::on_estop(const harvest::emergency_stop_t& msg) {
  if (!authority_.admit_estop(msg)) return;  // a clear nobody may give; an engage always passes
  const bool was = supervisor_.estopped();
  supervisor_.on_emergency_stop(msg.engaged, msg.clear, msg.source + ": " + msg.reason);
  if (supervisor_.estopped() && !was) {
    motion_ = NoMotion{};
    hardware_.master().set_goal(DriveGoal::kQuickStop);
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
  if (hardware_.master().phase() == MasterPhase::kFailed) {
    restart_drives();
  } else {
    hardware_.master().clear_faults();
    enable_started_ = now();
    enable_timed_out_ = false;
  }
}

void RobotLinkNode::supervise() {
  hardware_.report(supervisor_, [this](const std::string& counter, int64_t n) { count(counter, n); });
  const bool enabled = hardware_.enabled();
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
  CartesianStep step;
  // Joint-space motions, and the ramp to rest (no command, a stale one, a pose goal being planned).
  const auto in_joints = [&](const Eigen::VectorXd& want) {
    const auto lim = kinematics::limit_joint_velocity(config_.model, q_, last_cmd_, want, dt);
    step.qdot = lim.qdot;
    step.position_clipped = lim.position_clipped;
  };
  if (const auto* twist = std::get_if<TwistMotion>(&motion_); fresh && twist) {
    step = cartesian_step(config_, q_, kinematics::tool_pose(config_.model, q_), twist->twist, last_cmd_, dt);
  } else if (const auto* pose = std::get_if<CartesianMotion>(&motion_); fresh && pose) {
    step = pose_goal_step(config_, pose->path, rt::to_seconds(now() - pose->start), q_, last_cmd_, dt);
  } else if (const auto* joints = std::get_if<JointMotion>(&motion_); fresh && joints) {
    const double t = rt::to_seconds(now() - joints->start);
    in_joints(joints->path.velocity(t) + config_.joint_gain * (joints->path.position(t) - q_));
  } else {
    in_joints(Eigen::VectorXd::Zero(config_.model.dof()));
  }
  if (step.clip.clipped) {
    limited_now_ = true;
    if (limit_text_ != step.clip.reason) limit_event(step.clip.reason);  // one event per episode, not per cycle
  }
  joint_limited_now_ = step.position_clipped;
  if (step.position_clipped && !limited_now_) {
    limited_now_ = true;
    if (limit_text_ != "joint position limit") limit_event("joint position limit");
  }
  return step.qdot;
}

Eigen::VectorXd RobotLinkNode::shut_down(bool enabled, double dt) {
  canopen::Master& master = hardware_.master();
  Eigen::VectorXd cmd = Eigen::VectorXd::Zero(config_.model.dof());
  if (!supervisor_.may_move()) {
    // Stopped by a fault or e-stop: once at rest, disable what can be
    // disabled (a faulted drive stays in Fault, a lost one cannot answer).
    if (qd_.norm() >= 1e-3) {
      master.set_goal(DriveGoal::kQuickStop);
      return cmd;
    }
    master.set_goal(DriveGoal::kDisabled);
    if (master.all_in(Cia402State::kSwitchOnDisabled) || master.phase() != MasterPhase::kRunning ||
        ++shutdown_wait_ > 20) {
      master.stop_nodes();
      shutdown_done_ = true;
    }
    return cmd;
  }
  // Ramp to rest at the joint acceleration limits, then disable.
  if (enabled) cmd = kinematics::limit_joint_velocity(config_.model, q_, last_cmd_, cmd, dt).qdot;
  const bool at_rest = cmd.norm() < 1e-6 && qd_.norm() < 1e-3;
  if (at_rest || !enabled) master.set_goal(DriveGoal::kDisabled);
  if (master.all_in(Cia402State::kSwitchOnDisabled) || master.any_fault() || master.phase() != MasterPhase::kRunning) {
    master.stop_nodes();
    shutdown_done_ = true;
  }
  return cmd;
}

void RobotLinkNode::log_own_stalls(Micros t) {
  const rt::AwakeClock& awake = hardware_.master().awake();
  if (awake.stalls() == stalls_seen_) return;
  stalls_seen_ = awake.stalls();  // counted by the master (can_own_stalls in the heartbeat)
  int64_t unlogged = 0;
  Micros since = 0;
  if (!stall_log_.admit(t, unlogged, since)) return;
  // Not a fault of the drives: they see our silence past their RPDO deadline and stop the arm themselves.
  spdlog::warn(
      "robot link loop stalled ({} in all, longest {} ms beyond can.own_stall_ms, {} ms in all): not "
      "counted against the drives; the drives stop the arm after can.drive_rpdo_timeout_ms ({} ms)",
      stalls_seen_, awake.longest_lost_us() / 1000, awake.lost_us() / 1000, config_.can.drive_rpdo_timeout_ms);
}

void RobotLinkNode::tick() {
  const Micros t = now();
  const double dt = rt::to_seconds(config_.can.sync_period);
  have_joints_ = hardware_.read(t, q_, qd_);
  supervise();

  Eigen::VectorXd cmd = Eigen::VectorXd::Zero(config_.model.dof());
  const bool enabled = have_joints_ && hardware_.enabled();
  if (!supervisor_.may_move()) motion_ = NoMotion{};
  if (shutting_down_) {
    cmd = shut_down(enabled, dt);
  } else if (!supervisor_.may_move()) {
    hardware_.master().set_goal(DriveGoal::kQuickStop);
  } else {
    hardware_.master().set_goal(DriveGoal::kEnabled);
    if (enabled) cmd = command_velocity(dt);
  }
  if (!limited_now_ && !refused_) limit_text_.clear();
  hardware_.write(cmd, t);
  last_cmd_ = cmd;
  log_own_stalls(t);
  // After the SYNC, so a slice of pose-goal IK never delays it.
  if (std::holds_alternative<PlanningMotion>(motion_) && supervisor_.may_move() && !shutting_down_) continue_planning();

  if (supervisor_.estopped() || supervisor_.faulted())
    set_health(rt::Health::kError, supervisor_.estopped() ? supervisor_.estop_text() : supervisor_.fault_text());
  else if (enabled)
    set_health(rt::Health::kOk);
  else
    set_health(rt::Health::kStarting, "enabling drives");
  if (have_joints_) publish_state(cmd);
}

void RobotLinkNode::publish_state(const Eigen::VectorXd& cmd) {
  LinkSnapshot link;
  link.sampled = hardware_.sampled();  // the TPDOs answer the previous SYNC
  link.last_command_seq = last_command_seq_;
  link.q = q_;
  link.qd = qd_;
  link.cmd = cmd;
  link.drives_enabled = hardware_.enabled();
  link.shutting_down = shutting_down_;
  link.has_motion = !std::holds_alternative<NoMotion>(motion_);
  link.limited = limited_now_;
  link.joint_limited = joint_limited_now_;
  link.refused = refused_;
  link.enable_timed_out = enable_timed_out_;
  link.limit_events = limit_events_;
  link.limit_text = limit_text_;
  link.hardware_flags = hardware_.fault_flags();
  auto state = robot_state_message(config_.model, supervisor_, hardware_.master().drives(), link, now());
  publish(channels::kRobotState, state);  // stamps the header's seq
}

}  // namespace harvest::arm
