#include "demo/run_ports.hpp"

#include <gtest/gtest.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <regex>

#include "sim/ports.hpp"

namespace harvest::demo {
namespace {

int port_of(const std::string& url) {
  std::smatch m;
  EXPECT_TRUE(std::regex_search(url, m, std::regex(":(\\d+)\\?ttl=0$"))) << url;
  return m.empty() ? -1 : std::stoi(m[1]);
}

// Two demos on one machine get their own LCM port, CAN bus and board port:
// each free when picked, none the shipped default, and a port another process
// holds is never handed out.
TEST(RunPorts, EachRunGetsFreePortsOfItsOwn) {
  const RunPorts a = pick_run_ports();
  EXPECT_EQ(a.lcm_url.rfind("udpm://239.255.76.67:", 0), 0u) << a.lcm_url;
  EXPECT_EQ(a.can_bus.rfind("udp_multicast:239.74.163.2:", 0), 0u) << a.can_bus;
  const int lcm = port_of(a.lcm_url), can = port_of(a.can_bus);
  EXPECT_NE(lcm, can);
  EXPECT_NE(can, 43113);
  EXPECT_NE(a.board_port, 4001);
  EXPECT_TRUE(sim::port_free(lcm, true));
  EXPECT_TRUE(sim::port_free(can, true));
  EXPECT_TRUE(sim::port_free(a.board_port, false));

  // While the first run holds its bus (bound as the virtual CAN bus binds), a
  // second run is given another one.
  const int fd = ::socket(AF_INET, SOCK_DGRAM, 0);
  const int one = 1;
  ::setsockopt(fd, SOL_SOCKET, SO_REUSEADDR, &one, sizeof one);
  sockaddr_in addr{};
  addr.sin_family = AF_INET;
  addr.sin_addr.s_addr = htonl(INADDR_ANY);
  addr.sin_port = htons(static_cast<uint16_t>(can));
  ASSERT_EQ(::bind(fd, reinterpret_cast<sockaddr*>(&addr), sizeof addr), 0);
  EXPECT_FALSE(sim::port_free(can, true));
  for (int i = 0; i < 50; ++i) {
    const RunPorts b = pick_run_ports();
    ASSERT_NE(port_of(b.can_bus), can);
    ASSERT_NE(port_of(b.lcm_url), can);
  }
  ::close(fd);
}

}  // namespace
}  // namespace harvest::demo
