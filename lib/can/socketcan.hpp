// SocketCAN raw socket (Linux). Error frames are enabled and folded into
// state(); bus-off recovery is the kernel's (`ip link set can0 type can
// restart-ms 100`, see docs/can.md): after a restart the controller
// reports "restarted" and state() returns to active.
#pragma once

#include <string>

#include "can/can_bus.hpp"

namespace harvest::can {

// What an error frame (CAN_ERR_FLAG) says, decoded from linux/can/error.h.
struct ErrorReport {
  BusState state = BusState::kActive;  // state implied by the frame (kActive if it says nothing)
  bool bus_off = false;
  bool restarted = false;
  std::string text;  // human readable, for logs
};
ErrorReport decode_error_frame(const CanFrame& frame);

class SocketCanBus final : public CanBus {
 public:
  // Throws CanError if the kernel has no SocketCAN or the interface does not exist.
  explicit SocketCanBus(const std::string& interface);
  ~SocketCanBus() override;
  SocketCanBus(const SocketCanBus&) = delete;
  SocketCanBus& operator=(const SocketCanBus&) = delete;

  void send(const CanFrame& frame) override;
  std::optional<CanFrame> receive() override;
  int fd() const override { return fd_; }
  void set_filters(const std::vector<CanFilter>& filters) override;
  BusState state() const override { return state_; }
  std::string describe() const override { return "socketcan:" + interface_; }

 private:
  std::string interface_;
  int fd_ = -1;
  BusState state_ = BusState::kActive;
};

}  // namespace harvest::can
