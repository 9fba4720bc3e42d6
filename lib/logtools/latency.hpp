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
  double min_ms = 0, p50_ms = 0, p99_ms = 0, max_ms = 0;
};
// Nearest-rank percentiles of values in microseconds.
Distribution distribution(std::vector<int64_t> values_us);

struct ChannelLatency {
  Distribution age;        // publish_utime - utime: sensing to this publication
  Distribution transport;  // log time - publish_utime: publication to the logger's receipt
};

// Frames of one camera (a root channel: raw data, source_seq -1) followed to
// the first command that used each. A command names the newest input it was
// computed with (the servo controller: the newest TARGETS), and a node handles
// its inputs in order, so the first command that used a frame is the first
// published with its named input's seq at or above that of the frame's own
// (the frame's TARGETS). Every frame's time to it splits into stages that add
// up exactly: the root's publication after sensing, then per hop the input's
// transport (the logger's receipt stands for the subscriber's) and the next
// node's processing (its publication minus that receipt).
struct ChainLatency {
  std::string path;                     // "CAMERA_HAND > FRUIT_HAND > TARGETS > ROBOT_COMMAND"
  int64_t frames = 0;                   // frames sensed from the one the first command names to the last one used
  int64_t commanded = 0;                // ... of them used by a command
  std::map<std::string, int64_t> lost;  // the others by where their trace ends: "no FRUIT_HAND", "no TARGETS"
  Distribution end_to_end;              // command publication - frame utime
  Distribution processing;  // the processing stages' sum (the command's node including any wait for its timer)
  Distribution upstream;    // ... without the command's node: sensing to the named input's publication
  // With the command node's timer period known: the processing without the wait for the timer (up to the
  // command's input, then the tick's own work from when it was due).
  Distribution own;
  Distribution transport;                                    // the transport stages' sum
  std::vector<std::pair<std::string, Distribution>> stages;  // in chain order
  Distribution command_transport;  // the command's own publication to the logger's receipt (not in end_to_end)
};

struct LatencyReport {
  std::map<std::string, ChannelLatency> channels;  // channels whose messages carry a header
  std::map<std::string, Distribution> hops;        // "CAMERA_HAND -> FRUIT_HAND": publication to publication
  // The same hops from the logger's receipt of the input (for the subscriber's) to the output's publication: the
  // output's node at work, without LCM's share.
  std::map<std::string, Distribution> hop_processing;
  int64_t untraced = 0;  // derived messages whose input is not in the log
  std::map<std::string, int64_t> untraced_by_channel;
  int64_t unstamped = 0;                       // publish_utime 0: not stamped by its publisher
  int64_t malformed = 0;                       // events that do not decode
  std::string command_channel;                 // the channel chains end on
  std::map<std::string, ChainLatency> chains;  // by root channel; empty if no command traces to a frame
  Distribution command_tick;                   // traced commands' publication after their tick was due
};

struct LatencyOptions {
  std::string command_channel = "ROBOT_COMMAND";
  // The command node's timer period (the servo controller's tick_period_s), 0 if unknown. Its timer fires at
  // t0 + k * period exactly, so the commands' phase splits its stage into the wait for the tick and the tick's
  // own work (an estimate: see timer_phase in latency.cpp).
  int64_t command_period_us = 0;
};

LatencyReport latency(const std::vector<rt::LogRecord>& log, const LatencyOptions& options = {});
std::string format_latency(const std::string& path, const LatencyReport& report);
// The report as JSON (milliseconds, three decimals), for benchmarks that keep their figures.
std::string latency_json(const std::string& path, const LatencyReport& report);

}  // namespace harvest::logtools
