// Replays one node exactly as it ran live, from its process's journal
// (runtime/journal.hpp): each message its live twin handled is found in the
// recording (by channel and journal_key) and delivered at the time the live
// handler saw, and each timer fires when the live one ran, by label, never
// by its due time. What the node publishes goes to the output log stamped
// with that time. Same log, journal and code: the recorded outputs again;
// changed code: the new outputs for exactly the live inputs and moments.
#pragma once

#include <deque>
#include <lcm/lcm-cpp.hpp>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "runtime/journal.hpp"
#include "runtime/logical_time_runner.hpp"

namespace harvest::rt {

struct JournalReplayResult {
  int64_t messages = 0;        // inputs delivered
  int64_t timers = 0;          // timer firings
  int64_t missing_inputs = 0;  // handled live but not in the recording (the logger lost it)
  int64_t other_timers = 0;    // firings of timers this node does not have (the process's heartbeat)
  int64_t published = 0;
  std::vector<std::string> missing;  // the first few missing inputs, described
};

class JournalRunner final : public LogicalTimeRunner {
 public:
  // `start`: the node attaches then (its process's CONFIG snapshot time).
  JournalRunner(std::string input_log, std::string output_log, std::string prefix, Micros start);
  ~JournalRunner() override;

  // The nodes of one process (those replayed), driven by that process's journal.
  JournalReplayResult run(const std::vector<Node*>& nodes, const Journal& journal);

  void publish_bytes(const std::string& channel, const void* data, std::size_t size) override;
  void watch_fd(int, std::function<void()>) override;
  void unwatch_fd(int) override {}
  void request_stop(int) override { stop_ = true; }

 private:
  struct Held {
    Micros timestamp;
    int64_t key;
    std::vector<uint8_t> data;
  };
  // The recorded message on `channel` with `key`, read ahead in the log as far as `t` + 5 s.
  std::optional<std::vector<uint8_t>> find(const std::string& channel, int64_t key, Micros t);

  std::string input_log_, output_log_;
  Micros start_;
  std::unique_ptr<lcm::LogFile> in_, out_;
  bool in_done_ = false;
  Micros read_to_ = 0;
  std::map<std::string, std::deque<Held>> held_;
  JournalReplayResult result_;
  bool stop_ = false;
};

}  // namespace harvest::rt
