#include "can/memory_bus.hpp"

namespace harvest::can {

void MemoryBus::send(const CanFrame& frame) {
  if (frame.dlc > 8) throw CanError("memory bus: dlc > 8");
  if (!disconnected_ && wire_ != nullptr) wire_->deliver(this, frame);
}

std::optional<CanFrame> MemoryBus::receive() {
  while (!queue_.empty()) {
    CanFrame f = queue_.front();
    queue_.pop_front();
    if (filters_.empty() || f.error) return f;
    for (const auto& filter : filters_)
      if (filter.matches(f)) return f;
  }
  return std::nullopt;
}

MemoryBus& MemoryWire::attach() {
  endpoints_.push_back(std::make_unique<MemoryBus>());
  endpoints_.back()->wire_ = this;
  return *endpoints_.back();
}

void MemoryWire::deliver(const MemoryBus* from, const CanFrame& frame) {
  ++frames_;
  for (auto& e : endpoints_)
    if (e.get() != from) e->queue_.push_back(frame);
}

}  // namespace harvest::can
