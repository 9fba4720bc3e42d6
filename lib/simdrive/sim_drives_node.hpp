// Node of harvest-sim-drives: the arm's CiA 402 drives simulated on a CAN bus
// (normally the udp_multicast virtual bus), with fault injection through
// SIM_DRIVE_FAULT (sim_drive_fault_t).
#pragma once

#include <harvest/sim_drive_fault_t.hpp>

#include <memory>
#include <string>

#include "can/can_bus.hpp"
#include "config/config.hpp"
#include "kinematics/arm_model.hpp"
#include "runtime/node.hpp"
#include "simdrive/sim_drive.hpp"

namespace harvest::simdrive {

inline constexpr const char* kSimDriveFaultChannel = "SIM_DRIVE_FAULT";

// Drive parameters for an arm: node ids and scaling from the robot link's
// drive list, initial positions at the model's home, acceleration limits a
// margin above the model's joint limits (so the drives follow any command the
// robot link may send).
std::vector<SimDriveConfig> sim_drive_configs(const kinematics::ArmModel& model, const config::Node& drives_file_root,
                                              double acceleration_margin, double quick_stop_factor);

struct SimDrivesConfig {
  std::string bus = "udp_multicast:239.74.163.2:43113";
  std::vector<SimDriveConfig> drives;
  int64_t step_us = 1000;
  static SimDrivesConfig from_config(const config::Node& root);
};

class SimDrivesNode final : public rt::Node {
 public:
  explicit SimDrivesNode(SimDrivesConfig config);
  SimDriveSet& drives() { return *set_; }

 protected:
  void on_attach() override;

 private:
  void on_fault(const harvest::sim_drive_fault_t& msg);
  SimDrivesConfig config_;
  std::unique_ptr<can::CanBus> bus_;
  std::unique_ptr<SimDriveSet> set_;
};

}  // namespace harvest::simdrive
