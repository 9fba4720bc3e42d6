// Small helpers over lcm::LogFile for tools and tests: read a whole log,
// write one, compare two byte for byte.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "runtime/clock.hpp"
#include "runtime/wire_check.hpp"

namespace harvest::rt {

struct LogRecord {
  Micros timestamp = 0;
  std::string channel;
  std::vector<uint8_t> data;
  bool operator==(const LogRecord&) const = default;
};

// Throws std::runtime_error naming the file if it cannot be read.
std::vector<LogRecord> read_log(const std::string& path);
void write_log(const std::string& path, const std::vector<LogRecord>& records);

// Describes the first difference between two logs, or nullopt if identical.
std::optional<std::string> first_difference(const std::vector<LogRecord>& a, const std::vector<LogRecord>& b);

// Encode/decode an LCM message to and from bytes.
template <class Msg>
std::vector<uint8_t> encode(const Msg& m) {
  std::vector<uint8_t> out(static_cast<std::size_t>(m.getEncodedSize()));
  m.encode(out.data(), 0, static_cast<int>(out.size()));
  return out;
}
// Decoding goes through decode_checked: a malformed message is nullopt.
template <class Msg>
std::optional<Msg> decode(const std::vector<uint8_t>& bytes) {
  Msg m;
  if (!decode_checked(bytes.data(), bytes.size(), m).empty()) return std::nullopt;
  return m;
}

}  // namespace harvest::rt
