// An in-process CAN bus for unit tests and single-process simulation: every
// endpoint attached to one MemoryWire receives the frames the others send
// (never its own), in order. No file descriptor: poll receive() instead.
#pragma once

#include <deque>
#include <memory>
#include <vector>

#include "can/can_bus.hpp"

namespace harvest::can {

class MemoryWire;

class MemoryBus final : public CanBus {
 public:
  void send(const CanFrame& frame) override;
  std::optional<CanFrame> receive() override;
  int fd() const override { return -1; }
  void set_filters(const std::vector<CanFilter>& filters) override { filters_ = filters; }
  BusState state() const override { return BusState::kActive; }
  std::string describe() const override { return "memory"; }
  // Test hook: drop everything this endpoint sends (a cut cable).
  void set_disconnected(bool d) { disconnected_ = d; }

 private:
  friend class MemoryWire;
  MemoryWire* wire_ = nullptr;
  std::deque<CanFrame> queue_;
  std::vector<CanFilter> filters_;
  bool disconnected_ = false;
};

class MemoryWire {
 public:
  // Endpoints live as long as the wire.
  MemoryBus& attach();
  int64_t frames() const { return frames_; }

 private:
  friend class MemoryBus;
  void deliver(const MemoryBus* from, const CanFrame& frame);
  std::vector<std::unique_ptr<MemoryBus>> endpoints_;
  int64_t frames_ = 0;
};

}  // namespace harvest::can
