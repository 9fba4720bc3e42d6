// The delivery rules of every runner on logical time, written once: the
// replay runner and the in-memory runner of tests derive from it, so a test
// harness cannot drift from what replay does.
//   * what a handler publishes reaches the other nodes at the same time, in
//     publication order, before the next event (drain);
//   * timers fire at their own due times, one at a time, each followed by the
//     messages it caused (fire_until).
#pragma once

#include <cstdint>
#include <deque>
#include <functional>
#include <string>
#include <utility>
#include <vector>

#include "runtime/clock.hpp"
#include "runtime/dispatcher.hpp"

namespace harvest::rt {

class LogicalTimeRunner : public Dispatcher {
 public:
  Micros now() const override { return clock_.now(); }

 protected:
  // `name` says which runner in the error of nodes publishing to each other without end.
  LogicalTimeRunner(std::string prefix, Micros start, std::string name)
      : Dispatcher(std::move(prefix)), clock_(start), name_(std::move(name)) {}

  // A published message waits for drain().
  void queue(const std::string& channel, const void* data, std::size_t size);
  // Delivers every waiting message, and what their handlers publish, at the current time.
  void drain();
  // Fires every timer due up to `t` (none once `stop` says so), each followed
  // by drain(); the clock is left at the last due time. Returns how many fired.
  int64_t fire_until(Micros t, const std::function<bool()>& stop = {});

  ManualClock clock_;

 private:
  std::deque<std::pair<std::string, std::vector<uint8_t>>> pending_;
  std::string name_;
};

}  // namespace harvest::rt
