// The arm's hardware interface (ros2_control's term): the CAN bus and the
// CANopen master of the arm's drives. The robot link reads it at the start of
// each control period and writes it at the end (joint velocities, then SYNC);
// what the drives report becomes latched faults in the motion supervisor and
// bits of robot_state_t.fault_flags.
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <string>

#include "arm/motion_safety.hpp"
#include "can/can_bus.hpp"
#include "canopen/master.hpp"

namespace harvest::arm {

class ArmHardware {
 public:
  using Count = std::function<void(const std::string& counter, int64_t n)>;

  // `bus` may be injected (tests); otherwise open() opens `bus_spec`.
  ArmHardware(std::string bus_spec, canopen::MasterConfig can, std::unique_ptr<can::CanBus> bus);
  void open();  // throws can::CanError with the reason

  // A new master: every drive's start-up (configuration over SDO, NMT start)
  // again, with the goal Operation Enabled.
  void restart(Micros now);

  // Start of a period: every frame received, the drives' deadlines checked,
  // joints read. False until every drive has sent its PDOs.
  bool read(Micros now, Eigen::VectorXd& q, Eigen::VectorXd& qd);
  // The drives' events logged, their counters added to `count`, and every
  // latched cause (drive fault, lost drive, foreign frames, bus off, failed
  // start-up) passed to `supervisor` (which latches each text once).
  void report(MotionSupervisor& supervisor, const Count& count);
  // End of a period: the joint velocity commands, then SYNC.
  void write(const Eigen::VectorXd& qdot, Micros now);

  // Started and running (false before the first restart or once the start-up failed).
  bool running() const { return master_ && master_->phase() == canopen::MasterPhase::kRunning; }
  bool enabled() const { return master_->all_in(canopen::Cia402State::kOperationEnabled); }
  // The drives' and the bus's bits of robot_state_t.fault_flags.
  int32_t fault_flags() const;
  // Time of the SYNC before the last one: what the TPDOs read in read() answer.
  Micros sampled() const { return sampled_; }

  canopen::Master& master() { return *master_; }
  const canopen::Master& master() const { return *master_; }
  can::CanBus& bus() { return *bus_; }

 private:
  std::string bus_spec_;
  canopen::MasterConfig can_;
  std::unique_ptr<can::CanBus> bus_;
  std::unique_ptr<canopen::Master> master_;
  std::map<std::string, int64_t> mirrored_;  // master counters already passed on
  Micros last_sync_ = 0, sampled_ = 0;
};

}  // namespace harvest::arm
