#include "runtime/timer_queue.hpp"

#include <stdexcept>

namespace harvest::rt {

TimerId TimerQueue::add(Micros first_due, Micros period, std::function<void()> callback) {
  if (period < 0) throw std::invalid_argument("timer period must be >= 0");
  const TimerId id = next_id_++;
  by_due_.emplace(std::make_pair(first_due, id),
                  Entry{period, std::make_shared<std::function<void()>>(std::move(callback))});
  due_of_[id] = first_due;
  return id;
}

void TimerQueue::cancel(TimerId id) {
  auto it = due_of_.find(id);
  if (it == due_of_.end()) return;
  by_due_.erase({it->second, id});
  due_of_.erase(it);
}

std::optional<Micros> TimerQueue::next_due() const {
  if (by_due_.empty()) return std::nullopt;
  return by_due_.begin()->first.first;
}

std::size_t TimerQueue::fire_due(Micros until, const std::function<void(Micros, TimerId)>& set_time) {
  std::size_t fired = 0;
  while (!by_due_.empty() && by_due_.begin()->first.first <= until) {
    auto node = by_due_.extract(by_due_.begin());
    const Micros due = node.key().first;
    const TimerId id = node.key().second;
    Entry entry = std::move(node.mapped());
    if (entry.period > 0) {
      // Re-arm before the callback so the callback may cancel its own timer.
      by_due_.emplace(std::make_pair(due + entry.period, id), Entry{entry.period, entry.callback});
      due_of_[id] = due + entry.period;
    } else {
      due_of_.erase(id);
    }
    set_time(due, id);
    (*entry.callback)();  // `entry` holds it alive even if the callback cancels its own timer
    ++fired;
  }
  return fired;
}

bool TimerQueue::periodic(TimerId id) const {
  auto it = due_of_.find(id);
  return it != due_of_.end() && by_due_.at({it->second, id}).period > 0;
}

bool TimerQueue::fire_now(TimerId id) {
  auto it = due_of_.find(id);
  if (it == due_of_.end()) return false;
  const auto key = std::make_pair(it->second, id);
  const Entry entry = by_due_.at(key);
  if (entry.period == 0) {
    by_due_.erase(key);
    due_of_.erase(it);
  }
  (*entry.callback)();
  return true;
}

}  // namespace harvest::rt
