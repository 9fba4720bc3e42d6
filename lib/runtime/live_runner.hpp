// Runs nodes live on LCM: one thread, one poll loop over the LCM socket, the
// watched device descriptors and the timers. Time is the system clock.
#pragma once

#include <lcm/lcm-cpp.hpp>

#include <atomic>
#include <map>
#include <memory>
#include <optional>

#include "runtime/journal.hpp"

#include "runtime/dispatcher.hpp"

namespace harvest::rt {

struct LiveOptions {
  std::string lcm_url;                   // empty: LCM default / $LCM_DEFAULT_URL
  std::string prefix;                    // channel prefix, e.g. "ARM2_"
  Micros shutdown_timeout = 3 * kSecond; // how long nodes get to finish shutting down
  // Non-empty: publish the journal of what the nodes handled (JOURNAL, runtime/journal.hpp) under this
  // instance name, so a replay can drive them exactly as they ran.
  std::string journal_instance;
};

class LiveRunner final : public Dispatcher {
 public:
  explicit LiveRunner(LiveOptions options);
  ~LiveRunner() override;

  // Attach the nodes and run until request_stop(); returns the exit code.
  int run();
  // Async-signal-safe: may be called from a signal handler or another thread.
  void request_stop(int exit_code) override;

  // While a handler or timer callback runs, the moment it began: every now()
  // in it reads the same value, the one the journal records.
  Micros now() const override { return event_time_ ? *event_time_ : clock_.now(); }
  Micros publish_time() const override { return clock_.now(); }
  void publish_bytes(const std::string& channel, const void* data, std::size_t size) override;
  void watch_fd(int fd, std::function<void()> on_readable) override;
  void unwatch_fd(int fd) override;

  lcm::LCM& lcm() { return *lcm_; }

 private:
  void on_first_subscription(const std::string& channel) override;
  void poll_once(Micros max_wait);
  static void on_lcm_message(const lcm::ReceiveBuffer* rbuf, const std::string& channel, LiveRunner* self);

  void flush_journal(bool force);

  LiveOptions options_;
  SystemClock clock_;
  std::optional<Micros> event_time_;
  std::unique_ptr<JournalWriter> journal_;
  std::unique_ptr<lcm::LCM> lcm_;
  std::map<int, std::function<void()>> watched_;
  int wake_pipe_[2] = {-1, -1};
  std::atomic<bool> stop_requested_{false};
  std::atomic<int> exit_code_{0};
};

}  // namespace harvest::rt
