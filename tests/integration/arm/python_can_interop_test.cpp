// Wire compatibility of the virtual CAN bus with python-can 4.x's own
// udp_multicast interface (Debian python3-can), in both directions.
#include <gtest/gtest.h>
#include <poll.h>
#include <unistd.h>

#include "can/can_bus.hpp"
#include "test_support.hpp"

namespace harvest::can {
namespace {

std::optional<CanFrame> wait_for(CanBus& bus, uint32_t id, int ms) {
  for (int waited = 0; waited <= ms; waited += 10) {
    while (auto f = bus.receive())
      if (f->id == id) return f;
    pollfd p{bus.fd(), POLLIN, 0};
    ::poll(&p, 1, 10);
  }
  return std::nullopt;
}

TEST(PythonCanInterop, FramesCrossBothWays) {
  const int port = 40000 + static_cast<int>(::getpid()) % 20000;
  auto bus = open_bus("udp_multicast:239.74.163.2:" + std::to_string(port) + "?ttl=0");
  testing::TempDir tmp;
  testing::ChildProcess peer(
      {"/usr/bin/python3", testing::source_path("tests/integration/arm/python_can_peer.py"), std::to_string(port)},
      tmp / "peer.log");

  // python-can -> us
  const auto hello = wait_for(*bus, 0x100, 10000);
  ASSERT_TRUE(hello) << peer.output();
  EXPECT_EQ(hello->dlc, 3);
  EXPECT_EQ(hello->data[0], 0xAA);
  EXPECT_EQ(hello->data[2], 0x01);

  // us -> python-can -> us, standard and extended ids
  CanFrame f;
  f.id = 0x123;
  f.dlc = 8;
  for (int i = 0; i < 8; ++i) f.data[static_cast<std::size_t>(i)] = static_cast<uint8_t>(i + 1);
  bus->send(f);
  const auto reply = wait_for(*bus, 0x124, 5000);
  ASSERT_TRUE(reply) << peer.output();
  EXPECT_EQ(reply->dlc, 8);
  for (int i = 0; i < 8; ++i) EXPECT_EQ(reply->data[static_cast<std::size_t>(i)], i + 2);

  CanFrame ext;
  ext.id = 0x1ABCDE0;
  ext.extended = true;
  ext.dlc = 2;
  ext.data[0] = 0xFF;
  ext.data[1] = 0x10;
  bus->send(ext);
  const auto ext_reply = wait_for(*bus, 0x1ABCDE1, 5000);
  ASSERT_TRUE(ext_reply) << peer.output();
  EXPECT_TRUE(ext_reply->extended);
  EXPECT_EQ(ext_reply->data[0], 0x00);
  EXPECT_EQ(ext_reply->data[1], 0x11);
  EXPECT_EQ(peer.wait(std::chrono::seconds(5)), 0) << peer.output();
}

}  // namespace
}  // namespace harvest::can
