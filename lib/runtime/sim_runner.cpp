#include "runtime/sim_runner.hpp"

#include <algorithm>

namespace harvest::rt {

void SimRunner::start() {
  attach_all();
  drain();
}

void SimRunner::publish_bytes(const std::string& channel, const void* data, std::size_t size) {
  const auto* p = static_cast<const uint8_t*>(data);
  log_.push_back({clock_.now(), channel, std::vector<uint8_t>(p, p + size)});
  queue(channel, data, size);
}

void SimRunner::inject_raw(const std::string& channel, const std::vector<uint8_t>& bytes) {
  publish_bytes(channel, bytes.data(), bytes.size());
  drain();
}

void SimRunner::run_until(Micros t) {
  fire_until(t);
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
