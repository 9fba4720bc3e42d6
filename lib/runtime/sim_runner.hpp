// In-memory runner for tests: nodes on a shared manual clock, messages passed
// in process, delivered in exactly ReplayRunner's order (sim_runner_test
// proves it against a replay of the same events):
//   * run_until(t) fires every timer due up to t at its own due time, one at a
//     time, each followed by the messages it caused, then sets the clock to t;
//   * a message (published by a node or injected by the test) is delivered to
//     every handler of its channel at the current time, after the messages
//     already waiting, in publication order, before anything else happens.
// Every message on the bus, injected or published, is kept in order in log(),
// as a logger on a live bus would record it. One in-memory runner for every
// test so no test harness drifts from what replay does.
// Devices (a CAN bus, a serial link) are not in a replay: a node's watched
// descriptor is offered to it when the test says its device may have data,
// poll(), at the current time, followed by the messages it caused.
#pragma once

#include <deque>
#include <functional>
#include <map>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "runtime/clock.hpp"
#include "runtime/log_io.hpp"
#include "runtime/logical_time_runner.hpp"

namespace harvest::rt {

class SimRunner : public LogicalTimeRunner {
 public:
  explicit SimRunner(Micros start, std::string prefix = "")
      : LogicalTimeRunner(std::move(prefix), start, "sim runner") {}

  // Attaches the added nodes and delivers what they published on attach.
  void start();
  void run_until(Micros t);

  template <class Msg>
  void inject(const std::string& channel, const Msg& msg) {
    const std::vector<uint8_t> bytes = encode(msg);
    inject_raw(channel, bytes);
  }
  // Also for bytes that are not a valid message (the runtime drops those).
  void inject_raw(const std::string& channel, const std::vector<uint8_t>& bytes);

  const std::vector<LogRecord>& log() const { return log_; }
  // Messages on a channel that decode as Msg, with their time (a test's
  // injected garbage is not a message).
  template <class Msg>
  std::vector<std::pair<Micros, Msg>> messages(const std::string& channel) const {
    std::vector<std::pair<Micros, Msg>> out;
    for (const auto& r : log_)
      if (r.channel == channel)
        if (auto m = decode<Msg>(r.data)) out.emplace_back(r.timestamp, std::move(*m));
    return out;
  }
  // Offers every watched descriptor to its node once, as a poller finding it
  // readable would.
  void poll();
  bool watching() const { return !watched_.empty(); }
  const Clock& clock() const { return clock_; }
  bool stop_requested() const { return stop_requested_; }
  int exit_code() const { return exit_code_; }

  // Context
  void publish_bytes(const std::string& channel, const void* data, std::size_t size) override;
  void watch_fd(int fd, std::function<void()> on_readable) override { watched_[fd] = std::move(on_readable); }
  void unwatch_fd(int fd) override { watched_.erase(fd); }
  void request_stop(int exit_code) override {
    stop_requested_ = true;
    exit_code_ = exit_code;
  }

 private:
  std::vector<LogRecord> log_;
  std::map<int, std::function<void()>> watched_;
  bool stop_requested_ = false;
  int exit_code_ = 0;
};

}  // namespace harvest::rt
