// harvest-log export: one channel of a log as CSV or JSON lines, one row per
// message, one column per field path ("header.utime", "fruits[0].u_px"),
// after `log_utime` (the log's timestamp, microseconds).
#pragma once

#include <cstdint>
#include <iosfwd>
#include <string>
#include <vector>

#include "runtime/log_io.hpp"

namespace harvest::logtools {

enum class ExportFormat { kCsv, kJsonl };

struct ExportOptions {
  ExportFormat format = ExportFormat::kCsv;
  // Keep only fields whose path, with indices written "[]", equals or starts
  // with one of these ("header.utime", "fruits[]"); empty keeps all.
  std::vector<std::string> fields;
  // Where to say which events could not be decoded (corrupt or unknown); a
  // CSV row for one has only its log_utime, a JSON line an "error".
  std::ostream* problems = nullptr;
};

// Returns the number of messages written. Throws std::runtime_error if the
// channel is not in the log.
int64_t export_channel(const std::vector<rt::LogRecord>& log, const std::string& channel, const ExportOptions& options,
                       std::ostream& out);

}  // namespace harvest::logtools
