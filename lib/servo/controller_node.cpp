#include "servo/controller_node.hpp"

#include <spdlog/spdlog.h>

#include "harvest/twist_t.hpp"
#include "runtime/channels.hpp"
#include "servo/tbz_approach.hpp"

namespace harvest::servo {

ServoControllerNode::ServoControllerNode(ServoConfig config, security::AuthorityConfig authority, std::string name)
    : rt::Node(std::move(name)),
      cfg_(config),
      authority_(authority, authority.load(), clock(), [this](const std::string& c, int64_t n) { count(c, n); }),
      machine_(config, make_approach(config)) {
  if (authority_.config().sender.empty()) throw std::invalid_argument("servo controller: authority.sender is empty");
  log_health_changes(false);  // the health carries the status summary, which publish_status() logs
}

void ServoControllerNode::on_attach() {
  namespace ch = channels;
  advertise(ch::kRobotCommand);
  advertise(ch::kGripperCommand);
  advertise(ch::kHarvestStatus);
  subscribe<targets_t>(ch::kTargets, [this](const targets_t& m) { emit(machine_.on_targets(m, now())); });
  subscribe<fruit_detections_t>(ch::kFruitHand,
                                [this](const fruit_detections_t& m) { emit(machine_.on_hand_fruit(m, now())); });
  subscribe<robot_state_t>(ch::kRobotState,
                           [this](const robot_state_t& m) { emit(machine_.on_robot_state(m, now())); });
  subscribe<ir_range_t>(ch::kIrRange, [this](const ir_range_t& m) { emit(machine_.on_ir(m, now())); });
  subscribe<gripper_state_t>(ch::kGripperState,
                             [this](const gripper_state_t& m) { emit(machine_.on_gripper(m, now())); });
  // Operator commands and an e-stop clear only when an operator signed them
  // (refusals counted and logged by the gates); an e-stop engage from anyone.
  subscribe<operator_command_t>(ch::kOperatorCommand, [this](const operator_command_t& m) {
    if (authority_.admit_from_operator("OPERATOR_COMMAND", m)) emit(machine_.on_operator(m, now()));
  });
  subscribe<emergency_stop_t>(ch::kEmergencyStop, [this](const emergency_stop_t& m) {
    if (authority_.admit_estop(m)) emit(machine_.on_estop(m, now()));
  });
  // Teach by zooming (approach_mode tbz) steers from the feature tracker's verified correspondences.
  if (auto* tbz = dynamic_cast<TbzApproach*>(&machine_.approach())) {
    subscribe<feature_matches_t>(ch::kFeatureMatches, [tbz](const feature_matches_t& m) { tbz->on_matches(m); });
    advertise(kTbzErrorChannel);
  }
  every(rt::from_seconds(cfg_.tick_period_s), [this] {
    emit(machine_.tick(now()));
    publish_tbz_error();
  });
  every(rt::from_seconds(cfg_.status_period_s), [this] { publish_status(); });
  spdlog::info("{}approach mode '{}', speed limit {:.3f} m/s, IR switch at {:.1f} mm", log_prefix(), cfg_.approach_mode,
               cfg_.max_linear_speed, cfg_.ir_switch_distance * 1000.0);
  spdlog::info("{}{}", log_prefix(), authority_.describe());
  publish_status();
}

void ServoControllerNode::emit(MachineOutput out) {
  // The robot command first: on an emergency stop nothing may delay it.
  if (out.robot) {
    publish(channels::kRobotCommand, *out.robot, [this](robot_command_t& m) { authority_.sign(m); });
    count(out.robot->type == robot_command_t::TYPE_STOP ? "stop_commands" : "motion_commands");
  }
  if (out.gripper)
    publish(channels::kGripperCommand, *out.gripper, [this](gripper_command_t& m) { authority_.sign(m); });
  if (!out.log.empty()) spdlog::warn("{}{}", log_prefix(), out.log);
  if (!out.invalid_input.empty()) {
    count("invalid_input");
    const int64_t n = stats().counters.at("invalid_input");
    int64_t suppressed = 0;
    rt::Micros since = 0;
    if (invalid_log_.admit(now(), suppressed, since))
      spdlog::warn("{}{}; {} invalid inputs so far", log_prefix(), out.invalid_input, n);
  }
  if (out.status_changed) publish_status();
  if (machine_.state() == State::kFault || machine_.estop())
    set_health(rt::Health::kDegraded, machine_.summary());
  else
    set_health(rt::Health::kOk);
}

void ServoControllerNode::publish_tbz_error() {
  const auto* tbz = dynamic_cast<const TbzApproach*>(&machine_.approach());
  if (!tbz || !tbz->stepped_at() || *tbz->stepped_at() == tbz_error_published_) return;
  tbz_error_published_ = *tbz->stepped_at();
  twist_t e{};
  const auto& o = tbz->last_output();
  for (int i = 0; i < 3; ++i) {
    e.linear[i] = o.e_v[i];
    e.angular[i] = o.e_w[i];
  }
  publish(kTbzErrorChannel, e);
}

void ServoControllerNode::publish_status() {
  harvest_status_t s = machine_.status();
  if (s.summary != last_summary_) {
    spdlog::info("{}{}", log_prefix(), s.summary);
    last_summary_ = s.summary;
  }
  publish(channels::kHarvestStatus, s);
}

}  // namespace harvest::servo
