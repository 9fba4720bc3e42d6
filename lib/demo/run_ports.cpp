#include "demo/run_ports.hpp"

#include "sim/ports.hpp"

namespace harvest::demo {

RunPorts pick_run_ports() {
  RunPorts p;
  const int lcm = sim::free_port(true);
  int can = sim::free_port(true);
  while (can == lcm) can = sim::free_port(true);  // both sockets are closed: the kernel may offer a port twice
  p.lcm_url = "udpm://239.255.76.67:" + std::to_string(lcm) + "?ttl=0";
  p.can_bus = "udp_multicast:239.74.163.2:" + std::to_string(can) + "?ttl=0";
  p.board_port = sim::free_port(false);
  return p;
}

}  // namespace harvest::demo
