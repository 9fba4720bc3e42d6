#include "runtime/logical_time_runner.hpp"

#include <stdexcept>

namespace harvest::rt {

void LogicalTimeRunner::queue(const std::string& channel, const void* data, std::size_t size) {
  const auto* p = static_cast<const uint8_t*>(data);
  pending_.emplace_back(channel, std::vector<uint8_t>(p, p + size));
}

void LogicalTimeRunner::drain() {
  std::size_t guard = 0;
  while (!pending_.empty()) {
    const auto [channel, bytes] = std::move(pending_.front());
    pending_.pop_front();
    deliver(channel, bytes.data(), bytes.size(), clock_.now());
    if (++guard > 1'000'000) throw std::runtime_error(name_ + ": nodes keep publishing to each other without end");
  }
}

int64_t LogicalTimeRunner::fire_until(Micros t, const std::function<bool()>& stop) {
  int64_t fired = 0;
  while (!(stop && stop())) {
    const auto due = timers_.next_due();
    if (!due || *due > t) break;
    fired += static_cast<int64_t>(timers_.fire_due(*due, [this](Micros d, TimerId id) {
      clock_.set(d);
      if (!timers_.periodic(id)) forget_timer(id);
    }));
    drain();
  }
  return fired;
}

}  // namespace harvest::rt
