#include <arpa/inet.h>
#include <gtest/gtest.h>
#include <linux/can.h>
#include <linux/can/error.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <string>

#include "can/python_can_codec.hpp"
#include "can/socketcan.hpp"
#include "can/udp_multicast.hpp"

namespace harvest::can {
namespace {

std::vector<uint8_t> from_hex(const std::string& hex) {
  std::vector<uint8_t> out;
  for (std::size_t i = 0; i + 1 < hex.size(); i += 2)
    out.push_back(static_cast<uint8_t>(std::stoi(hex.substr(i, 2), nullptr, 16)));
  return out;
}

// Produced by python-can 4.1 (Debian python3-can):
//   pack_message(can.Message(timestamp=1.5, arbitration_id=0x181, is_extended_id=False, data=[1, 2, 3, 0xff]))
const char* kPythonStandard =
    "8ba974696d657374616d70cb3ff8000000000000ae6172626974726174696f6e5f6964cd0181ae69735f657874656e6465645f6964c2af69"
    "735f72656d6f74655f6672616d65c2ae69735f6572726f725f6672616d65c2a76368616e6e656cc0a3646c6304a464617461c404010203ff"
    "a569735f6664c2ae626974726174655f737769746368c2b56572726f725f73746174655f696e64696361746f72c2";
//   pack_message(can.Message(arbitration_id=0x1234567, is_extended_id=True, data=[]))
const char* kPythonExtended =
    "8ba974696d657374616d70cb0000000000000000ae6172626974726174696f6e5f6964ce01234567ae69735f657874656e6465645f6964c3"
    "af69735f72656d6f74655f6672616d65c2ae69735f6572726f725f6672616d65c2a76368616e6e656cc0a3646c6300a464617461c400a569"
    "735f6664c2ae626974726174655f737769746368c2b56572726f725f73746174655f696e64696361746f72c2";

CanFrame frame(uint32_t id, std::initializer_list<uint8_t> bytes) {
  CanFrame f;
  f.id = id;
  f.dlc = static_cast<uint8_t>(bytes.size());
  std::copy(bytes.begin(), bytes.end(), f.data.begin());
  return f;
}

TEST(PythonCanCodec, EncodesExactlyAsPythonCan) {
  EXPECT_EQ(encode_python_can(frame(0x181, {1, 2, 3, 0xff}), 1.5), from_hex(kPythonStandard));
  CanFrame ext;
  ext.id = 0x1234567;
  ext.extended = true;
  EXPECT_EQ(encode_python_can(ext, 0.0), from_hex(kPythonExtended));
}

TEST(PythonCanCodec, DecodesPythonCanFrames) {
  auto bytes = from_hex(kPythonStandard);
  CanFrame f = decode_python_can(bytes.data(), bytes.size());
  EXPECT_EQ(f, frame(0x181, {1, 2, 3, 0xff}));
  bytes = from_hex(kPythonExtended);
  f = decode_python_can(bytes.data(), bytes.size());
  EXPECT_TRUE(f.extended);
  EXPECT_EQ(f.id, 0x1234567u);
  EXPECT_EQ(f.dlc, 0);
}

TEST(PythonCanCodec, RejectsMalformedInputWithAReason) {
  const auto good = from_hex(kPythonStandard);
  const auto expect_error = [](const std::vector<uint8_t>& b, const std::string& fragment) {
    try {
      decode_python_can(b.data(), b.size());
      ADD_FAILURE() << "accepted: " << fragment;
    } catch (const CanError& e) {
      EXPECT_NE(std::string(e.what()).find(fragment), std::string::npos) << e.what();
    }
  };
  expect_error(std::vector<uint8_t>(good.begin(), good.end() - 5), "not a complete msgpack");
  expect_error(from_hex("93010203"), "not a msgpack map");
  // dlc 9 with 4 data bytes: replace "dlc" value 0x04 by 0x09.
  auto bad = good;
  const std::string hex(kPythonStandard);
  bad[hex.find("a3646c6304") / 2 + 4] = 0x09;
  expect_error(bad, "dlc > 8");
  bad = good;
  bad[hex.find("a3646c6304") / 2 + 4] = 0x03;
  expect_error(bad, "dlc does not match");
  // is_fd true
  bad = good;
  bad[hex.find("a569735f6664c2") / 2 + 6] = 0xc3;
  expect_error(bad, "CAN FD");
  // Standard id > 0x7FF
  CanFrame f = frame(0x181, {});
  auto enc = encode_python_can(f, 0);
  enc[std::string(reinterpret_cast<const char*>(enc.data()), enc.size()).find("arbitration_id") + 14 + 1] = 0x08;
  expect_error(enc, "out of range");
  // Counts and lengths the datagram cannot hold are refused before msgpack-c
  // allocates for them (array32 of 2^32 - 1: 128 GB; map16 of 65535; str32 of 1 GB).
  expect_error(from_hex("ddffffffff01"), "declares more objects than the datagram has bytes");
  expect_error(from_hex("deffff0101"), "declares more objects than the datagram has bytes");
  expect_error(from_hex("81a178db40000000616263"), "declares a length past the end");
  expect_error(from_hex("81a178c1"), "invalid type byte");
}

TEST(SocketCan, MissingInterfaceOrKernelSupportGivesAClearError) {
  try {
    SocketCanBus bus("nosuchcan7");
    FAIL() << "opened a CAN interface that does not exist";
  } catch (const CanError& e) {
    const std::string msg = e.what();
    EXPECT_NE(msg.find("socketcan:nosuchcan7"), std::string::npos) << msg;
    // Either this kernel lacks SocketCAN (our build machines) or the interface is missing.
    EXPECT_TRUE(msg.find("no SocketCAN support") != std::string::npos ||
                msg.find("no such network interface") != std::string::npos)
        << msg;
  }
  EXPECT_THROW(open_bus("socketcan:"), CanError);
  EXPECT_THROW(open_bus("socketcan:an-interface-name-too-long"), CanError);
}

TEST(SocketCan, DecodesErrorFrames) {
  CanFrame f;
  f.error = true;
  f.id = CAN_ERR_BUSOFF;
  ErrorReport r = decode_error_frame(f);
  EXPECT_TRUE(r.bus_off);
  EXPECT_EQ(r.state, BusState::kBusOff);
  EXPECT_NE(r.text.find("bus off"), std::string::npos);

  f.id = CAN_ERR_CRTL;
  f.data[1] = CAN_ERR_CRTL_TX_PASSIVE;
  r = decode_error_frame(f);
  EXPECT_EQ(r.state, BusState::kPassive);

  f.id = CAN_ERR_RESTARTED;
  r = decode_error_frame(f);
  EXPECT_TRUE(r.restarted);
  EXPECT_EQ(r.state, BusState::kActive);

  f.id = CAN_ERR_ACK;
  EXPECT_NE(decode_error_frame(f).text.find("no ack"), std::string::npos);
}

TEST(OpenBus, RejectsBadSpecs) {
  EXPECT_THROW(open_bus("pcan:0"), CanError);
  EXPECT_THROW(open_bus("udp_multicast:10.0.0.1:43113"), CanError);  // not multicast
  EXPECT_THROW(open_bus("udp_multicast:239.74.163.2:port"), CanError);
  EXPECT_THROW(open_bus("udp_multicast:239.74.163.2:70000"), CanError);
  EXPECT_THROW(open_bus("udp_multicast:239.74.163.2:43113?ttl=256"), CanError);
  EXPECT_THROW(open_bus("udp_multicast:239.74.163.2:43113?ttl=-1"), CanError);
  EXPECT_THROW(open_bus("udp_multicast:239.74.163.2:43113?ttl="), CanError);
  EXPECT_THROW(open_bus("udp_multicast:239.74.163.2:43113?hops=0"), CanError);
  EXPECT_THROW(open_bus("socketcan:can0?ttl=0"), CanError);
}

// Checked without opening anything (what --check-config relies on), with a
// message that names the string and says what is wrong.
TEST(BusSpec, ParsesWithoutOpeningAndExplainsRefusals) {
  const BusSpec d = parse_bus_spec("udp_multicast");
  EXPECT_EQ(d.kind, BusSpec::Kind::kUdpMulticast);
  EXPECT_EQ(d.udp.group, "239.74.163.2");
  EXPECT_EQ(d.udp.port, 43113);
  EXPECT_EQ(d.udp.hop_limit, 0) << "the virtual bus stays on this host unless told otherwise";
  EXPECT_EQ(d.describe(), "udp_multicast:239.74.163.2:43113?ttl=0");
  const BusSpec l = parse_bus_spec("udp_multicast:239.74.163.9:61234?ttl=1");
  EXPECT_EQ(l.udp.group, "239.74.163.9");
  EXPECT_EQ(l.udp.port, 61234);
  EXPECT_EQ(l.udp.hop_limit, 1);
  EXPECT_EQ(parse_bus_spec("udp_multicast:239.74.163.9?ttl=2").udp.port, 43113);
  const BusSpec s = parse_bus_spec("socketcan:can1");
  EXPECT_EQ(s.kind, BusSpec::Kind::kSocketCan);
  EXPECT_EQ(s.interface, "can1");
  try {
    parse_bus_spec("canbus:can0");
    ADD_FAILURE() << "an unknown transport was accepted";
  } catch (const CanError& e) {
    EXPECT_NE(std::string(e.what()).find("'canbus:can0'"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("unknown transport 'canbus'"), std::string::npos) << e.what();
  }
}

// A port no other test process uses at the same time.
int test_port() {
  static int counter = 0;
  return 20000 + (static_cast<int>(::getpid()) * 7 + counter++) % 20000;
}

std::optional<CanFrame> receive_within(CanBus& bus, int ms) {
  for (int waited = 0; waited <= ms; waited += 10) {
    if (auto f = bus.receive()) return f;
    pollfd p{bus.fd(), POLLIN, 0};
    ::poll(&p, 1, 10);
  }
  return std::nullopt;
}

TEST(UdpMulticast, MembersExchangeFramesAndDoNotHearThemselves) {
  const std::string spec = "udp_multicast:239.74.163.2:" + std::to_string(test_port());
  auto a = open_bus(spec);
  auto b = open_bus(spec);
  a->send(frame(0x601, {0x40, 0x41, 0x60, 0x00, 0, 0, 0, 0}));
  auto got = receive_within(*b, 1000);
  ASSERT_TRUE(got);
  EXPECT_EQ(*got, frame(0x601, {0x40, 0x41, 0x60, 0x00, 0, 0, 0, 0}));
  EXPECT_GT(got->timestamp_us, 0);
  EXPECT_FALSE(receive_within(*a, 50)) << "a sender must not receive its own frame";

  b->send(frame(0x581, {0x4B, 0x41, 0x60, 0x00, 0x37, 0x02}));
  got = receive_within(*a, 1000);
  ASSERT_TRUE(got);
  EXPECT_EQ(got->id, 0x581u);
  EXPECT_EQ(got->dlc, 6);
}

// The TTL the kernel really uses for the frames we send, read back with
// getsockopt: 0 (this host only) unless the bus string says otherwise.
TEST(UdpMulticast, TtlComesFromTheBusStringAndDefaultsToThisHostOnly) {
  const std::string group_port = "udp_multicast:239.74.163.2:" + std::to_string(test_port());
  for (const auto& [suffix, ttl] : std::vector<std::pair<std::string, int>>{{"", 0}, {"?ttl=0", 0}, {"?ttl=1", 1},
                                                                            {"?ttl=5", 5}}) {
    auto bus = open_bus(group_port + suffix);
    auto* udp = dynamic_cast<UdpMulticastBus*>(bus.get());
    ASSERT_NE(udp, nullptr);
    EXPECT_EQ(udp->multicast_ttl(), ttl) << group_port + suffix;
    EXPECT_NE(udp->describe().find("?ttl=" + std::to_string(ttl)), std::string::npos) << udp->describe();
  }
}

TEST(UdpMulticast, FiltersAndMalformedDatagrams) {
  const int port = test_port();
  UdpMulticastOptions o;
  o.port = port;
  UdpMulticastBus rx(o);
  auto tx = open_bus("udp_multicast:239.74.163.2:" + std::to_string(port));
  rx.set_filters({{0x180, 0x780}});  // TPDO1 of any node

  // A stray non-frame datagram on the group: counted, not delivered, nothing lost after it.
  const int raw = ::socket(AF_INET, SOCK_DGRAM, 0);
  sockaddr_in dest{};
  dest.sin_family = AF_INET;
  dest.sin_port = htons(static_cast<uint16_t>(port));
  ::inet_pton(AF_INET, "239.74.163.2", &dest.sin_addr);
  const char junk[] = "not msgpack";
  ::sendto(raw, junk, sizeof(junk), 0, reinterpret_cast<sockaddr*>(&dest), sizeof(dest));
  ::close(raw);

  tx->send(frame(0x201, {1}));  // filtered out
  tx->send(frame(0x182, {2}));
  auto got = receive_within(rx, 1000);
  ASSERT_TRUE(got);
  EXPECT_EQ(got->id, 0x182u);
  EXPECT_EQ(rx.malformed(), 1);
  EXPECT_NE(rx.last_error().find("python-can frame"), std::string::npos);
}

TEST(PythonCanCodec, ARemoteFrameCarriesNoData) {
  // Data bytes in a remote frame's datagram are not the frame's (the encoder
  // sends none); found by python_can_codec_fuzz as a failed round trip.
  auto bytes = encode_python_can(frame(0x601, {1, 2, 3, 4}), 0);
  const std::string text(reinterpret_cast<const char*>(bytes.data()), bytes.size());
  bytes[text.find("is_remote_frame") + 15] = 0xc3;  // true
  const CanFrame d = decode_python_can(bytes.data(), bytes.size());
  EXPECT_TRUE(d.remote);
  EXPECT_EQ(d.dlc, 4);
  EXPECT_EQ(d.data, (std::array<uint8_t, 8>{}));
  const auto again = encode_python_can(d, 0);
  EXPECT_EQ(decode_python_can(again.data(), again.size()), d);
}

}  // namespace
}  // namespace harvest::can
