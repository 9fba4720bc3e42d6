// harvest-log latency: how old each message is when it is published and
// when it is received, and how long each hop of the graph takes, read from
// the headers of any recording (docs/log-tools.md).
//
// Every header carries utime (when the data was sensed, copied down the
// chain), seq, source_seq (the seq of the input that caused it) and
// publish_utime. A hop A -> B is a message on B whose utime and source_seq
// equal the utime and seq of a message on A: the time from A's publication
// to B's is the hop, the time from B's publication to the logger's receipt
// (the log's event time) is B's transport share.
#pragma once

#include <cstdint>
#include <map>
#include <string>
#include <vector>

#include "runtime/log_io.hpp"

namespace harvest::logtools {

struct Distribution {
  int64_t count = 0;
  double p50_ms = 0, p99_ms = 0, max_ms = 0;
};
// Nearest-rank percentiles of values in microseconds.
Distribution distribution(std::vector<int64_t> values_us);

struct ChannelLatency {
  Distribution age;        // publish_utime - utime: sensing to this publication
  Distribution transport;  // log time - publish_utime: publication to the logger's receipt
};

struct LatencyReport {
  std::map<std::string, ChannelLatency> channels;  // channels whose messages carry a header
  std::map<std::string, Distribution> hops;        // "CAMERA_HAND -> FRUIT_HAND": publication to publication
  int64_t untraced = 0;                            // derived messages whose input is not in the log
  std::map<std::string, int64_t> untraced_by_channel;
  int64_t unstamped = 0;  // publish_utime 0: not stamped by its publisher
  int64_t malformed = 0;  // events that do not decode
};

LatencyReport latency(const std::vector<rt::LogRecord>& log);
std::string format_latency(const std::string& path, const LatencyReport& report);

}  // namespace harvest::logtools
