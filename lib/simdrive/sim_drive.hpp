// A simulated CiA 402 servo drive on a CAN bus: object dictionary subset, SDO
// server, NMT, heartbeat producer, EMCY, synchronous PDOs with the mapping the
// master configured (so a wrong configuration shows up as wrong data), the
// CiA 402 state machine, and a joint that follows the target velocity with
// an acceleration limit and a finite encoder resolution. Fault injection
// hooks let tests and the simulator break it on purpose.
//
// Like a node, it has no clock of its own: callers pass now (microseconds).
// The simulator embeds SimDriveSet and reads the true joint positions.
#pragma once

#include <array>
#include <cstdint>
#include <functional>
#include <memory>
#include <vector>

#include "can/can_bus.hpp"
#include "canopen/cia402.hpp"
#include "canopen/protocol.hpp"
#include "canopen/sdo_server.hpp"
#include "runtime/awake_clock.hpp"

namespace harvest::simdrive {

using canopen::Cia402State;
using canopen::Micros;
using canopen::NmtState;

struct SimDriveConfig {
  uint8_t node_id = 1;
  double counts_per_radian = 417'000.0;
  int32_t zero_offset_counts = 0;
  double max_acceleration = 3.0;         // [rad/s^2] velocity following
  double quick_stop_deceleration = 6.0;  // [rad/s^2]
  double initial_position = 0.0;         // [rad]
  // A vendor's own communication watchdog, on before any master configures
  // the standard objects below: with torque on and no SYNC for this long the
  // drive goes to fault reaction (ramp down) and Fault with error code
  // 0x8100. 0 = off (the default, so embedders keep the old behaviour;
  // harvest-sim-drives sets it from sync_timeout_ms).
  Micros sync_timeout_us = 0;
  // The drive is real hardware that never stops; the simulator's host may
  // (a frozen virtual machine stops the drives and the master alike). A gap
  // longer than this between two calls counts only this much against the
  // deadlines below (rt::AwakeClock); the joint still moves through all of
  // it. 0 = off (the default; harvest-sim-drives sets it from own_stall_ms).
  Micros own_stall_us = 0;
  // The standard protection a master configures by SDO (docs/can.md), as a
  // drive implements it: heartbeat consumer 0x1016 (EMCY 0x8130 on a lost
  // heartbeat), RPDO deadline 0x1400:05 (EMCY 0x8250), each a communication
  // error answered with the abort connection option 0x6007 and the error
  // behaviour 0x1029:01; quick stop at 0x6085. Their defaults before a
  // master writes them: consumer off, deadline off, 0x6007 = 1 (fault),
  // 0x1029:01 = 0 (pre-operational), 0x6085 from quick_stop_deceleration.
};

class SimDrive {
 public:
  SimDrive(SimDriveConfig config, std::function<void(const can::CanFrame&)> send);

  void handle_frame(const can::CanFrame& frame, Micros now);
  // Integrates the joint up to `now` and sends heartbeats that are due.
  void advance(Micros now);

  // Truth, for the simulator and tests.
  double position() const { return position_; }  // [rad]
  double velocity() const { return velocity_; }  // [rad/s]
  Cia402State state() const { return state_; }
  NmtState nmt_state() const { return nmt_; }
  const SimDriveConfig& config() const { return config_; }
  const canopen::ObjectDictionary& dictionary() const { return od_; }

  // Fault injection.
  void inject_fault(uint16_t error_code);             // fault reaction (ramp down), then Fault; sends EMCY
  void set_silent(bool silent) { silent_ = silent; }  // sends nothing at all (drive lost, cable cut)
  void set_heartbeat_enabled(bool on) { heartbeat_enabled_ = on; }
  void set_position(double rad) { position_ = rad; }
  // The drive's own input (safe torque off, a local panel) switches it off:
  // switch on disabled, with no command on the bus.
  void local_disable() { set_state(Cia402State::kSwitchOnDisabled); }

 private:
  void send(const can::CanFrame& f);
  void build_dictionary();
  void reset(bool application);  // NMT reset node (true) or reset communication
  void communication_error(uint16_t emcy_code);
  // The abort connection option (0x6007) on a drive producing torque; a
  // fault (option 1) gets `fault_code`.
  void abort_connection(uint16_t fault_code);
  void on_sync(Micros now);
  void apply_rpdo(const can::CanFrame& f);
  void send_tpdos();
  void set_state(Cia402State s);
  int32_t position_counts() const;

  SimDriveConfig config_;
  std::function<void(const can::CanFrame&)> send_;
  canopen::ObjectDictionary od_;
  std::unique_ptr<canopen::SdoServer> sdo_;
  NmtState nmt_ = NmtState::kBootUp;
  Cia402State state_ = Cia402State::kSwitchOnDisabled;
  uint16_t last_controlword_ = 0;
  std::vector<can::CanFrame> pending_rpdo_;  // synchronous RPDOs act at the next SYNC
  double position_ = 0.0, velocity_ = 0.0, target_velocity_ = 0.0;
  rt::AwakeClock awake_;   // the deadlines below are in its time, the motion in wall time
  Micros last_advance_ = -1;
  Micros last_sync_ = -1;
  Micros next_heartbeat_ = 0;
  Micros master_heartbeat_ = -1;  // last heartbeat of the consumed producer (-1: none yet, not monitored)
  bool master_heartbeat_lost_ = false;
  Micros last_rpdo_ = -1;  // last RPDO1 in operational (-1: none yet, deadline not monitored)
  bool rpdo_late_ = false;
  bool booted_ = false;
  bool silent_ = false;
  bool heartbeat_enabled_ = true;
};

// Several drives sharing one bus, as on the arm.
class SimDriveSet {
 public:
  SimDriveSet(can::CanBus& bus, const std::vector<SimDriveConfig>& configs);
  void drain(Micros now);  // dispatch every waiting frame
  // When the last frame from the bus arrived (its transport timestamp, else
  // the `now` it was drained at); -1 before the first.
  Micros last_frame_time() const { return last_frame_; }
  void advance(Micros now);
  SimDrive& drive(std::size_t i) { return *drives_[i]; }
  std::size_t size() const { return drives_.size(); }
  std::vector<double> positions() const;

 private:
  can::CanBus& bus_;
  std::vector<std::unique_ptr<SimDrive>> drives_;
  Micros last_frame_ = -1;
};

}  // namespace harvest::simdrive
