#include "arm/robot_link_node.hpp"

#include <spdlog/spdlog.h>

#include <algorithm>
#include <cmath>

#include "runtime/channels.hpp"

namespace harvest::arm {
namespace {

using canopen::Cia402State;
using canopen::DriveGoal;
using canopen::MasterPhase;

Eigen::Vector3d vec3(const config::Node& n, const std::string& key, const std::vector<double>& fallback) {
  const auto v = n.numbers(key, fallback, 3);
  return {v[0], v[1], v[2]};
}

void to_pose(const Eigen::Isometry3d& t, harvest::pose_t& p) {
  const Eigen::Quaterniond q(t.linear());
  for (int i = 0; i < 3; ++i) p.position[i] = t.translation()[i];
  p.orientation[0] = q.w();
  p.orientation[1] = q.x();
  p.orientation[2] = q.y();
  p.orientation[3] = q.z();
}

}  // namespace

RobotLinkConfig RobotLinkConfig::from_config(const config::Node& root) {
  RobotLinkConfig c;
  c.bus = root.get<std::string>("bus", c.bus);
  c.model = kinematics::ArmModel::load(root.file_path("arm_model", "k1207i.yaml").string());
  c.can = canopen::MasterConfig::from_config(root.child("can"));
  if (static_cast<int>(c.can.drives.size()) != c.model.dof())
    root.child("can").fail("drives", "one drive per joint of the arm model (" + std::to_string(c.model.dof()) + ")");
  const auto lim = root.child("limits");
  c.limits.linear_speed = lim.get<double>("max_linear_speed", 0.381, {0.001, 2.0});
  c.limits.angular_speed = lim.get<double>("max_angular_speed", 1.0, {0.001, 5.0});
  c.limits.linear_acceleration = lim.get<double>("max_linear_acceleration", 0.5, {0.01, 10.0});
  c.limits.angular_acceleration = lim.get<double>("max_angular_acceleration", 2.0, {0.01, 20.0});
  c.limits.default_validity = lim.get<int>("default_validity_ms", 100, {10, 1000}) * 1000;
  c.limits.max_validity = lim.get<int>("max_validity_ms", 1000, {10, 10000}) * 1000;
  const auto ws = root.child("workspace");
  c.workspace.min = vec3(ws, "min", {-2, -2, -2});
  c.workspace.max = vec3(ws, "max", {2, 2, 2});
  if ((c.workspace.min.array() >= c.workspace.max.array()).any()) ws.fail("max", "greater than min on every axis");
  const auto ctl = root.child("control");
  c.position_gain = ctl.get<double>("position_gain", 5.0, {0.0, 100.0});
  c.orientation_gain = ctl.get<double>("orientation_gain", 5.0, {0.0, 100.0});
  c.joint_gain = ctl.get<double>("joint_gain", 5.0, {0.0, 100.0});
  c.enable_timeout = ctl.get<int>("enable_timeout_ms", 3000, {100, 60000}) * 1000;
  return c;
}

RobotLinkNode::RobotLinkNode(RobotLinkConfig config, std::unique_ptr<can::CanBus> bus)
    : rt::Node("robot_link"), config_(std::move(config)), bus_(std::move(bus)), supervisor_(config_.limits) {
  const int n = config_.model.dof();
  q_ = config_.model.home;
  qd_ = Eigen::VectorXd::Zero(n);
  last_cmd_ = Eigen::VectorXd::Zero(n);
}

RobotLinkNode::~RobotLinkNode() = default;

void RobotLinkNode::on_attach() {
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
}

void RobotLinkNode::restart_master() {
  master_ = std::make_unique<canopen::Master>(*bus_, config_.can);
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
  spdlog::warn("command limited: {}", why);
}

void RobotLinkNode::refuse(const harvest::robot_command_t& cmd, const std::string& why) {
  refused_ = true;
  limit_event("command seq " + std::to_string(cmd.header.seq) + " refused: " + why);
  count("commands_refused");
}

void RobotLinkNode::on_command(const harvest::robot_command_t& cmd) {
  if (shutting_down_) return;
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
      kinematics::Twist v;
      v << cmd.twist.linear[0], cmd.twist.linear[1], cmd.twist.linear[2], cmd.twist.angular[0], cmd.twist.angular[1],
          cmd.twist.angular[2];
      if (!v.allFinite()) return refuse(cmd, "twist is not finite");
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
      if (active_ == Active::kPoseGoal && cmd.goal_id == goal_id_) break;  // same goal, refreshed
      Eigen::Isometry3d goal = Eigen::Isometry3d::Identity();
      goal.translation() = pos;
      goal.linear() = q.normalized().toRotationMatrix();
      CartesianTrajectory::Limits lim{config_.limits.linear_speed, config_.limits.angular_speed,
                                      config_.limits.linear_acceleration, config_.limits.angular_acceleration};
      if (cmd.max_linear_speed > 0) lim.linear_speed = std::min(lim.linear_speed, cmd.max_linear_speed);
      if (cmd.max_angular_speed > 0) lim.angular_speed = std::min(lim.angular_speed, cmd.max_angular_speed);
      pose_traj_.emplace(kinematics::tool_pose(config_.model, q_), goal, lim);
      traj_start_ = t;
      goal_id_ = cmd.goal_id;
      active_ = Active::kPoseGoal;
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

void RobotLinkNode::on_estop(const harvest::emergency_stop_t& msg) {
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

Eigen::VectorXd RobotLinkNode::desired_velocity(double dt) {
  const int n = config_.model.dof();
  Eigen::VectorXd qd = Eigen::VectorXd::Zero(n);
  limited_now_ = false;
  if (!supervisor_.command_fresh(now())) return qd;  // stale or no command: controlled stop
  const Eigen::Isometry3d tool = kinematics::tool_pose(config_.model, q_);
  kinematics::Twist v = kinematics::Twist::Zero();
  switch (active_) {
    case Active::kNone:
      return qd;
    case Active::kJointGoal: {
      const double t = rt::to_seconds(now() - traj_start_);
      return joint_traj_->velocity(t) + config_.joint_gain * (joint_traj_->position(t) - q_);
    }
    case Active::kTwist:
      v = twist_;
      break;
    case Active::kPoseGoal: {
      const double t = rt::to_seconds(now() - traj_start_);
      const kinematics::Twist e = kinematics::pose_error(pose_traj_->pose(t), tool);
      v = pose_traj_->twist(t);
      v.head<3>() += config_.position_gain * e.head<3>();
      v.tail<3>() += config_.orientation_gain * e.tail<3>();
      break;
    }
  }
  const ClippedTwist c = clip_twist(v, tool.translation(), config_.workspace, config_.limits, dt);
  if (c.clipped) {
    limited_now_ = true;
    if (limit_text_ != c.reason) limit_event(c.reason);  // one event per episode, not per cycle
  }
  int locked = 0;
  qd = kinematics::joint_velocity_within_limits(config_.model, q_, c.twist, dt, {}, &locked);
  return qd;
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
    if (enabled) {
      const Eigen::VectorXd want = desired_velocity(dt);
      const auto lim = kinematics::limit_joint_velocity(config_.model, q_, last_cmd_, want, dt);
      if (lim.position_clipped && !limited_now_) {
        limited_now_ = true;
        if (limit_text_ != "joint position limit") limit_event("joint position limit");
      }
      cmd = lim.qdot;
    }
  }
  if (!limited_now_ && !refused_) limit_text_.clear();
  master_->set_velocities(std::vector<double>(cmd.data(), cmd.data() + n));
  last_cmd_ = cmd;
  const Micros sampled = last_sync_;
  master_->sync(t);
  last_sync_ = t;

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
  }
  to_pose(kinematics::tool_pose(config_.model, q_), s.tool_pose);
  to_pose(kinematics::camera_pose(config_.model, q_), s.camera_pose);
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
