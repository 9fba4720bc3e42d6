// The arm's default PDO mapping (docs/can.md), and the SDO writes that
// configure it on a drive at start:
//   RPDO1 0x200+id: controlword 0x6040 (u16) + target velocity 0x60FF (i32)
//   TPDO1 0x180+id: statusword 0x6041 (u16) + position actual 0x6064 (i32)
//   TPDO2 0x280+id: velocity actual 0x606C (i32)
// All PDOs are synchronous (transmission type 1: every SYNC).
#pragma once

#include <cstdint>
#include <optional>
#include <vector>

#include "canopen/protocol.hpp"

namespace harvest::canopen {

CanFrame rpdo1_frame(uint8_t node, uint16_t controlword, int32_t target_velocity);

struct Tpdo1 {
  uint16_t statusword = 0;
  int32_t position = 0;  // counts
};
std::optional<Tpdo1> decode_tpdo1(const CanFrame& f);
std::optional<int32_t> decode_tpdo2(const CanFrame& f);  // counts/s

// One object-dictionary write.
struct SdoWrite {
  uint16_t index;
  uint8_t sub;
  uint32_t value;
  uint8_t size;  // bytes: 1, 2 or 4
};

// What a drive is told to do on its own when the master falls silent
// (docs/can.md, "Drive-side protection"): it consumes the master's heartbeat
// (CiA 301 0x1016), watches the deadline of its RPDO1 (CiA 301 0x1400:05,
// the RPDO event timer: EMCY 0x8250 on expiry) and answers either loss with
// the abort connection option (CiA 402 0x6007) quick stop, at its quick-stop
// deceleration (0x6085). 0 leaves an item as the drive has it.
struct DriveProtection {
  uint8_t master_node = 0;               // whose heartbeat the drive consumes (0 = none)
  uint16_t heartbeat_consumer_ms = 0;    // 0x1016:01 consumer time
  uint16_t rpdo_timeout_ms = 0;          // 0x1400:05 RPDO1 event timer (deadline)
  int16_t abort_connection_option = 3;   // 0x6007: 0 none, 1 fault, 2 disable voltage, 3 quick stop
  uint32_t quick_stop_deceleration = 0;  // 0x6085 [counts/s^2]
  // 0x1029:01, the NMT state a communication error sends the drive to: 0
  // pre-operational (the CiA 301 default), 1 no change, 2 stopped; -1 leaves
  // it as the drive has it. 1 keeps the TPDOs coming while the drive stops
  // itself, so the master still sees the joints (pre-operational and stopped
  // end them: the master's last reading would freeze mid-ramp).
  int8_t communication_error_behaviour = 1;
};

// The writes, in order, that put a drive into cyclic synchronous velocity
// mode with the default mapping, a heartbeat every `heartbeat_ms` and its own
// protection. PDOs are disabled (COB-ID bit 31) while their mapping is
// rewritten, as CiA 301 requires.
std::vector<SdoWrite> default_drive_configuration(uint8_t node, uint16_t heartbeat_ms,
                                                  const DriveProtection& protection = {});

}  // namespace harvest::canopen
