#include "simdrive/sim_drives_node.hpp"

#include <spdlog/spdlog.h>

#include "canopen/master.hpp"

namespace harvest::simdrive {

std::vector<SimDriveConfig> sim_drive_configs(const kinematics::ArmModel& model, const config::Node& drives_root,
                                              double acceleration_margin, double quick_stop_factor) {
  // The same reader as the robot link's, so both sides agree on ids and scaling.
  const auto drives = drives_root.children("drives");
  if (static_cast<int>(drives.size()) != model.dof())
    drives_root.fail("drives", "one drive per joint of the arm model (" + std::to_string(model.dof()) + ")");
  std::vector<SimDriveConfig> out;
  for (int i = 0; i < model.dof(); ++i) {
    const auto& d = drives[static_cast<std::size_t>(i)];
    SimDriveConfig c;
    c.node_id = static_cast<uint8_t>(d.get(canopen::drive_keys::node_id));
    c.counts_per_radian = d.get(canopen::drive_keys::counts_per_radian);
    c.zero_offset_counts = d.get(canopen::drive_keys::zero_offset_counts);
    const auto& joint = model.joints[static_cast<std::size_t>(i)];
    c.max_acceleration = acceleration_margin * joint.max_acceleration;
    c.quick_stop_deceleration = quick_stop_factor * joint.max_acceleration;
    c.initial_position = model.home[i];
    out.push_back(c);
  }
  return out;
}

SimDrivesConfig SimDrivesConfig::from_config(const config::Node& root) {
  namespace k = sim_drives_keys;
  SimDrivesConfig c;
  c.bus = canopen::bus_from_config(root, canopen::kBusKey);
  const auto model = kinematics::ArmModel::load(root.get(k::arm_model).string());
  auto drives_doc = config::Document::load_file(root.get(k::drives_file));
  const double margin = root.get(k::acceleration_margin);
  const double qs = root.get(k::quick_stop_deceleration_factor);
  c.drives = sim_drive_configs(model, drives_doc.root(), margin, qs);
  drives_doc.check_unused();
  c.step_us = root.get(k::step_ms) * 1000;
  const Micros sync_timeout = root.get(k::sync_timeout_ms) * 1000;
  const Micros own_stall = root.get(k::own_stall_ms) * 1000;
  if (own_stall > 0 && own_stall < c.step_us) root.fail("own_stall_ms", "0 (off) or at least step_ms");
  for (auto& d : c.drives) {
    d.sync_timeout_us = sync_timeout;
    d.own_stall_us = own_stall;
  }
  return c;
}

std::vector<config::Section> SimDrivesConfig::schema() {
  namespace k = sim_drives_keys;
  return {config::section("sim_drives", "harvest-sim-drives, config/arm/sim_drives.yaml (docs/robot-link.md).",
                          canopen::kBusKey, k::arm_model, k::drives_file, k::acceleration_margin,
                          k::quick_stop_deceleration_factor, k::step_ms, k::sync_timeout_ms, k::own_stall_ms)};
}

SimDrivesNode::SimDrivesNode(SimDrivesConfig config) : rt::Node("sim_drives"), config_(std::move(config)) {}

void SimDrivesNode::on_attach() {
  bus_ = can::open_bus(config_.bus);
  set_ = std::make_unique<SimDriveSet>(*bus_, config_.drives);
  if (bus_->fd() >= 0) ctx().watch_fd(bus_->fd(), [this] { set_->drain(now()); });
  every(config_.step_us, [this] {
    set_->drain(now());
    set_->advance(now());
  });
  subscribe<harvest::sim_drive_fault_t>(kSimDriveFaultChannel, [this](const auto& m) { on_fault(m); });
  set_health(rt::Health::kOk);
  spdlog::info("{} simulated CiA 402 drives on {}", set_->size(), bus_->describe());
}

void SimDrivesNode::on_fault(const harvest::sim_drive_fault_t& msg) {
  if (msg.joint < 0 || msg.joint > static_cast<int>(set_->size())) {
    spdlog::warn("SIM_DRIVE_FAULT for joint {} ignored: the arm has {} joints", msg.joint, set_->size());
    return;
  }
  for (std::size_t i = 0; i < set_->size(); ++i) {
    if (msg.joint != 0 && static_cast<int>(i) + 1 != msg.joint) continue;
    SimDrive& d = set_->drive(i);
    switch (msg.kind) {
      case harvest::sim_drive_fault_t::KIND_FAULT:
        d.inject_fault(static_cast<uint16_t>(msg.error_code));
        break;
      case harvest::sim_drive_fault_t::KIND_HEARTBEAT_OFF:
        d.set_heartbeat_enabled(false);
        break;
      case harvest::sim_drive_fault_t::KIND_SILENT:
        d.set_silent(true);
        break;
      case harvest::sim_drive_fault_t::KIND_RESTORE:
        d.set_silent(false);
        d.set_heartbeat_enabled(true);
        break;
      default:
        spdlog::warn("SIM_DRIVE_FAULT kind {} unknown", msg.kind);
        return;
    }
    spdlog::warn("injected fault kind {} into joint {}", msg.kind, i + 1);
  }
}

}  // namespace harvest::simdrive
