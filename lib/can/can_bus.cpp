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
  const auto colon = spec.find(':');
  const std::string kind = spec.substr(0, colon);
  const std::string rest = colon == std::string::npos ? "" : spec.substr(colon + 1);
  if (kind == "socketcan") {
    if (rest.empty()) throw CanError("CAN bus '" + spec + "': expected socketcan:<interface>, e.g. socketcan:can0");
    return std::make_unique<SocketCanBus>(rest);
  }
  if (kind == "udp_multicast") {
    UdpMulticastOptions o;
    if (!rest.empty()) {
      const auto c2 = rest.rfind(':');
      o.group = rest.substr(0, c2);
      if (c2 != std::string::npos) {
        const std::string port = rest.substr(c2 + 1);
        std::size_t used = 0;
        try {
          o.port = std::stoi(port, &used);
        } catch (const std::exception&) {
          used = 0;
        }
        if (used == 0 || used != port.size()) throw CanError("CAN bus '" + spec + "': bad port '" + port + "'");
      }
    }
    return std::make_unique<UdpMulticastBus>(o);
  }
  throw CanError("CAN bus '" + spec + "': unknown transport '" + kind +
                 "' (expected socketcan:<interface> or udp_multicast[:<group>[:<port>]])");
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
