// Incremental parser for the end-effector line protocol: any chunking of the
// byte stream in, complete valid frames out. Every way a line can be wrong
// is counted separately, and the parser resynchronises on the next '$'.
#pragma once

#include <cstddef>
#include <cstdint>
#include <functional>
#include <span>
#include <string>
#include <vector>

#include "endeffector/protocol.hpp"

namespace harvest::endeffector {

struct ParserCounters {
  int64_t frames = 0;           // valid frames delivered
  int64_t bad_checksum = 0;     // CRC mismatch
  int64_t truncated = 0;        // frame cut short: new '$' before '\n', no "*CRC" tail, or reset mid-frame
  int64_t garbage_bytes = 0;    // bytes outside any frame
  int64_t oversize = 0;         // line longer than kMaxLine, dropped
  int64_t unknown_version = 0;  // intact frame of another protocol version
  int64_t unknown_type = 0;     // intact frame with a type tag we do not know
  int64_t bad_fields = 0;       // intact frame whose fields do not parse or are out of range

  int64_t errors() const {
    return bad_checksum + truncated + oversize + unknown_version + unknown_type + bad_fields;
  }
};

class Parser {
 public:
  using Sink = std::function<void(const Frame&)>;

  // Feed any number of bytes; `sink` is called once per valid frame, in order.
  void feed(std::span<const uint8_t> bytes, const Sink& sink);
  // Convenience for tests and tools.
  std::vector<Frame> feed(std::string_view bytes);

  // The stream was interrupted (disconnect): a partial frame counts as truncated.
  void reset();

  const ParserCounters& counters() const { return counters_; }
  // Why the last rejected line was rejected, for logs.
  const std::string& last_error() const { return last_error_; }

 private:
  enum class State { kHunting, kInFrame, kDiscarding };
  void finish_line(const Sink& sink);
  void reject(int64_t& counter, std::string why);

  State state_ = State::kHunting;
  std::string line_;  // bytes after '$', without the '\n'
  ParserCounters counters_;
  std::string last_error_;
};

}  // namespace harvest::endeffector
