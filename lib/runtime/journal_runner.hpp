// Replays one node exactly as it ran live, from its process's journal
// (runtime/journal.hpp): each message its live twin handled is found in the
// recording (by channel and journal_key) and delivered at the time the live
// handler saw, and each timer fires when the live one ran, by label, never
// by its due time. What the node publishes is kept, stamped with that time.
// Same log, journal and code: the recorded outputs again; changed code: the
// new outputs for exactly the live inputs and moments.
//
// Every journalled process of a recording is replayed in one pass over the
// log (replay_journals): each event is read once, its key computed once, and
// the processes that subscribe to its channel hold a view of it (no copy)
// until their journal reaches it.
#pragma once

#include <deque>
#include <string>
#include <string_view>
#include <vector>

#include "runtime/journal.hpp"
#include "runtime/log_io.hpp"
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

// The replayed nodes of one process, driven by that process's journal.
class JournalRunner final : public LogicalTimeRunner {
 public:
  // `start`: the nodes attach then (their process's CONFIG snapshot time).
  // The journal must outlive the runner.
  JournalRunner(std::string prefix, Micros start, const Journal& journal);
  ~JournalRunner() override;

  const JournalReplayResult& result() const { return result_; }
  // What the nodes published, in order, stamped with the replay clock (full channel names).
  const std::vector<LogRecord>& published() const { return published_; }

  void publish_bytes(const std::string& channel, const void* data, std::size_t size) override;
  void watch_fd(int, std::function<void()>) override;
  void unwatch_fd(int) override {}
  void request_stop(int) override { stop_ = true; }

 private:
  friend void replay_journals(const std::string& input_log, const std::vector<JournalRunner*>& runners);
  struct Held {  // a recorded message, in the mapped log
    Micros timestamp;
    int64_t key;
    const uint8_t* data;
    std::size_t size;
  };
  struct Inputs {         // the recorded messages on one channel this process subscribes to, not yet handled
    std::string channel;  // logical
    std::deque<Held> held;
  };
  void on_first_subscription(const std::string&) override { subscriptions_changed_ = true; }
  // The journal's next entry to replay, or nullptr when it is done.
  const JournalEntry* next_entry();
  Inputs& inputs_of(const std::string& channel);

  Micros start_;
  const Journal& journal_;
  std::size_t next_ = 0;
  std::deque<Inputs> inputs_;  // a deque: replay_journals keeps pointers to them
  bool subscriptions_changed_ = false;
  std::vector<LogRecord> published_;
  JournalReplayResult result_;
  bool stop_ = false;
};

// Replays every runner's nodes from its journal in one pass over `input_log`.
// The runners have their nodes added (Dispatcher::add) and attach here.
void replay_journals(const std::string& input_log, const std::vector<JournalRunner*>& runners);

}  // namespace harvest::rt
