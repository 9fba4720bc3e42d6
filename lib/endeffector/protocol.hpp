// The end-effector line protocol (docs/end-effector-protocol.md): typed
// messages, their encoding into framed, checksummed ASCII lines, and CRC-16.
// No I/O here: bytes in, bytes out.
//
//   $<version>,<seq>,<TYPE>[,<field>...]*<CRC16 as 4 upper-case hex digits>\n
//
// The CRC (CRC-16/CCITT-FALSE) covers everything between '$' and '*'.
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>
#include <string_view>
#include <variant>

namespace harvest::endeffector {

inline constexpr int kProtocolVersion = 1;
inline constexpr std::size_t kMaxLine = 128;  // bytes from '$' to '\n' inclusive
inline constexpr std::size_t kMaxFaultText = 48;

// CRC-16/CCITT-FALSE: poly 0x1021, init 0xFFFF, no reflection, no final xor.
uint16_t crc16(std::string_view data);

// ---- host -> board ----
struct Ping {
  uint32_t token = 0;  // echoed in the Pong
};
struct Open {};
struct Close {
  int32_t force_mn = 0;  // grip force limit [mN], 0 = board default
};
struct Move {
  int32_t position_permille = 0;  // target opening, 0 = closed, 1000 = fully open
  int32_t force_mn = 0;
};
struct Stop {};

// ---- board -> host ----
struct IrSample {
  int32_t raw = 0;  // ADC counts
};
enum class GripState : int8_t { kOpen = 0, kClosing = 1, kClosed = 2, kHolding = 3, kOpening = 4, kStopped = 5, kFault = 6 };
inline constexpr int kGripStateMax = 6;
struct Grip {
  GripState state = GripState::kOpen;
  int32_t position_permille = 1000;
  int32_t force_mn = 0;
};
struct Fault {
  int32_t code = 0;  // 0: all faults cleared
  std::string text;  // sanitised on encode: [A-Za-z0-9 _.:-/] only, <= kMaxFaultText
};
struct Pong {
  uint32_t token = 0;
  int32_t version = kProtocolVersion;
  std::string firmware;  // same character set as Fault::text
};
struct Ack {
  uint16_t command_seq = 0;
  int32_t status = 0;  // 0 accepted, otherwise rejected (see docs)
};

using Message = std::variant<Ping, Open, Close, Move, Stop, IrSample, Grip, Fault, Pong, Ack>;

struct Frame {
  uint16_t seq = 0;  // per sender, wraps at 65536
  Message message;
};

// The frame type tag as written on the line ("PING", "IR", ...).
std::string_view type_tag(const Message& m);

// One complete line including the trailing '\n'.
std::string encode(const Frame& frame);
// Builds a line with arbitrary version and payload (tests, fuzz seeds, emulator faults).
std::string encode_raw(int version, std::string_view payload_after_version);

// Restrict free text to characters that cannot break framing.
std::string sanitize_text(std::string_view text);

}  // namespace harvest::endeffector
