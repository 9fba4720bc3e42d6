// Board emulator, its TCP server and the TCP / serial transports.
#include <gtest/gtest.h>

#include <thread>

#include "endeffector/board_emulator.hpp"
#include "endeffector/board_server.hpp"
#include "endeffector/parser.hpp"
#include "endeffector/transport.hpp"

namespace ee = harvest::endeffector;
using harvest::rt::kMilli;
using harvest::rt::kSecond;

namespace {

std::span<const uint8_t> bytes_of(const std::string& s) {
  return std::span(reinterpret_cast<const uint8_t*>(s.data()), s.size());
}

template <class T>
std::vector<T> only(const std::vector<ee::Frame>& frames) {
  std::vector<T> out;
  for (const auto& f : frames)
    if (auto* m = std::get_if<T>(&f.message)) out.push_back(*m);
  return out;
}

}  // namespace

TEST(EeEmulator, StreamsIrAtItsConfiguredRateWithoutBursts) {
  ee::EmulatorConfig cfg;
  cfg.ir_rate_hz = 100;
  ee::BoardEmulator board(cfg);
  board.new_session(0);
  ee::Parser host;
  std::vector<ee::Frame> frames;
  for (harvest::rt::Micros t = 0; t <= kSecond; t += kMilli) {
    for (auto& f : host.feed(board.produce(t))) frames.push_back(f);
  }
  const auto ir = only<ee::IrSample>(frames);
  EXPECT_EQ(ir.size(), 101u);  // t = 0, 10 ms, ..., 1000 ms
  EXPECT_EQ(ir.front().raw, cfg.ir_raw);
  EXPECT_EQ(host.counters().errors(), 0);
  // Sequence numbers are consecutive across frame types.
  for (std::size_t i = 1; i < frames.size(); ++i) EXPECT_EQ(frames[i].seq, frames[i - 1].seq + 1);
}

TEST(EeEmulator, GripperClosesInTheConfiguredTimeAndHoldsAnObject) {
  ee::EmulatorConfig cfg;
  cfg.full_travel_s = 0.5;
  ee::BoardEmulator board(cfg);
  auto gripper = std::make_unique<ee::LinearGripper>(cfg.full_travel_s, cfg.default_force_n);
  gripper->set_object_position(0.4);  // a fruit stops the fingers at 40 % opening
  board.set_gripper(std::move(gripper));
  board.new_session(0);
  ee::Parser host;
  board.receive(bytes_of(ee::encode({5, ee::Close{7000}})), 0);
  const auto first = host.feed(board.produce(0));
  ASSERT_EQ(only<ee::Ack>(first).size(), 1u);
  EXPECT_EQ(only<ee::Ack>(first)[0].command_seq, 5);
  EXPECT_EQ(only<ee::Ack>(first)[0].status, 0);
  // 1.0 -> 0.4 at 2/s takes 0.3 s.
  std::vector<ee::Grip> grips;
  for (harvest::rt::Micros t = kMilli; t <= 400 * kMilli; t += kMilli) {
    for (auto& g : only<ee::Grip>(host.feed(board.produce(t)))) grips.push_back(g);
    if (t == 250 * kMilli) {
      ASSERT_FALSE(grips.empty());
      EXPECT_EQ(grips.back().state, ee::GripState::kClosing);
    }
  }
  EXPECT_EQ(grips.back().state, ee::GripState::kHolding);
  EXPECT_EQ(grips.back().position_permille, 400);
  EXPECT_EQ(grips.back().force_mn, 7000);
}

TEST(EeEmulator, AnswersPingAndRejectsCommandsWhileFaulted) {
  ee::BoardEmulator board;
  board.new_session(0);
  ee::Parser host;
  board.receive(bytes_of(ee::encode({1, ee::Ping{77}})), 0);
  const auto pong = only<ee::Pong>(host.feed(board.produce(0)));
  ASSERT_EQ(pong.size(), 1u);
  EXPECT_EQ(pong[0].token, 77u);
  EXPECT_EQ(pong[0].version, ee::kProtocolVersion);
  board.raise_fault(3, "motor stall");
  board.receive(bytes_of(ee::encode({2, ee::Open{}})), kMilli);
  const auto frames = host.feed(board.produce(kMilli));
  ASSERT_EQ(only<ee::Fault>(frames).size(), 1u);
  EXPECT_EQ(only<ee::Fault>(frames)[0].text, "motor stall");
  ASSERT_EQ(only<ee::Ack>(frames).size(), 1u);
  EXPECT_EQ(only<ee::Ack>(frames)[0].status, 2);
  ASSERT_FALSE(only<ee::Grip>(frames).empty());
  EXPECT_EQ(only<ee::Grip>(frames).back().state, ee::GripState::kFault);
}

TEST(EeEmulator, SilentBoardSendsNothing) {
  ee::BoardEmulator board;
  board.new_session(0);
  board.set_silent(true);
  board.receive(bytes_of(ee::encode({1, ee::Ping{1}})), 0);
  for (harvest::rt::Micros t = 0; t < 100 * kMilli; t += kMilli) EXPECT_TRUE(board.produce(t).empty());
  board.set_silent(false);
  EXPECT_FALSE(board.produce(100 * kMilli).empty());
}

TEST(EeEmulator, PluggedInIrSourceIsUsed) {
  ee::BoardEmulator board;
  board.set_ir_source([](harvest::rt::Micros now) { return static_cast<int32_t>(now / kMilli); });
  board.new_session(0);
  ee::Parser host;
  const auto ir = only<ee::IrSample>(host.feed(board.produce(42 * kMilli)));
  ASSERT_EQ(ir.size(), 1u);
  EXPECT_EQ(ir[0].raw, 42);
}

TEST(EeTransport, TcpClientTalksToTheBoardServer) {
  ee::BoardEmulator board;
  ee::BoardServer server(board, "127.0.0.1", 0);
  ASSERT_GT(server.port(), 0);
  auto link = ee::make_tcp_stream({"127.0.0.1", server.port()});
  EXPECT_EQ(link->describe(), "tcp:127.0.0.1:" + std::to_string(server.port()));
  link->open();
  harvest::rt::Micros t = 0;
  ee::Parser host;
  std::vector<ee::Frame> frames;
  bool pinged = false;
  for (int i = 0; i < 500 && only<ee::Pong>(frames).empty(); ++i, t += kMilli) {
    server.service(t);
    if (link->poll_open() != ee::LinkState::kOpen) continue;
    if (!pinged) {
      const std::string ping = ee::encode({1, ee::Ping{9}});
      ASSERT_EQ(link->write(bytes_of(ping)).bytes, ping.size());
      pinged = true;
    }
    uint8_t buf[256];
    const auto r = link->read(buf);
    if (r.status == ee::IoResult::kOk)
      host.feed(std::span<const uint8_t>(buf, r.bytes), [&](const ee::Frame& f) { frames.push_back(f); });
    std::this_thread::sleep_for(std::chrono::milliseconds(1));
  }
  ASSERT_EQ(only<ee::Pong>(frames).size(), 1u);
  EXPECT_EQ(only<ee::Pong>(frames)[0].token, 9u);
  EXPECT_FALSE(only<ee::IrSample>(frames).empty());
  EXPECT_EQ(server.connections(), 1);
}

TEST(EeTransport, TcpConnectToAClosedPortFailsNamingTheEndpoint) {
  int port;
  {
    ee::BoardEmulator board;
    ee::BoardServer server(board, "127.0.0.1", 0);
    port = server.port();
  }  // closed again: nobody listens there now
  auto link = ee::make_tcp_stream({"127.0.0.1", port});
  try {
    link->open();
    for (int i = 0; i < 1000 && link->poll_open() == ee::LinkState::kConnecting; ++i)
      std::this_thread::sleep_for(std::chrono::milliseconds(1));
    FAIL() << "connect to a closed port succeeded";
  } catch (const ee::TransportError& e) {
    EXPECT_NE(std::string(e.what()).find("tcp:127.0.0.1:" + std::to_string(port)), std::string::npos) << e.what();
  }
  EXPECT_EQ(link->state(), ee::LinkState::kClosed);
}

TEST(EeTransport, NonExistentSerialPortGivesAnErrorNamingIt) {
  ee::SerialOptions o;
  o.port = "/dev/ttyHARVEST_DOES_NOT_EXIST";
  auto link = ee::make_serial_stream(o);
  EXPECT_EQ(link->describe(), "serial:/dev/ttyHARVEST_DOES_NOT_EXIST");
  try {
    link->open();
    FAIL() << "opened a serial port that does not exist";
  } catch (const ee::TransportError& e) {
    EXPECT_NE(std::string(e.what()).find("/dev/ttyHARVEST_DOES_NOT_EXIST"), std::string::npos) << e.what();
  }
  EXPECT_EQ(link->state(), ee::LinkState::kClosed);
  EXPECT_EQ(link->fd(), -1);
}

TEST(EeTransport, ConfigChoosesTransportAndRejectsBadValues) {
  auto doc = harvest::config::Document::load_string("transport: serial\nserial: {port: /dev/ttyUSB7, parity: even}\n");
  auto link = ee::make_stream_from_config(doc.root());
  EXPECT_EQ(link->describe(), "serial:/dev/ttyUSB7");
  auto bad = harvest::config::Document::load_string("transport: serial\nserial: {port: /dev/ttyUSB7, parity: maybe}\n");
  EXPECT_THROW(ee::make_stream_from_config(bad.root()), harvest::config::Error);
  auto bad_host = harvest::config::Document::load_string("transport: tcp\ntcp: {host: board.local, port: 4001}\n");
  EXPECT_THROW(ee::make_stream_from_config(bad_host.root()), ee::TransportError);
}

TEST(EeEmulator, HostCanPushIrValuesAndObserveCommands) {
  ee::BoardEmulator board;
  std::vector<ee::Frame> seen;
  board.set_command_observer([&](const ee::Frame& f, harvest::rt::Micros) { seen.push_back(f); });
  board.set_ir_raw(512);
  board.new_session(0);
  ee::Parser host;
  board.receive(bytes_of(ee::encode({3, ee::Close{4000}}) + ee::encode({4, ee::Ping{1}})), 0);
  const auto frames = host.feed(board.produce(0));
  ASSERT_EQ(only<ee::IrSample>(frames).size(), 1u);
  EXPECT_EQ(only<ee::IrSample>(frames)[0].raw, 512);
  ASSERT_EQ(seen.size(), 2u);
  EXPECT_EQ(seen[0].seq, 3);
  EXPECT_EQ(std::get<ee::Close>(seen[0].message).force_mn, 4000);
  EXPECT_TRUE(std::holds_alternative<ee::Ping>(seen[1].message));
}

TEST(EeTransport, SerialOptionsReadEveryLineSetting) {
  auto doc = harvest::config::Document::load_string(
      "port: /dev/ttyUSB3\nbaud: 9600\ndata_bits: 7\nparity: odd\nstop_bits: 2\nflow_control: rtscts\n");
  const auto o = ee::SerialOptions::from_config(doc.root());
  EXPECT_EQ(o.port, "/dev/ttyUSB3");
  EXPECT_EQ(o.baud, 9600);
  EXPECT_EQ(o.data_bits, 7);
  EXPECT_EQ(o.parity, "odd");
  EXPECT_EQ(o.stop_bits, 2);
  EXPECT_EQ(o.flow_control, "rtscts");
  EXPECT_NO_THROW(doc.check_unused());
  for (const char* bad : {"port: /dev/ttyUSB3\nstop_bits: 3\n", "port: /dev/ttyUSB3\nbaud: 10\n",
                          "port: /dev/ttyUSB3\nflow_control: maybe\n", "port: ''\n", "baud: 9600\n"}) {
    auto d = harvest::config::Document::load_string(bad);
    EXPECT_THROW(ee::SerialOptions::from_config(d.root()), harvest::config::Error) << bad;
  }
}
