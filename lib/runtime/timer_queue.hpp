// Timers driven by an injected clock. Both runners use this one queue, so a
// timer fires at the same logical times live and in replay: periodic timers
// re-arm at due + period, never at "now + period".
#pragma once

#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <optional>
#include <utility>

#include "runtime/clock.hpp"

namespace harvest::rt {

using TimerId = uint64_t;

class TimerQueue {
 public:
  TimerId add(Micros first_due, Micros period, std::function<void()> callback);
  void cancel(TimerId id);
  std::optional<Micros> next_due() const;
  // Fire every timer due at or before `until`, earliest first (ties in
  // creation order). set_time is called with each timer's due time before
  // its callback runs. Returns the number fired.
  std::size_t fire_due(Micros until, const std::function<void(Micros, TimerId)>& set_time);
  // Runs timer `id`'s callback now, whatever its due time (a journal replay
  // fires timers when the live ones ran): a periodic timer stays armed as it
  // was, a one-shot one is gone. False if there is no such timer.
  bool fire_now(TimerId id);
  bool periodic(TimerId id) const;
  std::size_t size() const { return by_due_.size(); }

 private:
  struct Entry {
    Micros period;
    // Shared by the re-armed entry: one callback object for the timer's life
    // (a copy per firing lost what a mutable callback kept, and allocated).
    std::shared_ptr<std::function<void()>> callback;
  };
  // key: (due, id) gives a total, deterministic order.
  std::map<std::pair<Micros, TimerId>, Entry> by_due_;
  std::map<TimerId, Micros> due_of_;
  TimerId next_id_ = 1;
};

}  // namespace harvest::rt
