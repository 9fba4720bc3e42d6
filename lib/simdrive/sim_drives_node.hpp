// Node of harvest-sim-drives: the arm's CiA 402 drives simulated on a CAN bus
// (normally the udp_multicast virtual bus), with fault injection through
// SIM_DRIVE_FAULT (sim_drive_fault_t).
#pragma once

#include <harvest/sim_drive_fault_t.hpp>

#include <memory>
#include <string>

#include "can/can_bus.hpp"
#include "canopen/master.hpp"
#include "config/config.hpp"
#include "config/schema.hpp"
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

// The keys of config/arm/sim_drives.yaml (the drive list: canopen::drive_keys).
namespace sim_drives_keys {
using config::Key;
inline constexpr Key<config::Path> arm_model{"arm_model", "k1207i.yaml", {}, "",
                                             "the arm model: joint limits and home (the drives start there)"};
inline constexpr Key<config::Path> drives_file{"drives_file", "drives_k1207i.yaml", {}, "",
                                               "the drive list, shared with the robot link"};
inline constexpr Key<double> acceleration_margin{"acceleration_margin", 1.5, {1.0, 100.0}, "",
                                                 "a drive follows at up to this x its joint's acceleration limit"};
inline constexpr Key<double> quick_stop_deceleration_factor{
    "quick_stop_deceleration_factor", 3.0, {1.0, 100.0}, "",
    "quick-stop ramp before the master writes 0x6085, x the joint's acceleration limit"};
inline constexpr Key<int> step_ms{"step_ms", 1, {1, 100}, "ms", "simulation step"};
inline constexpr Key<int> sync_timeout_ms{"sync_timeout_ms", 500, {0, 10000}, "ms",
                                          "vendor watchdog: an enabled drive without SYNC this long faults (0: off)"};
inline constexpr Key<int> own_stall_ms{
    "own_stall_ms", 10, {0, 1000}, "ms",
    "a gap longer than this between two steps of the drives is this host's stall, not the master's silence (real "
    "drives keep running): only this much of it counts against the heartbeat, RPDO and SYNC deadlines (0 = off)"};
}  // namespace sim_drives_keys

struct SimDrivesConfig {
  std::string bus{canopen::kBusKey.fallback};
  std::vector<SimDriveConfig> drives;
  int64_t step_us = sim_drives_keys::step_ms.fallback * 1000;
  static SimDrivesConfig from_config(const config::Node& root);
  static std::vector<config::Section> schema();
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
