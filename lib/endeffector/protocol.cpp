#include "endeffector/protocol.hpp"

#include <cstdio>
#include <type_traits>

namespace harvest::endeffector {

uint16_t crc16(std::string_view data) {
  uint16_t crc = 0xFFFF;
  for (const char ch : data) {
    crc ^= static_cast<uint16_t>(static_cast<uint8_t>(ch) << 8);
    for (int bit = 0; bit < 8; ++bit) {
      crc = (crc & 0x8000) ? static_cast<uint16_t>((crc << 1) ^ 0x1021) : static_cast<uint16_t>(crc << 1);
    }
  }
  return crc;
}

std::string sanitize_text(std::string_view text) {
  std::string out;
  for (const char ch : text) {
    if (out.size() >= kMaxFaultText) break;
    const bool ok = (ch >= 'a' && ch <= 'z') || (ch >= 'A' && ch <= 'Z') || (ch >= '0' && ch <= '9') || ch == ' ' ||
                    ch == '_' || ch == '.' || ch == ':' || ch == '-' || ch == '/';
    out.push_back(ok ? ch : '_');
  }
  return out;
}

std::string_view type_tag(const Message& m) {
  return std::visit(
      [](const auto& v) -> std::string_view {
        using T = std::decay_t<decltype(v)>;
        if constexpr (std::is_same_v<T, Ping>) return "PING";
        else if constexpr (std::is_same_v<T, Open>) return "OPEN";
        else if constexpr (std::is_same_v<T, Close>) return "CLOSE";
        else if constexpr (std::is_same_v<T, Move>) return "MOVE";
        else if constexpr (std::is_same_v<T, Stop>) return "STOP";
        else if constexpr (std::is_same_v<T, IrSample>) return "IR";
        else if constexpr (std::is_same_v<T, Grip>) return "GRIP";
        else if constexpr (std::is_same_v<T, Fault>) return "FAULT";
        else if constexpr (std::is_same_v<T, Pong>) return "PONG";
        else return "ACK";
      },
      m);
}

namespace {
std::string fields_of(const Message& m) {
  return std::visit(
      [](const auto& v) -> std::string {
        using T = std::decay_t<decltype(v)>;
        auto num = [](auto x) {
          std::string s(1, ',');  // appended, not operator+: GCC 12 warns falsely (-Wrestrict) on "," + string
          s += std::to_string(x);
          return s;
        };
        if constexpr (std::is_same_v<T, Ping>) return num(v.token);
        else if constexpr (std::is_same_v<T, Close>) return num(v.force_mn);
        else if constexpr (std::is_same_v<T, Move>) return num(v.position_permille) + num(v.force_mn);
        else if constexpr (std::is_same_v<T, IrSample>) return num(v.raw);
        else if constexpr (std::is_same_v<T, Grip>)
          return num(static_cast<int>(v.state)) + num(v.position_permille) + num(v.force_mn);
        else if constexpr (std::is_same_v<T, Fault>) return num(v.code) + "," + sanitize_text(v.text);
        else if constexpr (std::is_same_v<T, Pong>) return num(v.token) + num(v.version) + "," + sanitize_text(v.firmware);
        else if constexpr (std::is_same_v<T, Ack>) return num(v.command_seq) + num(v.status);
        else return "";  // Open, Stop: no fields
      },
      m);
}
}  // namespace

std::string encode_raw(int version, std::string_view payload_after_version) {
  std::string body = std::to_string(version) + ",";
  body.append(payload_after_version);
  char tail[8];
  std::snprintf(tail, sizeof tail, "*%04X\n", crc16(body));
  return "$" + body + tail;
}

std::string encode(const Frame& frame) {
  return encode_raw(kProtocolVersion,
                    std::to_string(frame.seq) + "," + std::string(type_tag(frame.message)) + fields_of(frame.message));
}

}  // namespace harvest::endeffector
