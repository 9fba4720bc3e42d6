// Virtual CAN bus on IPv4 UDP multicast, wire-compatible with python-can 4.x
// `udp_multicast` (see python_can_codec.hpp and docs/can.md).
//
// Every member binds the group's port (SO_REUSEADDR) and receives every
// datagram. Frames go out through a separate socket connected to the group,
// so the member recognises (and drops) its own frames by their source
// address, as a real CAN controller does not receive what it sends.
#pragma once

#include <netinet/in.h>

#include <string>

#include "can/bus_spec.hpp"
#include "can/can_bus.hpp"

namespace harvest::can {

class UdpMulticastBus final : public CanBus {
 public:
  explicit UdpMulticastBus(UdpMulticastOptions options);
  ~UdpMulticastBus() override;
  UdpMulticastBus(const UdpMulticastBus&) = delete;
  UdpMulticastBus& operator=(const UdpMulticastBus&) = delete;

  void send(const CanFrame& frame) override;
  std::optional<CanFrame> receive() override;
  int fd() const override { return rx_fd_; }
  void set_filters(const std::vector<CanFilter>& filters) override { filters_ = filters; }
  BusState state() const override { return BusState::kActive; }
  std::string describe() const override;
  // Datagrams that were not valid frames (counted, logged by the caller).
  int64_t malformed() const { return malformed_; }
  const std::string& last_error() const { return last_error_; }
  // IP_MULTICAST_TTL of the sending socket, read back from the kernel.
  int multicast_ttl() const;

 private:
  UdpMulticastOptions options_;
  int rx_fd_ = -1;
  int tx_fd_ = -1;
  sockaddr_in tx_addr_{};  // our own source address
  std::vector<CanFilter> filters_;
  int64_t malformed_ = 0;
  std::string last_error_;
};

}  // namespace harvest::can
