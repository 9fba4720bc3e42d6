// Ports a simulated robot holds on this machine (the virtual CAN bus's UDP
// port, the end-effector board's TCP port): free ones for a new run, and a
// check that a configured one is not already held by another run.
#pragma once

namespace harvest::sim {

// A UDP (udp = true) or TCP port nobody on this machine has bound now,
// chosen by the kernel. Throws std::runtime_error if no socket can be bound.
int free_port(bool udp);

// Whether a socket (any address, bound without SO_REUSEADDR) could take this
// port now. The virtual CAN bus and LCM bind with SO_REUSEADDR, so a port one
// of them holds reads as taken.
bool port_free(int port, bool udp);

}  // namespace harvest::sim
