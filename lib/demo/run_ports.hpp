// What one demo run must have to itself on this machine: its LCM network, the
// virtual CAN bus between the simulated drives and the robot link, and the TCP
// port of the simulated end-effector board. Two demos (or a demo and a set
// started by hand) on the fixed defaults would hear each other's drives and
// fight over port 4001, so every run takes ports that are free when it starts.
#pragma once

#include <string>

namespace harvest::demo {

struct RunPorts {
  std::string lcm_url;  // udpm://239.255.76.67:PORT?ttl=0
  std::string can_bus;  // udp_multicast:239.74.163.2:PORT?ttl=0
  int board_port = 0;   // TCP on 127.0.0.1
};

// Ports for one run, each free now and different from each other (the
// kernel's choice, sim::free_port). Throws std::runtime_error if none is.
RunPorts pick_run_ports();

}  // namespace harvest::demo
