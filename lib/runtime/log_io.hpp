// Small helpers over LCM logs for tools and tests: read one event by event
// without copying (LogReader), read a whole log, write one, compare two byte
// for byte.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "runtime/clock.hpp"
#include "runtime/wire_check.hpp"

namespace lcm {
class LogFile;
}

namespace harvest::rt {

struct LogRecord {
  Micros timestamp = 0;
  std::string channel;
  std::vector<uint8_t> data;
  bool operator==(const LogRecord&) const = default;
};

// One event of a LogReader: channel and payload point into the mapped file
// and stay valid as long as the reader.
struct LogView {
  Micros timestamp = 0;
  std::string_view channel;
  const uint8_t* data = nullptr;
  std::size_t size = 0;
};

// Reads a log (stock lcm-logger format) event by event from the file mapped
// into memory: nothing is allocated or copied per event. lcm::LogFile
// allocates and zeroes a buffer for each event and seeks back 4 bytes after
// it (a system call and a refilled stdio buffer per event): on a 40 MB
// recording of 20,000 events a pass took 50 ms. Like lcm's reader it skips
// to the next sync word when an event does not start with one, and ends at a
// truncated last event.
class LogReader {
 public:
  // Throws std::runtime_error naming the file if it cannot be opened.
  explicit LogReader(const std::string& path);
  ~LogReader();
  LogReader(const LogReader&) = delete;
  LogReader& operator=(const LogReader&) = delete;
  // The next event, or nullptr at the end.
  const LogView* next();

 private:
  const uint8_t* base_ = nullptr;
  std::size_t size_ = 0, pos_ = 0;
  LogView view_;
};

// Appends one event (the writer numbers it); false if it could not be written.
bool write_event(lcm::LogFile& f, Micros timestamp, const std::string& channel, const void* data, std::size_t size);

// Throws std::runtime_error naming the file if it cannot be read.
std::vector<LogRecord> read_log(const std::string& path);
void write_log(const std::string& path, const std::vector<LogRecord>& records);
// Copies the events at or after `from` of one log to another, event by
// event (nothing held in memory); returns how many were earlier, left out.
std::size_t copy_log_from(const std::string& in, const std::string& out, Micros from);

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
