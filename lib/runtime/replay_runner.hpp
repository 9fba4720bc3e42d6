// Replays an LCM log through nodes in process, as fast as the CPU allows.
//
// Events are read from the log file itself (never lcm-logplayer, which paces
// by the wall clock and re-sends over UDP, losing messages). The clock is the
// log's: before each event, every timer due at or before it fires at its own
// due time; then the event is delivered. Messages the nodes publish go to the
// output log stamped with the replay clock and are delivered to the other
// nodes at once, so nodes can be chained in one run. Recorded events on
// channels that a node advertises are not fed in: they are regenerated.
// The same log and configuration give a byte-identical output log.
#pragma once

#include <deque>
#include <lcm/lcm-cpp.hpp>
#include <memory>
#include <optional>
#include <set>
#include <string>
#include <utility>
#include <vector>

#include "runtime/logical_time_runner.hpp"

namespace harvest::rt {

struct ReplayOptions {
  std::string input_log;
  std::string output_log;          // empty: do not write one
  std::string prefix;              // channel prefix of the recorded graph
  bool copy_inputs = false;        // also copy the input events to the output log
  std::optional<Micros> end_time;  // stop after this log time (default: last event)
  Micros tail = 0;                 // keep firing timers this long after the last event
  // Every node against the recording: recorded events on the channels the
  // nodes regenerate are fed in too, and what the nodes publish goes to the
  // output log only, not to the other nodes. Each node then sees exactly what
  // its live twin saw (a detection when the live detector published it, not
  // at its camera frame's time), which is what comparing a live recording
  // needs; chaining (the default) is for running new code over old inputs.
  bool isolated = false;
};

struct ReplayResult {
  int64_t events_read = 0;
  int64_t events_delivered = 0;  // input events some node subscribed to
  int64_t events_skipped = 0;    // on channels a node regenerates (none when isolated)
  int64_t messages_published = 0;
  int64_t timers_fired = 0;
  Micros first_time = 0;
  Micros last_time = 0;
  int exit_code = 0;
};

class ReplayRunner final : public LogicalTimeRunner {
 public:
  explicit ReplayRunner(ReplayOptions options);
  ~ReplayRunner() override;

  ReplayResult run();

  // Attaches `node` at log time `start` instead of at the first event. For a
  // recording's own processes (from their CONFIG snapshots): each started at
  // its own moment, received only what was published after it, and ran its
  // timers from then; its replayed twin does the same.
  void add_from(Node& node, Micros start);

  void publish_bytes(const std::string& channel, const void* data, std::size_t size) override;
  void watch_fd(int, std::function<void()>) override;
  void unwatch_fd(int) override {}
  void request_stop(int exit_code) override;

 private:
  void fire_timers_until(Micros t);
  // Attaches the add_from() nodes due at or before `t`, each at its own time.
  void attach_due(Micros t);

  ReplayOptions options_;
  std::unique_ptr<lcm::LogFile> out_;
  ReplayResult result_;
  bool stop_ = false;
  bool write_failed_ = false;
  std::vector<std::pair<Micros, Node*>> late_;  // add_from(), ordered by start
  std::size_t late_attached_ = 0;
};

}  // namespace harvest::rt
