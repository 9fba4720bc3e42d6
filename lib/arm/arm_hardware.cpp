#include "arm/arm_hardware.hpp"

#include <spdlog/spdlog.h>

#include <algorithm>
#include <vector>

#include "arm/fault_flags.hpp"

namespace harvest::arm {

ArmHardware::ArmHardware(std::string bus_spec, canopen::MasterConfig can, std::unique_ptr<can::CanBus> bus)
    : bus_spec_(std::move(bus_spec)), can_(std::move(can)), bus_(std::move(bus)) {}

void ArmHardware::open() {
  if (!bus_) bus_ = can::open_bus(bus_spec_);
}

void ArmHardware::restart(Micros now) {
  master_ = std::make_unique<canopen::Master>(*bus_, can_);
  mirrored_.clear();
  master_->start(now);
  master_->set_goal(canopen::DriveGoal::kEnabled);
}

bool ArmHardware::read(Micros now, Eigen::VectorXd& q, Eigen::VectorXd& qd) {
  master_->drain(now);
  master_->check_timeouts(now);  // a lost drive stops this period's commands, not the next one's
  bool all_seen = true;
  const auto& drives = master_->drives();
  for (Eigen::Index i = 0; i < q.size(); ++i) {
    const auto& d = drives[static_cast<std::size_t>(i)];
    all_seen = all_seen && d.seen_pdo;
    q[i] = d.position;
    qd[i] = d.velocity;
  }
  return all_seen;
}

void ArmHardware::report(MotionSupervisor& supervisor, const Count& count) {
  for (const auto& e : master_->take_events()) spdlog::error("drive: {}", e);
  for (const auto& [name, value] : master_->counters()) {
    count(name, value - mirrored_[name]);
    mirrored_[name] = value;
  }
  if (master_->phase() == canopen::MasterPhase::kFailed) supervisor.on_fault(master_->error());
  if (master_->any_fault()) {
    // One entry per latched cause (the drive's text accumulates them), so the
    // supervisor's text lists each cause once.
    for (const auto& d : master_->drives()) {
      if (!d.faulted()) continue;
      std::size_t begin = 0;
      while (begin <= d.fault_text.size()) {
        const std::size_t end = std::min(d.fault_text.find("; ", begin), d.fault_text.size());
        if (end > begin) supervisor.on_fault(d.fault_text.substr(begin, end - begin));
        begin = end + 2;
      }
    }
  }
  if (!master_->bus_fault().empty()) supervisor.on_fault(master_->bus_fault());
  if (bus_->state() == can::BusState::kBusOff) supervisor.on_fault("CAN bus off");
}

void ArmHardware::write(const Eigen::VectorXd& qdot, Micros now) {
  master_->set_velocities(std::vector<double>(qdot.data(), qdot.data() + qdot.size()));
  sampled_ = last_sync_;
  master_->sync(now);
  last_sync_ = now;
}

int32_t ArmHardware::fault_flags() const {
  int32_t flags = 0;
  for (const auto& d : master_->drives()) {
    if (d.fault) flags |= kFlagDriveFault;
    if (d.emcy) flags |= kFlagEmcy;
    if (d.heartbeat_lost) flags |= kFlagHeartbeatLost;
    if (d.pdo_lost) flags |= kFlagPdoLost;
    if (d.foreign) flags |= kFlagForeign;
    if (d.nmt_left) flags |= kFlagNmtLeft;
    if (d.uncommanded) flags |= kFlagUncommanded;
  }
  if (!master_->bus_fault().empty()) flags |= kFlagForeign;
  if (master_->phase() == canopen::MasterPhase::kFailed || bus_->state() == can::BusState::kBusOff) flags |= kFlagBus;
  return flags;
}

}  // namespace harvest::arm
