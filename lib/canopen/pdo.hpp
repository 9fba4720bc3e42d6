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

// The writes, in order, that put a drive into cyclic synchronous velocity
// mode with the default mapping and a heartbeat every `heartbeat_ms`. PDOs
// are disabled (COB-ID bit 31) while their mapping is rewritten, as CiA 301
// requires.
std::vector<SdoWrite> default_drive_configuration(uint8_t node, uint16_t heartbeat_ms);

}  // namespace harvest::canopen
