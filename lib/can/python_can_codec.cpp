#include "can/python_can_codec.hpp"

#include <msgpack.h>

#include <cstring>
#include <string>
#include <string_view>

namespace harvest::can {
namespace {

void pack_key(msgpack_packer& pk, std::string_view key) {
  msgpack_pack_str(&pk, key.size());
  msgpack_pack_str_body(&pk, key.data(), key.size());
}
void pack_bool(msgpack_packer& pk, bool v) { v ? msgpack_pack_true(&pk) : msgpack_pack_false(&pk); }

struct Fields {
  std::optional<uint64_t> id;
  bool extended = false, remote = false, error = false, fd = false;
  std::optional<uint64_t> dlc;
  const char* data = nullptr;
  uint32_t data_size = 0;
  bool has_data = false;
};

bool as_bool(const msgpack_object& o, std::string_view key) {
  if (o.type == MSGPACK_OBJECT_BOOLEAN) return o.via.boolean;
  if (o.type == MSGPACK_OBJECT_NIL) return false;
  throw CanError("python-can frame: '" + std::string(key) + "' is not a boolean");
}
uint64_t as_uint(const msgpack_object& o, std::string_view key) {
  if (o.type == MSGPACK_OBJECT_POSITIVE_INTEGER) return o.via.u64;
  throw CanError("python-can frame: '" + std::string(key) + "' is not a non-negative integer");
}

// msgpack-c allocates every array and map at its declared size before it
// reads the elements (python_can_codec_fuzz: a datagram declaring 2^32
// elements asked for 128 GB). Walks the encoded object first and refuses
// any length or element count the bytes left cannot hold (every element
// takes at least one byte). Empty when it fits.
std::string msgpack_too_large(const uint8_t* d, std::size_t size) {
  std::size_t pos = 0;
  uint64_t pending = 1;  // objects still to read
  auto be = [&](std::size_t at, int n) {
    uint64_t v = 0;
    for (int i = 0; i < n; ++i) v = (v << 8) | d[at + static_cast<std::size_t>(i)];
    return v;
  };
  while (pending > 0) {
    if (pending > size - pos) return "declares more objects than the datagram has bytes";
    --pending;
    const uint8_t t = d[pos++];
    uint64_t skip = 0, items = 0;
    int len_bytes = 0;  // a length field of this many bytes follows
    bool ext = false;   // ext types carry a type byte after the length
    if (t <= 0x7f || t >= 0xe0 || t == 0xc0 || t == 0xc2 || t == 0xc3) {
      // fixint, nil, bool: the type byte is all
    } else if (t <= 0x8f) {
      items = 2u * (t & 0x0fu);
    } else if (t <= 0x9f) {
      items = t & 0x0fu;
    } else if (t <= 0xbf) {
      skip = t & 0x1fu;
    } else if (t >= 0xc4 && t <= 0xc6) {
      len_bytes = 1 << (t - 0xc4);
    } else if (t >= 0xc7 && t <= 0xc9) {
      len_bytes = 1 << (t - 0xc7);
      ext = true;
    } else if (t == 0xca || t == 0xcb) {
      skip = t == 0xca ? 4 : 8;
    } else if (t >= 0xcc && t <= 0xd3) {
      skip = 1u << ((t - 0xcc) % 4);
    } else if (t >= 0xd4 && t <= 0xd8) {
      skip = 1 + (1u << (t - 0xd4));
    } else if (t >= 0xd9 && t <= 0xdb) {
      len_bytes = 1 << (t - 0xd9);
    } else if (t >= 0xdc) {  // array16/32, map16/32
      const int n = (t == 0xdc || t == 0xde) ? 2 : 4;
      if (static_cast<std::size_t>(n) > size - pos) return "cut short";
      items = be(pos, n) * (t >= 0xde ? 2u : 1u);
      pos += static_cast<std::size_t>(n);
    } else {
      return "invalid type byte";  // 0xc1, never used
    }
    if (len_bytes > 0) {
      if (static_cast<std::size_t>(len_bytes) > size - pos) return "cut short";
      skip = be(pos, len_bytes) + (ext ? 1 : 0);
      pos += static_cast<std::size_t>(len_bytes);
    }
    if (skip > size - pos) return "declares a length past the end of the datagram";
    pos += static_cast<std::size_t>(skip);
    pending += items;
  }
  return {};
}

}  // namespace

std::vector<uint8_t> encode_python_can(const CanFrame& frame, double timestamp_s) {
  msgpack_sbuffer buf;
  msgpack_sbuffer_init(&buf);
  msgpack_packer pk;
  msgpack_packer_init(&pk, &buf, msgpack_sbuffer_write);
  msgpack_pack_map(&pk, 11);
  pack_key(pk, "timestamp");
  msgpack_pack_double(&pk, timestamp_s);
  pack_key(pk, "arbitration_id");
  msgpack_pack_uint32(&pk, frame.id);
  pack_key(pk, "is_extended_id");
  pack_bool(pk, frame.extended);
  pack_key(pk, "is_remote_frame");
  pack_bool(pk, frame.remote);
  pack_key(pk, "is_error_frame");
  pack_bool(pk, frame.error);
  pack_key(pk, "channel");
  msgpack_pack_nil(&pk);
  pack_key(pk, "dlc");
  msgpack_pack_uint8(&pk, frame.dlc);
  pack_key(pk, "data");
  const std::size_t n = frame.remote ? 0 : frame.dlc;  // python-can sends no data for remote frames
  msgpack_pack_bin(&pk, n);
  msgpack_pack_bin_body(&pk, frame.data.data(), n);
  pack_key(pk, "is_fd");
  msgpack_pack_false(&pk);
  pack_key(pk, "bitrate_switch");
  msgpack_pack_false(&pk);
  pack_key(pk, "error_state_indicator");
  msgpack_pack_false(&pk);
  std::vector<uint8_t> out(reinterpret_cast<uint8_t*>(buf.data), reinterpret_cast<uint8_t*>(buf.data) + buf.size);
  msgpack_sbuffer_destroy(&buf);
  return out;
}

CanFrame decode_python_can(const uint8_t* data, std::size_t size) {
  if (const std::string why = msgpack_too_large(data, size); !why.empty())
    throw CanError("python-can frame: not a complete msgpack object (" + why + ")");
  msgpack_unpacked msg;
  msgpack_unpacked_init(&msg);
  std::size_t offset = 0;
  const auto rc = msgpack_unpack_next(&msg, reinterpret_cast<const char*>(data), size, &offset);
  // The unpacked object lives in msg's zone: copy what we need, then free.
  struct Guard {
    msgpack_unpacked* m;
    ~Guard() { msgpack_unpacked_destroy(m); }
  } guard{&msg};
  if (rc != MSGPACK_UNPACK_SUCCESS) throw CanError("python-can frame: not a complete msgpack object");
  if (offset != size) throw CanError("python-can frame: trailing bytes after the msgpack object");
  const msgpack_object& root = msg.data;
  if (root.type != MSGPACK_OBJECT_MAP) throw CanError("python-can frame: not a msgpack map");

  Fields f;
  for (uint32_t i = 0; i < root.via.map.size; ++i) {
    const msgpack_object& k = root.via.map.ptr[i].key;
    const msgpack_object& v = root.via.map.ptr[i].val;
    if (k.type != MSGPACK_OBJECT_STR) throw CanError("python-can frame: non-string key");
    const std::string_view key(k.via.str.ptr, k.via.str.size);
    if (key == "arbitration_id")
      f.id = as_uint(v, key);
    else if (key == "is_extended_id")
      f.extended = as_bool(v, key);
    else if (key == "is_remote_frame")
      f.remote = as_bool(v, key);
    else if (key == "is_error_frame")
      f.error = as_bool(v, key);
    else if (key == "is_fd")
      f.fd = as_bool(v, key);
    else if (key == "dlc")
      f.dlc = as_uint(v, key);
    else if (key == "data") {
      if (v.type == MSGPACK_OBJECT_BIN) {
        f.data = v.via.bin.ptr;
        f.data_size = v.via.bin.size;
      } else if (v.type == MSGPACK_OBJECT_STR) {  // older senders without use_bin_type
        f.data = v.via.str.ptr;
        f.data_size = v.via.str.size;
      } else if (v.type != MSGPACK_OBJECT_NIL) {
        throw CanError("python-can frame: 'data' is not bytes");
      }
      f.has_data = true;
    }
    // timestamp, channel, bitrate_switch, error_state_indicator: not needed.
  }
  if (!f.id) throw CanError("python-can frame: missing arbitration_id");
  if (f.fd) throw CanError("python-can frame: CAN FD frames are not supported");
  const uint32_t id_limit = f.extended ? 0x1FFFFFFFu : 0x7FFu;
  if (*f.id > id_limit) throw CanError("python-can frame: arbitration_id out of range");
  if (f.data_size > 8) throw CanError("python-can frame: more than 8 data bytes");
  const uint64_t dlc = f.dlc.value_or(f.data_size);
  if (dlc > 8) throw CanError("python-can frame: dlc > 8");
  if (!f.remote && f.data_size != dlc) throw CanError("python-can frame: dlc does not match the data length");

  CanFrame frame;
  frame.id = static_cast<uint32_t>(*f.id);
  frame.extended = f.extended;
  frame.remote = f.remote;
  frame.error = f.error;
  frame.dlc = static_cast<uint8_t>(dlc);
  // A remote frame carries no data on the bus (the encoder sends none): any
  // bytes in the datagram are not the frame's (python_can_codec_fuzz).
  if (!f.remote && f.data_size > 0) std::memcpy(frame.data.data(), f.data, f.data_size);
  return frame;
}

}  // namespace harvest::can
