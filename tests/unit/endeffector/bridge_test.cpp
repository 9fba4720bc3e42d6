// The bridge's pure logic (commands, telemetry -> messages, back-off) and the
// bridge node itself on a manual clock, against the board emulator behind an
// in-memory link: no sockets, no LCM, every time exact.
#include <gtest/gtest.h>

#include <map>

#include "endeffector/board_emulator.hpp"
#include "endeffector/bridge_logic.hpp"
#include "endeffector/bridge_node.hpp"
#include "endeffector/parser.hpp"
#include "runtime/dispatcher.hpp"
#include "runtime/sim_runner.hpp"
#include "signing.hpp"

namespace ee = harvest::endeffector;
namespace rt = harvest::rt;
using harvest::gripper_command_t;
using harvest::gripper_state_t;
using harvest::ir_range_t;
using rt::kMilli;
using rt::kSecond;
using rt::Micros;

namespace {

// Copies of the LCM constants: gtest takes arguments by reference, and the
// generated static members have no out-of-line definition.
constexpr int8_t kCmdClose = gripper_command_t::ACTION_CLOSE;
constexpr int8_t kCmdMove = gripper_command_t::ACTION_MOVE;
constexpr int8_t kCmdOpen = gripper_command_t::ACTION_OPEN;
constexpr int8_t kCmdStop = gripper_command_t::ACTION_STOP;
constexpr int8_t kGsClosed = gripper_state_t::STATE_CLOSED;
constexpr int8_t kGsClosing = gripper_state_t::STATE_CLOSING;
constexpr int8_t kGsDisconnected = gripper_state_t::STATE_DISCONNECTED;
constexpr int8_t kGsFault = gripper_state_t::STATE_FAULT;
constexpr int8_t kGsHolding = gripper_state_t::STATE_HOLDING;
constexpr int8_t kGsOpen = gripper_state_t::STATE_OPEN;
constexpr int8_t kGsOpening = gripper_state_t::STATE_OPENING;
constexpr int8_t kGsUnknown = gripper_state_t::STATE_UNKNOWN;
constexpr int8_t kIrNoData = ir_range_t::NO_DATA;
constexpr int8_t kIrTooFar = ir_range_t::TOO_FAR;
constexpr int8_t kIrTooNear = ir_range_t::TOO_NEAR;
constexpr int8_t kIrValid = ir_range_t::VALID;
constexpr Micros kT0 = 1'700'000'000 * kSecond;  // an arbitrary epoch time

// ---------------------------------------------------------------------------
// The device double: a board emulator behind a fake byte stream.

struct FakeDevice {
  explicit FakeDevice(const rt::Clock& c) : clock(c) {}
  const rt::Clock& clock;
  ee::BoardEmulator board;
  bool accept = true;         // false: connection refused
  bool hang_connect = false;  // true: the connect never completes
  bool connected = false;
  bool closed_by_device = false;
  std::vector<Micros> open_attempts;
  int sessions = 0;
  std::string to_host;
  std::string from_host;  // every byte the host wrote, all sessions

  // The device drops the connection after half a frame.
  void close_mid_frame() {
    to_host += board.produce(clock.now());
    const std::string f = ee::encode({0, ee::IrSample{1234}});
    to_host += f.substr(0, f.size() / 2);
    closed_by_device = true;
  }
  std::vector<ee::Frame> host_frames() const {
    ee::Parser p;
    return p.feed(from_host);
  }
};

class FakeLink final : public ee::ByteStream {
 public:
  explicit FakeLink(FakeDevice& d) : d_(d) {}
  std::string describe() const override { return "fake:board"; }
  void open() override {
    close();
    d_.open_attempts.push_back(d_.clock.now());
    if (!d_.accept) throw ee::TransportError("fake:board: connect: Connection refused");
    state_ = d_.hang_connect ? ee::LinkState::kConnecting : ee::LinkState::kOpen;
    if (state_ == ee::LinkState::kOpen) start();
  }
  ee::LinkState poll_open() override { return state_; }
  ee::LinkState state() const override { return state_; }
  int fd() const override { return state_ == ee::LinkState::kClosed ? -1 : 1000; }
  ee::IoResult read(std::span<uint8_t> buf) override {
    if (!d_.closed_by_device) d_.to_host += d_.board.produce(d_.clock.now());
    if (d_.to_host.empty()) {
      if (d_.closed_by_device) return {ee::IoResult::kClosed, 0, {}};
      return {ee::IoResult::kWouldBlock, 0, {}};
    }
    const std::size_t n = std::min(buf.size(), d_.to_host.size());
    std::copy_n(d_.to_host.begin(), n, buf.begin());
    d_.to_host.erase(0, n);
    return {ee::IoResult::kOk, n, {}};
  }
  ee::IoResult write(std::span<const uint8_t> b) override {
    if (d_.closed_by_device) return {ee::IoResult::kClosed, 0, {}};
    d_.from_host.append(reinterpret_cast<const char*>(b.data()), b.size());
    d_.board.receive(b, d_.clock.now());
    return {ee::IoResult::kOk, b.size(), {}};
  }
  void close() override {
    if (state_ != ee::LinkState::kClosed) d_.connected = false;
    state_ = ee::LinkState::kClosed;
  }

 private:
  void start() {
    d_.connected = true;
    d_.closed_by_device = false;
    d_.to_host.clear();
    ++d_.sessions;
    d_.board.new_session(d_.clock.now());
  }
  FakeDevice& d_;
  ee::LinkState state_ = ee::LinkState::kClosed;
};

// ---------------------------------------------------------------------------
// The bridge on the one in-memory runner (rt::SimRunner, replay's delivery
// order): timers fire at their due times, the device's descriptor is offered
// to the node every millisecond.

class TestRunner final : public rt::SimRunner {
 public:
  TestRunner() : SimRunner(kT0) {}
  const rt::Clock& clock = SimRunner::clock();

  void start(rt::Node& node) {
    add(node);
    SimRunner::start();
  }
  void run_for(Micros d) { run_until(now() + d); }
  void run_until(Micros until) {
    while (now() < until) {
      SimRunner::run_until(std::min(until, now() + kMilli));
      poll();
    }
  }
  // Gripper commands go in signed by the controller, e-stops by an operator
  // (docs/security.md); inject_as_is sends them as they are.
  template <class Msg>
  void inject(const std::string& channel, Msg msg) {
    if constexpr (std::is_same_v<Msg, harvest::gripper_command_t>)
      msg = controller(msg);
    else if constexpr (std::is_same_v<Msg, harvest::emergency_stop_t>)
      msg = operator_signer(msg);
    inject_as_is(channel, msg);
  }
  harvest::testing::CommandSigner controller{harvest::testing::kController, &clock};
  harvest::testing::CommandSigner operator_signer{harvest::testing::kOperator, &clock};
  template <class Msg>
  void inject_as_is(const std::string& channel, const Msg& msg) {
    SimRunner::inject(channel, msg);
  }
  // What the bridge published on `channel` from `since` on.
  template <class Msg>
  std::vector<Msg> messages(const std::string& channel, Micros since = 0) const {
    std::vector<Msg> out;
    for (auto& [time, m] : SimRunner::messages<Msg>(channel))
      if (time >= since) out.push_back(std::move(m));
    return out;
  }
};

// A two-knot curve whose values are easy to work out by hand:
// raw 100 -> 0.30 m, raw 500 -> 0.10 m (higher raw is nearer).
ee::IrCurve hand_curve() { return ee::IrCurve({{100, 0.30}, {500, 0.10}}); }

ee::BridgeConfig test_config(FakeDevice& dev) {
  ee::BridgeConfig c;
  c.make_link = [&dev] { return std::make_unique<FakeLink>(dev); };
  c.ir_curve = hand_curve();
  c.ir_channel = "IR_RANGE";
  c.state_channel = "GRIPPER_STATE";
  c.command_channel = "GRIPPER_COMMAND";
  c.estop_channel = "EMERGENCY_STOP";
  c.authority = harvest::testing::sim_authority("");
  return c;  // timing defaults: silence 200 ms, reconnect after 1 s, back-off 100 ms .. 2 s
}

int64_t counter(const rt::Node& n, const std::string& name) {
  const auto it = n.stats().counters.find(name);
  return it == n.stats().counters.end() ? 0 : it->second;
}

gripper_command_t command(int8_t action, float force_n, float position = 0) {
  gripper_command_t c{};
  c.action = action;
  c.force_n = force_n;
  c.position = position;
  return c;
}

template <class T>
std::vector<T> only(const std::vector<ee::Frame>& frames) {
  std::vector<T> out;
  for (const auto& f : frames)
    if (auto* m = std::get_if<T>(&f.message)) out.push_back(*m);
  return out;
}

struct Fixture {
  TestRunner run;
  FakeDevice dev{run.clock};
  std::unique_ptr<ee::BridgeNode> node;
  explicit Fixture(std::function<void(ee::BridgeConfig&)> tweak = {}) {
    auto cfg = test_config(dev);
    if (tweak) tweak(cfg);
    node = std::make_unique<ee::BridgeNode>(std::move(cfg));
    dev.board.set_ir_source([](Micros) { return 300; });  // inside the hand curve: 0.20 m
  }
  void start() { run.start(*node); }
};

}  // namespace

// ---------------------------------------------------------------------------
// Pure logic

TEST(EeBridgeLogic, IrRangeCarriesRawMetresFromTheCurveAndValidity) {
  const ee::IrCurve curve = hand_curve();
  // Inside: raw 300 is half-way from 100 to 500 -> 0.30 + 0.5 * (0.10 - 0.30) = 0.20 m.
  const ir_range_t mid = ee::make_ir_range(300, curve, kT0);
  EXPECT_EQ(mid.raw, 300);
  EXPECT_FLOAT_EQ(mid.range_m, 0.20f);
  EXPECT_EQ(mid.validity, kIrValid);
  EXPECT_EQ(mid.header.utime, kT0);
  // raw 200: 0.30 - 0.25 * 0.20 = 0.25 m.
  EXPECT_FLOAT_EQ(ee::make_ir_range(200, curve, kT0).range_m, 0.25f);
  // Beyond the knots: clamped, flagged by which end (higher raw = nearer).
  const ir_range_t near = ee::make_ir_range(900, curve, kT0);
  EXPECT_EQ(near.validity, kIrTooNear);
  EXPECT_FLOAT_EQ(near.range_m, 0.10f);
  const ir_range_t far = ee::make_ir_range(40, curve, kT0);
  EXPECT_EQ(far.validity, kIrTooFar);
  EXPECT_FLOAT_EQ(far.range_m, 0.30f);
  const ir_range_t none = ee::make_ir_no_data(kT0);
  EXPECT_EQ(none.validity, kIrNoData);
  EXPECT_EQ(none.raw, -1);
}

TEST(EeBridgeLogic, GripperStateMapsEveryBoardState) {
  const std::pair<ee::GripState, int8_t> map[] = {
      {ee::GripState::kOpen, kGsOpen},       {ee::GripState::kClosing, kGsClosing},
      {ee::GripState::kClosed, kGsClosed},   {ee::GripState::kHolding, kGsHolding},
      {ee::GripState::kOpening, kGsOpening}, {ee::GripState::kStopped, kGsUnknown},
      {ee::GripState::kFault, kGsFault}};
  for (const auto& [board, bus] : map) {
    const auto m = ee::make_gripper_state({board, 400, 7000}, 3, "stall", kT0);
    EXPECT_EQ(m.state, bus) << static_cast<int>(board);
    EXPECT_FLOAT_EQ(m.position, 0.4f);
    EXPECT_FLOAT_EQ(m.force_n, 7.0f);
    EXPECT_TRUE(m.connected);
    EXPECT_EQ(m.fault_code, 3);
    EXPECT_EQ(m.fault_text, "stall");
  }
  const auto gone = ee::make_gripper_disconnected(0.4, "board silent", kT0);
  EXPECT_EQ(gone.state, kGsDisconnected);
  EXPECT_FALSE(gone.connected);
  EXPECT_EQ(gone.fault_text, "board silent");
}

TEST(EeBridgeLogic, CommandsBecomeFramesWithinLimits) {
  ee::CommandGate gate(40.0);
  const auto close = gate.on_command(command(kCmdClose, 7.5f));
  ASSERT_TRUE(close.frame);
  EXPECT_EQ(std::get<ee::Close>(*close.frame).force_mn, 7500);
  EXPECT_TRUE(std::holds_alternative<ee::Open>(*gate.on_command(command(kCmdOpen, 0)).frame));
  EXPECT_TRUE(std::holds_alternative<ee::Stop>(*gate.on_command(command(kCmdStop, 0)).frame));
  const auto move = gate.on_command(command(kCmdMove, 2.0f, 0.25f));
  ASSERT_TRUE(move.frame);
  EXPECT_EQ(std::get<ee::Move>(*move.frame).position_permille, 250);
  EXPECT_EQ(std::get<ee::Move>(*move.frame).force_mn, 2000);

  const auto too_strong = gate.on_command(command(kCmdClose, 41.0f));
  EXPECT_FALSE(too_strong.frame);
  EXPECT_NE(too_strong.rejection.find("force_n"), std::string::npos);
  EXPECT_FALSE(gate.on_command(command(kCmdClose, -1.0f)).frame);
  EXPECT_FALSE(gate.on_command(command(kCmdClose, std::nanf(""))).frame);
  EXPECT_FALSE(gate.on_command(command(kCmdMove, 1.0f, 1.5f)).frame);
  const auto unknown = gate.on_command(command(9, 1.0f));
  EXPECT_FALSE(unknown.frame);
  EXPECT_NE(unknown.rejection.find("unknown action 9"), std::string::npos);
}

TEST(EeBridgeLogic, EmergencyStopLatchesUntilCleared) {
  ee::CommandGate gate(40.0);
  harvest::emergency_stop_t stop{};
  stop.engaged = true;
  const auto sent = gate.on_emergency_stop(stop);
  ASSERT_TRUE(sent);
  EXPECT_TRUE(std::holds_alternative<ee::Stop>(*sent));
  EXPECT_FALSE(gate.on_command(command(kCmdOpen, 0)).frame);
  harvest::emergency_stop_t neither{};
  EXPECT_FALSE(gate.on_emergency_stop(neither));
  EXPECT_TRUE(gate.stopped());  // only an explicit clear releases it
  harvest::emergency_stop_t clear{};
  clear.clear = true;
  gate.on_emergency_stop(clear);
  EXPECT_FALSE(gate.stopped());
  EXPECT_TRUE(gate.on_command(command(kCmdOpen, 0)).frame);
}

TEST(EeBridgeLogic, BackoffDoublesToItsCapAndResets) {
  ee::Backoff b(100 * kMilli, 1000 * kMilli);
  EXPECT_EQ(b.next(), 100 * kMilli);
  EXPECT_EQ(b.next(), 200 * kMilli);
  EXPECT_EQ(b.next(), 400 * kMilli);
  EXPECT_EQ(b.next(), 800 * kMilli);
  EXPECT_EQ(b.next(), 1000 * kMilli);
  EXPECT_EQ(b.next(), 1000 * kMilli);
  b.reset();
  EXPECT_EQ(b.next(), 100 * kMilli);
}

// ---------------------------------------------------------------------------
// The node on a manual clock

TEST(EeBridgeNode, PublishesIrRangeThroughTheCurveAndGripperState) {
  Fixture f;
  int32_t raw = 300;
  f.dev.board.set_ir_source([&raw](Micros) { return raw; });
  f.start();
  f.run.run_for(kSecond);
  raw = 900;  // nearer than the curve knows
  f.run.run_for(100 * kMilli);

  const auto ir = f.run.messages<ir_range_t>("IR_RANGE");
  // The emulator streams IR at 100 Hz: 100 samples in the first second, +-1.
  ASSERT_GE(ir.size(), 100u);
  int valid = 0, too_near = 0;
  for (const auto& m : ir) {
    if (m.raw == 300) {
      ++valid;
      EXPECT_EQ(m.validity, kIrValid);
      EXPECT_FLOAT_EQ(m.range_m, 0.20f);
    } else {
      ++too_near;
      EXPECT_EQ(m.raw, 900);
      EXPECT_EQ(m.validity, kIrTooNear);
    }
    EXPECT_EQ(m.header.utime, m.header.publish_utime);  // stamped on receipt, by the injected clock
  }
  EXPECT_GE(valid, 99);
  EXPECT_GE(too_near, 9);
  // Sequence numbers on the bus are consecutive.
  for (std::size_t i = 1; i < ir.size(); ++i) EXPECT_EQ(ir[i].header.seq, ir[i - 1].header.seq + 1);

  const auto st = f.run.messages<gripper_state_t>("GRIPPER_STATE");
  ASSERT_GE(st.size(), 20u);  // GRIP at 20 Hz
  EXPECT_EQ(st.back().state, kGsOpen);
  EXPECT_TRUE(st.back().connected);
  EXPECT_FLOAT_EQ(st.back().position, 1.0f);
  EXPECT_EQ(f.node->health(), rt::Health::kOk);
  EXPECT_EQ(counter(*f.node, "connects"), 1);
  EXPECT_EQ(counter(*f.node, "bad_checksum") + counter(*f.node, "truncated"), 0);
  // The bridge pings on connect; the board's PONG counts as a frame like the rest.
  EXPECT_EQ(only<ee::Ping>(f.dev.host_frames()).size(), 1u);
}

TEST(EeBridgeNode, GripperCommandsAreEncodedForTheBoardAndStateFollows) {
  Fixture f;
  auto gripper = std::make_unique<ee::LinearGripper>(0.5, 10.0);
  gripper->set_object_position(0.4);
  f.dev.board.set_gripper(std::move(gripper));
  f.start();
  f.run.run_for(100 * kMilli);
  f.run.inject("GRIPPER_COMMAND", command(kCmdClose, 7.5f));
  f.run.run_for(600 * kMilli);
  auto st = f.run.messages<gripper_state_t>("GRIPPER_STATE");
  EXPECT_EQ(st.back().state, kGsHolding);
  EXPECT_NEAR(st.back().position, 0.4f, 1e-3);
  EXPECT_NEAR(st.back().force_n, 7.5f, 1e-3);
  bool saw_closing = false;
  for (const auto& m : st) saw_closing |= m.state == kGsClosing;
  EXPECT_TRUE(saw_closing);

  const Micros before_open = f.run.clock.now();
  f.run.inject("GRIPPER_COMMAND", command(kCmdOpen, 0));
  f.run.run_for(600 * kMilli);
  st = f.run.messages<gripper_state_t>("GRIPPER_STATE", before_open);
  EXPECT_EQ(st.back().state, kGsOpen);
  f.run.inject("GRIPPER_COMMAND", command(kCmdMove, 3.0f, 0.25f));
  f.run.inject("GRIPPER_COMMAND", command(kCmdStop, 0));
  f.run.inject("GRIPPER_COMMAND", command(kCmdClose, 99.0f));  // over max_force_n
  f.run.run_for(10 * kMilli);

  // What went over the wire, in order, exactly.
  const auto frames = f.dev.host_frames();
  const auto closes = only<ee::Close>(frames);
  ASSERT_EQ(closes.size(), 1u);
  EXPECT_EQ(closes[0].force_mn, 7500);
  EXPECT_EQ(only<ee::Open>(frames).size(), 1u);
  ASSERT_EQ(only<ee::Move>(frames).size(), 1u);
  EXPECT_EQ(only<ee::Move>(frames)[0].position_permille, 250);
  EXPECT_EQ(only<ee::Move>(frames)[0].force_mn, 3000);
  EXPECT_EQ(only<ee::Stop>(frames).size(), 1u);
  for (std::size_t i = 1; i < frames.size(); ++i) EXPECT_EQ(frames[i].seq, frames[i - 1].seq + 1);
  EXPECT_EQ(counter(*f.node, "commands_sent"), 4);
  EXPECT_EQ(counter(*f.node, "commands_rejected"), 1);
  EXPECT_EQ(counter(*f.node, "commands_refused_by_board"), 0);
}

TEST(EeBridgeNode, EmergencyStopSendsStopAndBlocksCommands) {
  Fixture f;
  f.start();
  f.run.run_for(50 * kMilli);
  harvest::emergency_stop_t stop{};
  stop.engaged = true;
  f.run.inject("EMERGENCY_STOP", stop);
  f.run.inject("GRIPPER_COMMAND", command(kCmdClose, 5.0f));
  f.run.run_for(10 * kMilli);
  const auto frames = f.dev.host_frames();
  EXPECT_EQ(only<ee::Stop>(frames).size(), 1u);
  EXPECT_TRUE(only<ee::Close>(frames).empty());
  EXPECT_EQ(counter(*f.node, "commands_rejected"), 1);
}

// Command authority (docs/security.md): only the bound controller's signed,
// fresh, not-yet-seen gripper commands reach the board; an e-stop clear only
// from an operator. Refusals are counted by reason and send nothing.
TEST(EeBridgeNode, ForwardsOnlyTheControllersSignedCommands) {
  Fixture f;
  f.start();
  f.run.run_for(50 * kMilli);
  harvest::testing::CommandSigner impostor("someone-else", &f.run.clock);
  const auto captured = f.run.controller(command(kCmdClose, 5.0f));
  f.run.inject_as_is("GRIPPER_COMMAND", captured);                        // obeyed
  f.run.inject_as_is("GRIPPER_COMMAND", captured);                        // replayed
  f.run.inject_as_is("GRIPPER_COMMAND", command(kCmdOpen, 0));            // unsigned
  f.run.inject_as_is("GRIPPER_COMMAND", impostor(command(kCmdOpen, 0)));  // not the controller
  f.run.run_for(10 * kMilli);
  EXPECT_EQ(only<ee::Close>(f.dev.host_frames()).size(), 1u);
  EXPECT_TRUE(only<ee::Open>(f.dev.host_frames()).empty());
  EXPECT_EQ(counter(*f.node, "commands_sent"), 1);
  EXPECT_EQ(counter(*f.node, "gripper_command_refused"), 3);
  EXPECT_EQ(counter(*f.node, "gripper_command_replayed"), 1);
  EXPECT_EQ(counter(*f.node, "gripper_command_unsigned"), 1);
  EXPECT_EQ(counter(*f.node, "gripper_command_unknown_sender"), 1);
  // E-stop: engaged unsigned; an unsigned clear leaves it engaged.
  harvest::emergency_stop_t stop{};
  stop.engaged = true;
  f.run.inject_as_is("EMERGENCY_STOP", stop);
  harvest::emergency_stop_t clear{};
  clear.clear = true;
  f.run.inject_as_is("EMERGENCY_STOP", clear);
  f.run.inject("GRIPPER_COMMAND", command(kCmdOpen, 0));
  f.run.run_for(10 * kMilli);
  EXPECT_TRUE(only<ee::Open>(f.dev.host_frames()).empty()) << "an unsigned clear released the e-stop";
  EXPECT_EQ(counter(*f.node, "emergency_stop_clear_unsigned"), 1);
  f.run.inject("EMERGENCY_STOP", clear);
  f.run.inject("GRIPPER_COMMAND", command(kCmdOpen, 0));
  f.run.run_for(10 * kMilli);
  EXPECT_EQ(only<ee::Open>(f.dev.host_frames()).size(), 1u);
}

TEST(EeBridgeNode, BoardFaultReachesGripperState) {
  Fixture f;
  f.start();
  f.run.run_for(50 * kMilli);
  f.dev.board.raise_fault(3, "motor stall");
  f.run.run_for(100 * kMilli);
  const auto st = f.run.messages<gripper_state_t>("GRIPPER_STATE");
  EXPECT_EQ(st.back().state, kGsFault);
  EXPECT_EQ(st.back().fault_code, 3);
  EXPECT_EQ(st.back().fault_text, "motor stall");
  // A command to a faulted board is refused by the board and counted.
  f.run.inject("GRIPPER_COMMAND", command(kCmdOpen, 0));
  f.run.run_for(10 * kMilli);
  EXPECT_EQ(counter(*f.node, "commands_refused_by_board"), 1);
}

TEST(EeBridgeNode, SilentBoardIsReportedThenReconnectedAndRecovers) {
  Fixture f;
  f.start();
  f.run.run_for(500 * kMilli);
  ASSERT_EQ(f.node->health(), rt::Health::kOk);
  const Micros silent_from = f.run.clock.now();
  f.dev.board.set_silent(true);

  // Past silence_timeout (200 ms): degraded, NO_DATA and DISCONNECTED published, commands dropped.
  f.run.run_for(300 * kMilli);
  EXPECT_EQ(f.node->health(), rt::Health::kDegraded);
  EXPECT_NE(f.node->health_message().find("no telemetry from fake:board"), std::string::npos)
      << f.node->health_message();
  EXPECT_EQ(counter(*f.node, "silences"), 1);
  auto ir = f.run.messages<ir_range_t>("IR_RANGE", silent_from + 1);
  ASSERT_FALSE(ir.empty());
  EXPECT_EQ(ir.back().validity, kIrNoData);
  // No NO_DATA before the timeout: the first one comes after 200 ms of silence.
  EXPECT_GT(ir.front().header.utime, silent_from + 200 * kMilli - 15 * kMilli);
  auto st = f.run.messages<gripper_state_t>("GRIPPER_STATE", silent_from + 1);
  ASSERT_FALSE(st.empty());
  EXPECT_EQ(st.back().state, kGsDisconnected);
  EXPECT_FALSE(st.back().connected);
  f.run.inject("GRIPPER_COMMAND", command(kCmdClose, 5.0f));
  EXPECT_EQ(counter(*f.node, "commands_dropped_no_link"), 1);
  EXPECT_TRUE(only<ee::Close>(f.dev.host_frames()).empty());
  EXPECT_EQ(f.dev.sessions, 1);

  // Past reconnect_after_silence (1 s): the link is dropped and opened again after the back-off.
  f.run.run_for(1000 * kMilli);
  EXPECT_EQ(counter(*f.node, "silence_reconnects"), 1);
  EXPECT_GE(f.dev.sessions, 2);

  // The board talks again: valid data, health OK.
  f.dev.board.set_silent(false);
  const Micros back = f.run.clock.now();
  f.run.run_for(300 * kMilli);
  EXPECT_EQ(f.node->health(), rt::Health::kOk);
  ir = f.run.messages<ir_range_t>("IR_RANGE", back);
  ASSERT_FALSE(ir.empty());
  EXPECT_EQ(ir.back().validity, kIrValid);
  st = f.run.messages<gripper_state_t>("GRIPPER_STATE", back + 100 * kMilli);
  ASSERT_FALSE(st.empty());
  EXPECT_TRUE(st.back().connected);
}

TEST(EeBridgeNode, ReconnectsWithDoublingBackoffAndResetsAfterAGoodLink) {
  Fixture f([](ee::BridgeConfig& c) {
    c.backoff_initial = 100 * kMilli;
    c.backoff_max = 1000 * kMilli;
  });
  f.dev.accept = false;
  f.start();
  f.run.run_for(3500 * kMilli);
  // Attempts at 0, +100, +200, +400, +800, +1000 (cap), +1000 ms.
  const std::vector<Micros> expected = {0, 100, 300, 700, 1500, 2500, 3500};
  ASSERT_EQ(f.dev.open_attempts.size(), expected.size());
  for (std::size_t i = 0; i < expected.size(); ++i)
    EXPECT_EQ(f.dev.open_attempts[i] - kT0, expected[i] * kMilli) << "attempt " << i;
  EXPECT_EQ(f.node->health(), rt::Health::kError);
  EXPECT_NE(f.node->health_message().find("no link to fake:board: fake:board: connect: Connection refused"),
            std::string::npos)
      << f.node->health_message();
  // While there is no link, NO_DATA and DISCONNECTED keep coming at no_data_period (100 ms).
  const auto ir = f.run.messages<ir_range_t>("IR_RANGE");
  EXPECT_GE(ir.size(), 34u);
  for (const auto& m : ir) EXPECT_EQ(m.validity, kIrNoData);

  // The device comes up: the next attempt (at +1000 ms) connects, and after telemetry flowed
  // a loss starts the back-off afresh at 100 ms.
  f.dev.accept = true;
  f.run.run_for(1000 * kMilli);
  ASSERT_EQ(f.dev.open_attempts.size(), expected.size() + 1);
  EXPECT_EQ(f.node->health(), rt::Health::kOk);
  f.run.run_for(200 * kMilli);
  f.dev.close_mid_frame();
  f.dev.accept = false;
  const Micros lost = f.run.clock.now();
  f.run.run_for(350 * kMilli);
  ASSERT_EQ(f.dev.open_attempts.size(), expected.size() + 3);
  // Lost within a millisecond (the next readable callback), then +100 and +200 ms.
  const Micros at_loss = f.dev.open_attempts[expected.size() + 1] - 100 * kMilli;
  EXPECT_LE(at_loss - lost, 10 * kMilli);
  EXPECT_EQ(f.dev.open_attempts[expected.size() + 2] - f.dev.open_attempts[expected.size() + 1], 200 * kMilli);
}

TEST(EeBridgeNode, DeviceClosingMidFrameIsCountedAndTheLinkResumes) {
  Fixture f;
  f.start();
  f.run.run_for(300 * kMilli);
  f.dev.close_mid_frame();
  f.run.run_for(2 * kMilli);
  EXPECT_EQ(f.node->health(), rt::Health::kError);
  EXPECT_NE(f.node->health_message().find("connection closed by the device"), std::string::npos)
      << f.node->health_message();
  EXPECT_EQ(counter(*f.node, "disconnects"), 1);
  EXPECT_EQ(counter(*f.node, "truncated"), 1);  // the half frame
  EXPECT_FALSE(f.run.watching());               // the dead descriptor is no longer polled
  const Micros cut = f.run.clock.now();
  f.run.run_for(400 * kMilli);
  EXPECT_EQ(f.dev.sessions, 2);
  EXPECT_EQ(counter(*f.node, "connects"), 2);
  EXPECT_EQ(f.node->health(), rt::Health::kOk);
  const auto ir = f.run.messages<ir_range_t>("IR_RANGE", cut);
  ASSERT_FALSE(ir.empty());
  EXPECT_EQ(ir.back().validity, kIrValid);
  EXPECT_EQ(ir.back().raw, 300);
  // The half frame never turned into a reading.
  for (const auto& m : f.run.messages<ir_range_t>("IR_RANGE")) EXPECT_NE(m.raw, 1234);
}

TEST(EeBridgeNode, LineNoiseIsCountedInTheHeartbeatCountersAndDataGoesOn) {
  Fixture f;
  f.start();
  f.run.run_for(100 * kMilli);
  std::string bad = ee::encode({900, ee::IrSample{77}});
  bad[bad.size() - 2] = bad[bad.size() - 2] == '0' ? '1' : '0';
  f.dev.to_host += "\x01\x02noise" + bad + ee::encode_raw(2, "901,IR,77") + ee::encode({902, ee::IrSample{78}});
  f.run.run_for(100 * kMilli);
  EXPECT_EQ(counter(*f.node, "garbage_bytes"), 7);
  EXPECT_EQ(counter(*f.node, "bad_checksum"), 1);
  EXPECT_EQ(counter(*f.node, "unknown_version"), 1);
  const auto ir = f.run.messages<ir_range_t>("IR_RANGE");
  int n77 = 0, n78 = 0;
  for (const auto& m : ir) n77 += m.raw == 77, n78 += m.raw == 78;
  EXPECT_EQ(n77, 0);
  EXPECT_EQ(n78, 1);
  EXPECT_EQ(f.node->health(), rt::Health::kOk);
}

TEST(EeBridgeNode, SilenceReportSaysWhatArrivedInsteadOfTelemetry) {
  Fixture f;
  f.start();
  f.run.run_for(100 * kMilli);
  f.dev.board.set_silent(true);
  // A board of another protocol version: intact lines, none of them usable.
  f.dev.to_host += "~~" + ee::encode_raw(2, "1,IR,300") + ee::encode_raw(2, "2,IR,300");
  f.run.run_for(300 * kMilli);
  EXPECT_EQ(f.node->health(), rt::Health::kDegraded);
  EXPECT_NE(
      f.node->health_message().find("(since then 2 bytes outside frames, 2 lines rejected, last: protocol version 2)"),
      std::string::npos)
      << f.node->health_message();
  EXPECT_EQ(counter(*f.node, "unknown_version"), 2);
}

TEST(EeBridgeNode, ConnectThatNeverCompletesTimesOut) {
  Fixture f;
  f.dev.hang_connect = true;
  f.start();
  f.run.run_for(1200 * kMilli);
  EXPECT_EQ(f.node->health(), rt::Health::kError);
  EXPECT_NE(f.node->health_message().find("connect timed out"), std::string::npos) << f.node->health_message();
  ASSERT_EQ(f.dev.open_attempts.size(), 2u);               // at 0, and again 100 ms after the 1 s timeout
  EXPECT_EQ(f.dev.open_attempts[1] - kT0, 1110 * kMilli);  // timed out at the first 10 ms tick past 1 s
}

TEST(EeBridgeConfig, ReadsTimingCurveAndChannelsAndRejectsInconsistentTimeouts) {
  auto doc = harvest::config::Document::load_string(
      "link: {transport: tcp, tcp: {host: 127.0.0.1, port: 4555}}\n"
      "silence_timeout_s: 0.3\nreconnect_after_silence_s: 2\nbackoff_initial_s: 0.05\n"
      "channels: {ir_range: IR_LEFT}\n"
      "authority: {key: sim, controller: servo-controller}\n");
  const auto c = ee::BridgeConfig::from_config(doc.root());
  EXPECT_EQ(c.silence_timeout, 300 * kMilli);
  EXPECT_EQ(c.reconnect_after_silence, 2 * kSecond);
  EXPECT_EQ(c.backoff_initial, 50 * kMilli);
  EXPECT_EQ(c.ir_channel, "IR_LEFT");
  EXPECT_EQ(c.state_channel, "GRIPPER_STATE");
  EXPECT_EQ(c.make_link()->describe(), "tcp:127.0.0.1:4555");

  auto bad = harvest::config::Document::load_string(
      "link: {transport: tcp}\nsilence_timeout_s: 0.5\nreconnect_after_silence_s: 0.2\n"
      "authority: {key: sim, controller: servo-controller}\n");
  try {
    ee::BridgeConfig::from_config(bad.root());
    FAIL() << "accepted reconnect_after_silence_s < silence_timeout_s";
  } catch (const harvest::config::Error& e) {
    EXPECT_NE(std::string(e.what()).find("reconnect_after_silence_s"), std::string::npos) << e.what();
  }
}

TEST(EeBridgeConfig, ShippedConfigurationsLoadWithTheirCalibration) {
  for (const char* file : {"config/endeffector/ee-bridge.yaml", "config/endeffector/ee-bridge-serial.yaml"}) {
    auto doc = harvest::config::Document::load_file(file);
    const auto c = ee::BridgeConfig::from_config(doc.root());
    EXPECT_NO_THROW(doc.check_unused()) << file;
    EXPECT_GT(c.ir_curve.knots().size(), 5u) << file;
    // The fitted curve maps the raw value measured at 100 mm to about 100 mm.
    EXPECT_NEAR(c.ir_curve.evaluate(249.6).distance_m, 0.100, 0.01) << file;
  }
}
