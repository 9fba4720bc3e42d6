#include "canopen/protocol.hpp"

#include <cstdio>
#include <cstring>

namespace harvest::canopen {
namespace {

CanFrame make(uint32_t id, uint8_t dlc) {
  CanFrame f;
  f.id = id;
  f.dlc = dlc;
  return f;
}

CanFrame sdo_frame(uint32_t id, uint8_t command, uint16_t index, uint8_t sub) {
  CanFrame f = make(id, 8);
  f.data[0] = command;
  put_u16(&f.data[1], index);
  f.data[3] = sub;
  return f;
}

CanFrame segment(uint32_t id, uint8_t specifier, bool toggle, const uint8_t* data, uint8_t n, bool last) {
  CanFrame f = make(id, 8);
  // byte 0: scs/ccs (3 bits) | toggle (bit 4) | n = unused bytes (bits 3..1) | c = last (bit 0)
  f.data[0] = static_cast<uint8_t>((specifier << 5) | (toggle ? 0x10 : 0) | ((7 - n) << 1) | (last ? 1 : 0));
  if (n > 0) std::memcpy(&f.data[1], data, n);  // an empty object's data() may be null (canopen_frames_fuzz, UBSan)
  return f;
}

}  // namespace

const char* to_string(NmtState s) {
  switch (s) {
    case NmtState::kBootUp:
      return "boot-up";
    case NmtState::kStopped:
      return "stopped";
    case NmtState::kOperational:
      return "operational";
    case NmtState::kPreOperational:
      return "pre-operational";
  }
  return "unknown";
}

CanFrame nmt_frame(NmtCommand command, uint8_t node) {
  CanFrame f = make(cob::kNmt, 2);
  f.data[0] = static_cast<uint8_t>(command);
  f.data[1] = node;
  return f;
}

CanFrame heartbeat_frame(uint8_t node, NmtState state) {
  CanFrame f = make(cob::kHeartbeat + node, 1);
  f.data[0] = static_cast<uint8_t>(state);
  return f;
}

std::optional<NmtState> decode_heartbeat(const CanFrame& frame) {
  if (function_of(frame.id) != cob::kHeartbeat || frame.dlc != 1 || frame.remote || frame.extended) return std::nullopt;
  const uint8_t s = frame.data[0] & 0x7F;
  if (s != 0x00 && s != 0x04 && s != 0x05 && s != 0x7F) return std::nullopt;
  return static_cast<NmtState>(s);
}

CanFrame sync_frame() { return make(cob::kSync, 0); }

CanFrame emcy_frame(uint8_t node, const Emcy& e) {
  CanFrame f = make(cob::kEmcy + node, 8);
  put_u16(&f.data[0], e.error_code);
  f.data[2] = e.error_register;
  std::memcpy(&f.data[3], e.vendor.data(), 5);
  return f;
}

std::optional<Emcy> decode_emcy(const CanFrame& frame) {
  if (function_of(frame.id) != cob::kEmcy || node_of(frame.id) == 0 || frame.dlc != 8) return std::nullopt;
  Emcy e;
  e.error_code = get_u16(&frame.data[0]);
  e.error_register = frame.data[2];
  std::memcpy(e.vendor.data(), &frame.data[3], 5);
  return e;
}

std::string describe_emcy(uint16_t code) {
  const char* what = "unknown error";
  switch (code >> 12) {
    case 0x0:
      what = code == 0 ? "error reset / no error" : "generic";
      break;
    case 0x1:
      what = "generic error";
      break;
    case 0x2:
      what = "current";
      break;
    case 0x3:
      what = "voltage";
      break;
    case 0x4:
      what = "temperature";
      break;
    case 0x5:
      what = "device hardware";
      break;
    case 0x6:
      what = "device software";
      break;
    case 0x7:
      what = "additional modules";
      break;
    case 0x8:
      what = code == 0x8130               ? "heartbeat error (the drive lost the master's heartbeat)"
             : code == 0x8250             ? "RPDO timeout (the drive's commands stopped coming)"
             : (code & 0xFF00) == 0x8100   ? "communication"
             : (code & 0xFF00) == 0x8600 ? "positioning controller (following error)"
                                         : "monitoring";
      break;
    case 0x9:
      what = "external error";
      break;
    case 0xF:
      what = "additional functions";
      break;
    default:
      break;
  }
  char buf[80];
  std::snprintf(buf, sizeof(buf), "0x%04X %s", code, what);
  return buf;
}

namespace sdo {

const char* abort_name(uint32_t code) {
  switch (code) {
    case 0x05030000:
      return "toggle bit not alternated";
    case 0x05040000:
      return "SDO protocol timed out";
    case 0x05040001:
      return "client/server command specifier not valid or unknown";
    case 0x05040005:
      return "out of memory";
    case 0x06010000:
      return "unsupported access to an object";
    case 0x06010001:
      return "attempt to read a write only object";
    case 0x06010002:
      return "attempt to write a read only object";
    case 0x06020000:
      return "object does not exist in the object dictionary";
    case 0x06040041:
      return "object cannot be mapped to the PDO";
    case 0x06040042:
      return "the number and length of the objects to be mapped would exceed PDO length";
    case 0x06040043:
      return "general parameter incompatibility";
    case 0x06060000:
      return "access failed due to a hardware error";
    case 0x06070010:
      return "data type does not match, length of service parameter does not match";
    case 0x06070012:
      return "data type does not match, length of service parameter too high";
    case 0x06070013:
      return "data type does not match, length of service parameter too low";
    case 0x06090011:
      return "sub-index does not exist";
    case 0x06090030:
      return "invalid value for parameter";
    case 0x06090031:
      return "value of parameter written too high";
    case 0x06090032:
      return "value of parameter written too low";
    case 0x08000000:
      return "general error";
    case 0x08000020:
      return "data cannot be transferred or stored to the application";
    case 0x08000021:
      return "data cannot be transferred because of local control";
    case 0x08000022:
      return "data cannot be transferred because of the present device state";
    default:
      return "unknown abort code";
  }
}

CanFrame initiate_download_expedited(uint8_t node, uint16_t index, uint8_t sub, uint32_t value, uint8_t size) {
  // ccs=1, n = 4 - size (bits 3..2), e = 1, s = 1
  CanFrame f = sdo_frame(cob::kSdoRx + node, static_cast<uint8_t>(0x23 | ((4 - size) << 2)), index, sub);
  put_u32(&f.data[4], value);
  for (int i = size; i < 4; ++i) f.data[4 + i] = 0;
  return f;
}
CanFrame initiate_download_segmented(uint8_t node, uint16_t index, uint8_t sub, uint32_t total_size) {
  CanFrame f = sdo_frame(cob::kSdoRx + node, 0x21, index, sub);  // ccs=1, e=0, s=1
  put_u32(&f.data[4], total_size);
  return f;
}
CanFrame download_segment(uint8_t node, bool toggle, const uint8_t* data, uint8_t n, bool last) {
  return segment(cob::kSdoRx + node, kClientDownloadSegment, toggle, data, n, last);
}
CanFrame initiate_upload(uint8_t node, uint16_t index, uint8_t sub) {
  return sdo_frame(cob::kSdoRx + node, 0x40, index, sub);
}
CanFrame upload_segment_request(uint8_t node, bool toggle) {
  CanFrame f = make(cob::kSdoRx + node, 8);
  f.data[0] = static_cast<uint8_t>(0x60 | (toggle ? 0x10 : 0));
  return f;
}
CanFrame abort_frame(uint32_t cob_id, uint16_t index, uint8_t sub, uint32_t code) {
  CanFrame f = sdo_frame(cob_id, 0x80, index, sub);
  put_u32(&f.data[4], code);
  return f;
}
CanFrame download_response(uint8_t node, uint16_t index, uint8_t sub) {
  return sdo_frame(cob::kSdoTx + node, 0x60, index, sub);
}
CanFrame download_segment_response(uint8_t node, bool toggle) {
  CanFrame f = make(cob::kSdoTx + node, 8);
  f.data[0] = static_cast<uint8_t>(0x20 | (toggle ? 0x10 : 0));
  return f;
}
CanFrame upload_response_expedited(uint8_t node, uint16_t index, uint8_t sub, uint32_t value, uint8_t size) {
  CanFrame f = sdo_frame(cob::kSdoTx + node, static_cast<uint8_t>(0x43 | ((4 - size) << 2)), index, sub);
  put_u32(&f.data[4], value);
  for (int i = size; i < 4; ++i) f.data[4 + i] = 0;
  return f;
}
CanFrame upload_response_segmented(uint8_t node, uint16_t index, uint8_t sub, uint32_t total_size) {
  CanFrame f = sdo_frame(cob::kSdoTx + node, 0x41, index, sub);
  put_u32(&f.data[4], total_size);
  return f;
}
CanFrame upload_segment(uint8_t node, bool toggle, const uint8_t* data, uint8_t n, bool last) {
  return segment(cob::kSdoTx + node, kServerUploadSegment, toggle, data, n, last);
}

}  // namespace sdo
}  // namespace harvest::canopen
