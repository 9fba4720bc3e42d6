#include "runtime/sim_runner.hpp"

#include <algorithm>

namespace harvest::rt {

void SimRunner::start() {
  attach_all();
  drain();
}

void SimRunner::publish_bytes(const std::string& channel, const void* data, std::size_t size) {
  const auto* p = static_cast<const uint8_t*>(data);
  LogRecord r{clock_.now(), channel, std::vector<uint8_t>(p, p + size)};
  log_.push_back(r);
  pending_.push_back(std::move(r));
}

void SimRunner::inject_raw(const std::string& channel, const std::vector<uint8_t>& bytes) {
  publish_bytes(channel, bytes.data(), bytes.size());
  drain();
}

void SimRunner::drain() {
  // As ReplayRunner: what a handler publishes reaches the other nodes at the
  // same time, in publication order, before the next event.
  std::size_t guard = 0;
  while (!pending_.empty()) {
    LogRecord r = std::move(pending_.front());
    pending_.pop_front();
    deliver(r.channel, r.data.data(), r.data.size(), clock_.now());
    if (++guard > 1'000'000) throw std::runtime_error("sim runner: nodes keep publishing to each other without end");
  }
}

void SimRunner::run_until(Micros t) {
  // One timer at a time, its messages delivered before the next timer.
  while (true) {
    const auto due = timers_.next_due();
    if (!due || *due > t) break;
    timers_.fire_due(*due, [this](Micros d) { clock_.set(d); });
    drain();
  }
  clock_.set(std::max(clock_.now(), t));
}

void SimRunner::poll() {
  const auto watched = watched_;  // a callback may unwatch (a link closing)
  for (const auto& [fd, on_readable] : watched) {
    if (watched_.count(fd) == 0) continue;
    on_readable();
    drain();
  }
}

}  // namespace harvest::rt
