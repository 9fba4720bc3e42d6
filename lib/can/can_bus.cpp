#include "can/can_bus.hpp"

#include <cstdio>

#include "can/socketcan.hpp"
#include "can/udp_multicast.hpp"

namespace harvest::can {

const char* to_string(BusState s) {
  switch (s) {
    case BusState::kActive:
      return "error active";
    case BusState::kWarning:
      return "error warning";
    case BusState::kPassive:
      return "error passive";
    case BusState::kBusOff:
      return "bus off";
  }
  return "?";
}

std::unique_ptr<CanBus> open_bus(const std::string& spec) {
  const BusSpec s = parse_bus_spec(spec);
  if (s.kind == BusSpec::Kind::kSocketCan) return std::make_unique<SocketCanBus>(s.interface);
  return std::make_unique<UdpMulticastBus>(s.udp);
}

std::string to_string(const CanFrame& frame) {
  char buf[64];
  std::snprintf(buf, sizeof(buf), frame.extended ? "0x%08X" : "0x%03X", frame.id);
  std::string s = buf;
  if (frame.error) s += " ERR";
  if (frame.remote) s += " RTR";
  s += " [" + std::to_string(frame.dlc) + "]";
  for (int i = 0; i < frame.dlc && !frame.remote; ++i) {
    std::snprintf(buf, sizeof(buf), " %02X", frame.data[static_cast<std::size_t>(i)]);
    s += buf;
  }
  return s;
}

}  // namespace harvest::can
