#include "calib/plan_runner.hpp"

#include <fmt/format.h>

#include <cctype>
#include <cmath>

#include "geometry/pose_msg.hpp"
#include "harvest/robot_command_t.hpp"
#include "runtime/channels.hpp"

namespace harvest::calib {

PlanRunner::PlanRunner(PlanRunConfig config, security::Key key, std::string sender)
    : rt::Node("calibration-plan"), config_(std::move(config)), signer_(std::move(key), std::move(sender), clock()) {}

void PlanRunner::on_attach() {
  advertise(channels::kRobotCommand);
  subscribe<robot_state_t>(channels::kRobotState, [this](const robot_state_t& s) {
    state_ = s;
    state_heard_ = now();
  });
  // Goal ids from the start time: a new run's first goal never reuses the
  // id of a goal the link is still following (it would not be planned anew).
  goal_id_ = now();
  every(rt::from_seconds(0.05), [this] { tick(); });
}

void PlanRunner::say(const std::string& line) {
  if (on_progress) on_progress(line);
}

bool PlanRunner::still(const robot_state_t& s) const {
  const Eigen::Vector3d v(s.tool_twist.linear[0], s.tool_twist.linear[1], s.tool_twist.linear[2]);
  const Eigen::Vector3d w(s.tool_twist.angular[0], s.tool_twist.angular[1], s.tool_twist.angular[2]);
  return v.norm() <= config_.rest_speed_m_s && w.norm() <= config_.rest_rate_rad_s;
}

bool PlanRunner::at_goal(const robot_state_t& s) const {
  const Eigen::Isometry3d tool = geometry::to_isometry(s.tool_pose);
  const Eigen::Isometry3d& goal = config_.poses[index_];
  const double position = (tool.translation() - goal.translation()).norm();
  const double rotation = Eigen::AngleAxisd(tool.linear().transpose() * goal.linear()).angle();
  return position <= config_.position_tolerance_m && rotation <= config_.rotation_tolerance_rad && still(s);
}

void PlanRunner::tick() {
  if (outcome_ != Outcome::kRunning) return;
  const rt::Micros t = now();
  if (started_ < 0) started_ = pose_started_ = t;
  const rt::Micros state_timeout = rt::from_seconds(config_.state_timeout_s);
  if (!state_ || t - state_heard_ > state_timeout) {
    // Nothing moves without a robot state to check it against.
    if (t - started_ > state_timeout)
      abort(state_ ? fmt::format("ROBOT_STATE stopped coming ({:.1f} s old)", rt::to_seconds(t - state_heard_))
                   : fmt::format("no ROBOT_STATE in {:.1f} s: is the robot link running?", config_.state_timeout_s));
    return;
  }
  if (state_->mode == robot_state_t::MODE_FAULT || state_->mode == robot_state_t::MODE_ESTOP) {
    abort(fmt::format("the robot link is in {}: {}", state_->mode == robot_state_t::MODE_FAULT ? "FAULT" : "ESTOP",
                      state_->fault_text));
    return;
  }
  if (index_ >= config_.poses.size()) {
    finish();
    return;
  }
  const auto next_pose = [&] {
    ++index_;
    ++goal_id_;
    pose_started_ = t;
    resting_since_ = last_sent_ = goal_first_seq_ = -1;
    settling_ = false;
  };
  if (!settling_) {
    if (const auto why = refusal(*state_)) {
      // The link refused this goal (out of reach, workspace): no use waiting.
      skipped_.push_back(static_cast<int>(index_));
      say(fmt::format("pose {}/{} skipped: {}", index_ + 1, config_.poses.size(), *why));
      next_pose();
      if (index_ >= config_.poses.size()) finish();
      return;
    }
    if (at_goal(*state_)) {
      // Arrived: stop following the goal, so the link holds the arm still
      // (IDLE): the calibration uses frames taken with the arm at rest only.
      send_stop();
      settling_ = true;
      return;
    }
    if (last_sent_ < 0 || t - last_sent_ >= rt::from_seconds(config_.resend_period_s)) send_goal();
  } else if (state_->mode == robot_state_t::MODE_IDLE && still(*state_)) {
    if (resting_since_ < 0) resting_since_ = t;
    if (t - resting_since_ >= rt::from_seconds(config_.dwell_s)) {
      ++reached_;
      say(fmt::format("pose {}/{} reached after {:.1f} s, held {:.1f} s", index_ + 1, config_.poses.size(),
                      rt::to_seconds(resting_since_ - pose_started_), config_.dwell_s));
      next_pose();
      if (index_ >= config_.poses.size()) finish();
      return;
    }
  } else {
    resting_since_ = -1;
  }
  if (t - pose_started_ > rt::from_seconds(config_.pose_timeout_s)) {
    skipped_.push_back(static_cast<int>(index_));
    say(
        fmt::format("pose {}/{} not reached and held in {:.0f} s: skipped (refused by the robot link, or blocked: see "
                    "its log)",
                    index_ + 1, config_.poses.size(), config_.pose_timeout_s));
    next_pose();
    if (index_ >= config_.poses.size()) finish();
  }
}

std::optional<std::string> PlanRunner::refusal(const robot_state_t& s) const {
  // The link names a refused command in its state text: "command seq N refused: why".
  if (goal_first_seq_ < 0) return std::nullopt;
  static const std::string kMark = "command seq ";
  for (std::size_t at = s.fault_text.find(kMark); at != std::string::npos; at = s.fault_text.find(kMark, at + 1)) {
    std::size_t end = at + kMark.size();
    int64_t seq = 0;
    bool digits = false;
    while (end < s.fault_text.size() && std::isdigit(static_cast<unsigned char>(s.fault_text[end])))
      seq = seq * 10 + (s.fault_text[end++] - '0'), digits = true;
    static const std::string kRefused = " refused: ";
    if (digits && seq >= goal_first_seq_ && s.fault_text.compare(end, kRefused.size(), kRefused) == 0) {
      const std::size_t stop = s.fault_text.find("; ", end);
      return s.fault_text.substr(end + kRefused.size(),
                                 stop == std::string::npos ? std::string::npos : stop - end - kRefused.size());
    }
  }
  return std::nullopt;
}

void PlanRunner::send(int8_t type) {
  robot_command_t c{};
  c.header.utime = now();
  c.header.source_seq = -1;
  c.header.frame_id = "base";
  c.type = type;
  c.validity_us = rt::from_seconds(config_.validity_s);
  c.pose_goal = type == robot_command_t::TYPE_POSE_GOAL ? geometry::to_pose(config_.poses[index_])
                                                        : geometry::to_pose(Eigen::Isometry3d::Identity());
  c.num_joints = 0;
  c.max_linear_speed = config_.max_linear_speed;
  c.max_angular_speed = config_.max_angular_speed;
  c.goal_id = goal_id_;
  publish(channels::kRobotCommand, c, [this](robot_command_t& m) { signer_.sign(m); });
  if (type == robot_command_t::TYPE_POSE_GOAL) {
    if (goal_first_seq_ < 0) goal_first_seq_ = c.header.seq;
    last_sent_ = now();
  } else {
    stopped_sent_ = true;
  }
}

void PlanRunner::send_goal() { send(robot_command_t::TYPE_POSE_GOAL); }

void PlanRunner::send_stop() { send(robot_command_t::TYPE_STOP); }

void PlanRunner::abort(const std::string& why) {
  send_stop();
  outcome_ = Outcome::kAborted;
  why_ = why;
  say("stopped: " + why);
  ctx().request_stop(1);
}

void PlanRunner::finish() {
  send_stop();
  outcome_ = Outcome::kDone;
  say(fmt::format("plan done: {} of {} poses reached{}", reached_, config_.poses.size(),
                  skipped_.empty() ? "" : fmt::format(", {} skipped", skipped_.size())));
  ctx().request_stop(0);
}

void PlanRunner::begin_shutdown() {
  if (outcome_ == Outcome::kRunning) abort("stopped by the operator");
}

}  // namespace harvest::calib
