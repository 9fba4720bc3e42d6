// A CAN bus configuration string, parsed and checked without opening
// anything, so `--check-config` refuses a bad one before a process touches a
// bus (docs/can.md, "Transports and bus strings"):
//   socketcan:<interface>                          e.g. socketcan:can0
//   udp_multicast[:<group>[:<port>]][?ttl=<0..255>] e.g. udp_multicast:239.74.163.2:43113?ttl=0
// The virtual bus's TTL defaults to 0 (this host only), not python-can's 1:
// simulation and test traffic must not leave the machine; a virtual bus that
// really spans hosts says ?ttl=1.
#pragma once

#include <string>

namespace harvest::can {

struct UdpMulticastOptions {
  std::string group = "239.74.163.2";  // python-can DEFAULT_GROUP_IPv4
  int port = 43113;
  int hop_limit = 0;  // IP_MULTICAST_TTL: 0 = this host only
};

struct BusSpec {
  enum class Kind { kSocketCan, kUdpMulticast };
  Kind kind = Kind::kUdpMulticast;
  std::string interface;    // kSocketCan
  UdpMulticastOptions udp;  // kUdpMulticast
  std::string describe() const;  // canonical form, e.g. udp_multicast:239.74.163.2:43113?ttl=0
};

// Throws CanError naming the string and what is wrong with it.
BusSpec parse_bus_spec(const std::string& spec);

}  // namespace harvest::can
