// CANopen (CiA 301) frame layouts used by the arm: COB-IDs, NMT, heartbeat,
// SYNC, EMCY and SDO (expedited and segmented). Pure encoding and decoding,
// little-endian as the standard requires; no state.
#pragma once

#include <cstdint>
#include <optional>
#include <string>

#include "can/can_bus.hpp"

namespace harvest::canopen {

using can::CanFrame;
using Micros = int64_t;  // microseconds on the caller's (injected) clock

// Predefined connection set (CiA 301 7.3.5).
namespace cob {
inline constexpr uint32_t kNmt = 0x000;
inline constexpr uint32_t kSync = 0x080;
inline constexpr uint32_t kEmcy = 0x080;       // + node id
inline constexpr uint32_t kTpdo1 = 0x180;      // + node id
inline constexpr uint32_t kRpdo1 = 0x200;      // + node id
inline constexpr uint32_t kTpdo2 = 0x280;      // + node id
inline constexpr uint32_t kSdoTx = 0x580;      // server -> client, + node id
inline constexpr uint32_t kSdoRx = 0x600;      // client -> server, + node id
inline constexpr uint32_t kHeartbeat = 0x700;  // + node id
}  // namespace cob

// Function code (COB-ID minus node id) and node id of a predefined frame.
inline uint32_t function_of(uint32_t id) { return id & 0x780; }
inline uint8_t node_of(uint32_t id) { return static_cast<uint8_t>(id & 0x7F); }

enum class NmtCommand : uint8_t {
  kStart = 0x01,
  kStop = 0x02,
  kEnterPreOperational = 0x80,
  kResetNode = 0x81,
  kResetCommunication = 0x82,
};
enum class NmtState : uint8_t { kBootUp = 0x00, kStopped = 0x04, kOperational = 0x05, kPreOperational = 0x7F };
const char* to_string(NmtState s);

CanFrame nmt_frame(NmtCommand command, uint8_t node);  // node 0 = all nodes
CanFrame heartbeat_frame(uint8_t node, NmtState state);
std::optional<NmtState> decode_heartbeat(const CanFrame& frame);
CanFrame sync_frame();

struct Emcy {
  uint16_t error_code = 0;     // 0x0000 = error reset / no error
  uint8_t error_register = 0;  // object 0x1001
  std::array<uint8_t, 5> vendor{};
};
CanFrame emcy_frame(uint8_t node, const Emcy& e);
std::optional<Emcy> decode_emcy(const CanFrame& frame);
std::string describe_emcy(uint16_t error_code);  // "0x2310 current, device output side"

// ---- SDO (CiA 301 7.2.4.3) ----
namespace sdo {
// Command specifiers (bits 7..5 of byte 0).
inline constexpr uint8_t kClientDownloadSegment = 0;  // ccs 0
inline constexpr uint8_t kClientInitiateDownload = 1;
inline constexpr uint8_t kClientInitiateUpload = 2;
inline constexpr uint8_t kClientUploadSegment = 3;
inline constexpr uint8_t kAbort = 4;
inline constexpr uint8_t kServerUploadSegment = 0;  // scs 0
inline constexpr uint8_t kServerDownloadSegment = 1;
inline constexpr uint8_t kServerInitiateUpload = 2;
inline constexpr uint8_t kServerInitiateDownload = 3;

inline uint8_t specifier(const CanFrame& f) { return static_cast<uint8_t>(f.data[0] >> 5); }
inline uint16_t index_of(const CanFrame& f) { return static_cast<uint16_t>(f.data[1] | (f.data[2] << 8)); }
inline uint8_t subindex_of(const CanFrame& f) { return f.data[3]; }

// Abort codes (CiA 301 table 22).
inline constexpr uint32_t kAbortToggle = 0x05030000;
inline constexpr uint32_t kAbortTimeout = 0x05040000;
inline constexpr uint32_t kAbortBadCommand = 0x05040001;
inline constexpr uint32_t kAbortUnsupported = 0x06010000;
inline constexpr uint32_t kAbortReadOnly = 0x06010002;
inline constexpr uint32_t kAbortWriteOnly = 0x06010001;
inline constexpr uint32_t kAbortNoObject = 0x06020000;
inline constexpr uint32_t kAbortNotMappable = 0x06040041;
inline constexpr uint32_t kAbortLengthMismatch = 0x06070010;
inline constexpr uint32_t kAbortNoSubindex = 0x06090011;
inline constexpr uint32_t kAbortValueRange = 0x06090030;
inline constexpr uint32_t kAbortGeneral = 0x08000000;
inline constexpr uint32_t kAbortDeviceState = 0x08000022;
const char* abort_name(uint32_t code);  // e.g. "object does not exist in the object dictionary"

// Client -> server (COB-ID 0x600 + node).
CanFrame initiate_download_expedited(uint8_t node, uint16_t index, uint8_t sub, uint32_t value, uint8_t size);
CanFrame initiate_download_segmented(uint8_t node, uint16_t index, uint8_t sub, uint32_t total_size);
CanFrame download_segment(uint8_t node, bool toggle, const uint8_t* data, uint8_t n, bool last);
CanFrame initiate_upload(uint8_t node, uint16_t index, uint8_t sub);
CanFrame upload_segment_request(uint8_t node, bool toggle);
// Either direction (COB-ID 0x600+node from a client, 0x580+node from a server).
CanFrame abort_frame(uint32_t cob_id, uint16_t index, uint8_t sub, uint32_t code);
inline uint32_t abort_code_of(const CanFrame& f) {
  return static_cast<uint32_t>(f.data[4] | (f.data[5] << 8) | (f.data[6] << 16)) |
         (static_cast<uint32_t>(f.data[7]) << 24);
}
// Server -> client (COB-ID 0x580 + node).
CanFrame download_response(uint8_t node, uint16_t index, uint8_t sub);
CanFrame download_segment_response(uint8_t node, bool toggle);
CanFrame upload_response_expedited(uint8_t node, uint16_t index, uint8_t sub, uint32_t value, uint8_t size);
CanFrame upload_response_segmented(uint8_t node, uint16_t index, uint8_t sub, uint32_t total_size);
CanFrame upload_segment(uint8_t node, bool toggle, const uint8_t* data, uint8_t n, bool last);
}  // namespace sdo

// Little-endian helpers.
inline void put_u16(uint8_t* p, uint16_t v) {
  p[0] = static_cast<uint8_t>(v);
  p[1] = static_cast<uint8_t>(v >> 8);
}
inline void put_u32(uint8_t* p, uint32_t v) {
  for (int i = 0; i < 4; ++i) p[i] = static_cast<uint8_t>(v >> (8 * i));
}
inline uint16_t get_u16(const uint8_t* p) { return static_cast<uint16_t>(p[0] | (p[1] << 8)); }
inline uint32_t get_u32(const uint8_t* p) {
  return static_cast<uint32_t>(p[0]) | (static_cast<uint32_t>(p[1]) << 8) | (static_cast<uint32_t>(p[2]) << 16) |
         (static_cast<uint32_t>(p[3]) << 24);
}

}  // namespace harvest::canopen
