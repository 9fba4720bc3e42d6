// Field-by-field comparison of the messages a replay regenerated with the
// ones recorded in the input log (harvest-replay --compare).
//
// Per channel, recorded and replayed messages are paired by header.utime
// (the sensing time a derived message copies from its input; several with
// the same utime pair in order), or by position for types without a header.
// Each pair is decoded with the generated C++ types and compared field by
// field; header.publish_utime is always ignored.
//
// Tolerances are absolute and keyed "CHANNEL.path" with array indices
// written "[]" ("TARGETS.targets[].depth_m"); "*" matches any channel and a
// key also covers everything below it ("TARGETS.targets[]"). Without one:
// integers, booleans, strings and bytes must be equal; float fields may differ
// by 1e-6 and double fields by 1e-9, relative to max(1, |value|).
#pragma once

#include <cstddef>
#include <cstdint>
#include <limits>
#include <map>
#include <string>
#include <vector>

#include "runtime/log_io.hpp"

namespace harvest::logtools {

struct CompareOptions {
  std::map<std::string, double> tolerances;  // key -> abs tolerance; infinity = ignore
  double float_relative = 1e-6;
  double double_relative = 1e-9;
  bool allow_unmatched = false;  // messages on one side only are listed but do not fail
  std::size_t max_messages_per_channel = 10;
  std::size_t max_fields_per_message = 8;

  // "CHANNEL.field=abs" (or "CHANNEL.field" with `ignore`); throws std::invalid_argument.
  void add_tolerance(const std::string& spec);
  void add_ignore(const std::string& key);
  // The tolerance for one field, or nullopt for the default.
  const double* tolerance_for(const std::string& channel, const std::string& path) const;
};

struct FieldDiff {
  std::string path;
  std::string recorded, replayed;  // value texts; "(absent)" if missing
  double delta = std::numeric_limits<double>::quiet_NaN();
  double tolerance = 0;
};

struct MessageDiff {
  std::size_t recorded_index = 0, replayed_index = 0;  // within the channel, 0-based
  int64_t utime = 0;
  std::vector<FieldDiff> fields;  // the first max_fields_per_message
  std::size_t num_fields = 0;     // differing fields in total
};

struct ChannelReport {
  std::string channel;
  std::string type;
  std::size_t recorded = 0, replayed = 0, matched = 0, identical = 0, differing = 0;
  std::vector<std::size_t> only_recorded, only_replayed;  // channel indices
  std::vector<int64_t> only_recorded_utime, only_replayed_utime;
  std::vector<int64_t> only_recorded_time, only_replayed_time;  // their log times
  int64_t first_recorded_time = 0, last_recorded_time = 0;      // of the recorded messages (0: none)
  // Why each unmatched message has no partner (explain_unmatched), "" where
  // nothing in the logs tells; parallel to only_recorded / only_replayed.
  std::vector<std::string> only_recorded_why, only_replayed_why;
  std::vector<MessageDiff> diffs;   // the first max_messages_per_channel
  std::vector<std::string> errors;  // undecodable messages
  bool ok(const CompareOptions& o) const;
  // No differing pair, and every unmatched message explained.
  bool explained() const;
};

struct CompareReport {
  std::vector<ChannelReport> channels;
  bool ok = true;
  bool explained = false;  // not ok, but every difference explained (explain_unmatched)
};

// Compares, for each channel in `channels`, the recorded messages with the
// replayed ones.
CompareReport compare_logs(const std::vector<rt::LogRecord>& recorded, const std::vector<rt::LogRecord>& replayed,
                           const std::vector<std::string>& channels, const CompareOptions& options);

// The readable per-channel diff harvest-replay prints.
std::string format_report(const CompareReport& report, const CompareOptions& options);

}  // namespace harvest::logtools
