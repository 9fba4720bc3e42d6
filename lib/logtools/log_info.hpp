// harvest-log info: what is in a log (channels, types by fingerprint,
// counts, rates, time span, gaps).
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "runtime/log_io.hpp"

namespace harvest::logtools {

struct Gap {
  int64_t start = 0;   // log time of the message before the gap [us]
  int64_t length = 0;  // [us]
};

struct ChannelInfo {
  std::string channel;
  std::string type;  // "harvest.image_t", "unknown 0x...", or several joined by '|'
  int64_t count = 0;
  int64_t bytes = 0;
  int64_t first = 0, last = 0;  // log times [us]
  double rate_hz = 0;           // (count-1)/(last-first), 0 with fewer than 2
  int64_t median_interval = 0;  // [us]
  int64_t max_interval = 0;     // [us]
  std::vector<Gap> gaps;        // intervals > gap_factor x median and > min_gap
  int64_t decode_errors = 0;    // known fingerprint but malformed
};

struct LogInfo {
  int64_t events = 0;
  int64_t bytes = 0;
  int64_t first = 0, last = 0;
  int64_t non_monotonic = 0;          // events whose time is before the previous one
  std::vector<ChannelInfo> channels;  // sorted by name
};

struct InfoOptions {
  double gap_factor = 5;         // a gap is longer than this many median intervals
  int64_t min_gap_us = 200'000;  // ... and longer than this
};

LogInfo log_info(const std::vector<rt::LogRecord>& log, const InfoOptions& options = {});
std::string format_info(const std::string& path, const LogInfo& info, std::size_t max_gaps = 5);

// "2026-12-01 05:09:13.123456 UTC"
std::string utc_text(int64_t utime);

}  // namespace harvest::logtools
