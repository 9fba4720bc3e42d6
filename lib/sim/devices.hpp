// Hardware mode "devices": the simulator plays the arm's hardware, not the
// robot link or the end-effector bridge. The arm is a set of simulated CiA 402
// drives (lib/simdrive) on a CAN bus, configured exactly as harvest-sim-drives
// configures them; the arm's true pose is the forward kinematics of the true
// arm model at the drives' joint positions, placed by the scenario's true
// mounting. The end-effector board is the board emulator (lib/endeffector)
// whose IR reading and gripper are the simulator's physics. The field's
// harvest-robot-link and harvest-ee-bridge then run against it unchanged.
#pragma once

#include <Eigen/Geometry>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "can/can_bus.hpp"
#include "config/schema.hpp"
#include "config/config.hpp"
#include "endeffector/board_emulator.hpp"
#include "kinematics/arm_model.hpp"
#include "sim/hand.hpp"
#include "sim/scenario.hpp"
#include "simdrive/sim_drive.hpp"

namespace harvest::sim {

// The simulator's `devices` keys (hardware: devices); `board` takes the
// emulator's endeffector::board_keys too.
namespace devices_keys {
using config::Key;
inline constexpr Key<config::Path> drives_config{.name = "drives_config",
                                                 .doc = "the file harvest-sim-drives reads (config/arm/sim_drives.yaml)",
                                                 .required = true};
inline constexpr Key<std::string> bus{.name = "bus", .doc = "the CAN bus of the simulated drives (docs/can.md)",
                                      .derived = "the drives file's bus"};
inline constexpr Key<std::string> board_host{"host", "127.0.0.1", {}, "", "the board emulator listens here (TCP)"};
inline constexpr Key<int> board_port{"port", 4001, {1, 65535}, "", "... on this port, as ser2net serves the real one"};
inline constexpr Key<int> service_period_ms{"service_period_ms", 5, {1, 100}, "ms", "the board's service period"};
inline constexpr Key<std::string> board_firmware{"firmware", "harvest-sim-1", {}, "",
                                                 "firmware version the board reports"};
}  // namespace devices_keys

struct DevicesConfig {
  // The CAN bus spec; by default the one in the drives configuration.
  std::string bus;
  // The true arm and its drives, read from the file harvest-sim-drives reads
  // (config/arm/sim_drives.yaml: arm model, drive list, acceleration margins).
  std::string drives_config_path;
  kinematics::ArmModel model;
  std::vector<simdrive::SimDriveConfig> drives;
  int64_t drive_step_us = 1000;
  // The end-effector board on TCP, as ser2net serves the real one.
  std::string board_host{devices_keys::board_host.fallback};
  int board_port = devices_keys::board_port.fallback;
  int64_t board_service_us = devices_keys::service_period_ms.fallback * 1000;
  endeffector::EmulatorConfig board;

  static DevicesConfig from_config(const config::Node& node);
  static std::vector<config::Section> schema(const std::string& path, const std::string& where);
};

// Placement <-> Isometry3d.
Placement to_placement(const Eigen::Isometry3d& t);
Eigen::Isometry3d to_isometry(const Placement& p);

struct StartConfiguration {
  Eigen::VectorXd q;      // joint angles [rad]
  double tilt_rad = 0.0;  // how far the tool orientation had to give way
};

// Joint configuration that puts the tool at `start` (world frame) for an arm
// mounted at `mounting` (robot base frame in the world); searched from the
// model's home. If the wrist cannot take the start orientation, the position
// is kept and the orientation turned toward the home orientation as little
// as needed (`tilt_rad` says how much). Throws std::runtime_error if the arm
// cannot reach the position at all.
StartConfiguration start_joints(const kinematics::ArmModel& model, const Eigen::Isometry3d& mounting,
                                const Placement& start);

// The arm as drives on a bus. Like a node, it has no clock: callers pass now.
class DeviceArm {
 public:
  // The drives start at `q0` (their configured initial positions are replaced).
  DeviceArm(can::CanBus& bus, kinematics::ArmModel model, std::vector<simdrive::SimDriveConfig> drives,
            const Eigen::VectorXd& q0, const Eigen::Isometry3d& mounting, const Placement& hand_eye);

  void drain(rt::Micros now) { set_.drain(now); }
  void advance(rt::Micros now);

  Eigen::VectorXd joints() const;
  const Placement& tool() const { return tool_; }                // true TCP, world frame
  const Placement& hand_camera() const { return hand_camera_; }  // true hand camera, world frame
  simdrive::SimDriveSet& drives() { return set_; }
  const kinematics::ArmModel& model() const { return model_; }

 private:
  static std::vector<simdrive::SimDriveConfig> with_start(std::vector<simdrive::SimDriveConfig> d,
                                                          const Eigen::VectorXd& q0);
  void update_pose();

  kinematics::ArmModel model_;
  simdrive::SimDriveSet set_;
  Eigen::Isometry3d mounting_;
  Placement hand_eye_;  // true camera in the tool frame (the arm model's camera is the software's)
  Placement tool_, hand_camera_;
};

// The simulator's gripper as the board emulator's gripper model: board
// commands close and open the fingers; readings report what the physics does.
class BoardGripper final : public endeffector::GripperModel {
 public:
  // `seconds` maps board time to simulation time.
  BoardGripper(Gripper& gripper, std::function<double(rt::Micros)> seconds, double default_force_n)
      : gripper_(gripper), seconds_(std::move(seconds)), default_force_(default_force_n) {}
  void command(const endeffector::GripperGoal& goal, rt::Micros now) override;
  endeffector::GripperReading read(rt::Micros now) override;

 private:
  Gripper& gripper_;
  std::function<double(rt::Micros)> seconds_;
  double default_force_;
  double force_limit_ = 0.0;
};

}  // namespace harvest::sim
