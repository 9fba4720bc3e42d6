// harvest-ee-bridge as its own process, on its shipped configuration, over
// real LCM, against the board emulator served on a free TCP port from a
// thread of this test (the device double, as the simulator serves it):
// IR at the board's rate, gripper commands round-tripping to GRIPPER_STATE,
// the device closing mid-frame, vanishing and coming back, going silent and
// recovering, and a serial port that does not exist. Every wait is an
// "eventually" on what arrives on the bus; nothing asserts on wall time.
#include <gtest/gtest.h>

#include <atomic>
#include <harvest/gripper_command_t.hpp>
#include <harvest/gripper_state_t.hpp>
#include <harvest/ir_range_t.hpp>
#include <harvest/process_status_t.hpp>
#include <iostream>
#include <lcm/lcm-cpp.hpp>
#include <mutex>
#include <thread>

#include "endeffector/board_emulator.hpp"
#include "endeffector/board_server.hpp"
#include "runtime/clock.hpp"
#include "signing.hpp"
#include "test_support.hpp"

using namespace harvest;
namespace ee = harvest::endeffector;
namespace ht = harvest::testing;
using namespace std::chrono_literals;

namespace {

constexpr int8_t kIrValid = ir_range_t::VALID;
constexpr int8_t kIrNoData = ir_range_t::NO_DATA;
constexpr int8_t kGsHolding = gripper_state_t::STATE_HOLDING;
constexpr int8_t kGsOpen = gripper_state_t::STATE_OPEN;
constexpr int8_t kGsDisconnected = gripper_state_t::STATE_DISCONNECTED;
constexpr int8_t kPsOk = process_status_t::STATE_OK;
constexpr int8_t kPsDegraded = process_status_t::STATE_DEGRADED;
constexpr int8_t kPsError = process_status_t::STATE_ERROR;
constexpr int32_t kRaw = 249;  // about 0.10 m on the shipped calibration

// Gripper physics of the default emulator, with every command recorded.
class RecordingGripper final : public ee::GripperModel {
 public:
  explicit RecordingGripper(std::vector<ee::GripperGoal>& goals) : goals_(goals) {
    inner_.set_object_position(0.4);  // a fruit between the fingers stops them at 40 %
  }
  void command(const ee::GripperGoal& goal, rt::Micros now) override {
    goals_.push_back(goal);
    inner_.command(goal, now);
  }
  ee::GripperReading read(rt::Micros now) override { return inner_.read(now); }

 private:
  ee::LinearGripper inner_{0.3, 10.0};
  std::vector<ee::GripperGoal>& goals_;
};

// The board emulator behind a TCP server, serviced every millisecond in its own
// thread. Every access from the test goes through the mutex.
class DeviceDouble {
 public:
  DeviceDouble() {
    board_.set_ir_source([this](rt::Micros) {
      ++ir_samples_;
      return kRaw;
    });
    board_.set_gripper(std::make_unique<RecordingGripper>(goals_));
    server_ = std::make_unique<ee::BoardServer>(board_, "127.0.0.1", 0);
    port_ = server_->port();
    thread_ = std::thread([this] {
      while (!stop_) {
        {
          std::lock_guard<std::mutex> lock(mutex_);
          if (server_) server_->service(rt::wall_time_now());
        }
        std::this_thread::sleep_for(1ms);
      }
    });
  }
  ~DeviceDouble() {
    stop_ = true;
    thread_.join();
  }
  int port() const { return port_; }
  template <class F>
  auto with(F f) {
    std::lock_guard<std::mutex> lock(mutex_);
    return f(board_, server_);
  }
  int64_t ir_samples() {
    std::lock_guard<std::mutex> lock(mutex_);
    return ir_samples_;
  }
  std::vector<ee::GripperGoal> goals() {
    std::lock_guard<std::mutex> lock(mutex_);
    return goals_;
  }
  int64_t connections() {
    std::lock_guard<std::mutex> lock(mutex_);
    return connections_before_ + (server_ ? server_->connections() : 0);
  }
  // The device vanishes: nothing listens on the port any more.
  void unplug() {
    std::lock_guard<std::mutex> lock(mutex_);
    connections_before_ += server_->connections();
    server_.reset();
  }
  void plug_in() {
    std::lock_guard<std::mutex> lock(mutex_);
    server_ = std::make_unique<ee::BoardServer>(board_, "127.0.0.1", port_);
  }

 private:
  std::mutex mutex_;
  ee::BoardEmulator board_;
  std::vector<ee::GripperGoal> goals_;
  std::unique_ptr<ee::BoardServer> server_;
  int port_ = 0;
  int64_t ir_samples_ = 0;
  int64_t connections_before_ = 0;
  std::atomic<bool> stop_{false};
  std::thread thread_;
};

// Everything the bridge publishes, decoded, with the order of arrival.
class Bus {
 public:
  explicit Bus(const std::string& url) : lcm_(url) {
    lcm_.subscribe("IR_RANGE", &Bus::on_ir, this);
    lcm_.subscribe("GRIPPER_STATE", &Bus::on_state, this);
    lcm_.subscribe("PROCESS_STATUS", &Bus::on_status, this);
    thread_ = std::thread([this] {
      while (!stop_) lcm_.handleTimeout(20);
    });
  }
  ~Bus() {
    stop_ = true;
    thread_.join();
  }
  std::vector<ir_range_t> ir() {
    std::lock_guard<std::mutex> lock(mutex_);
    return ir_;
  }
  std::vector<gripper_state_t> states() {
    std::lock_guard<std::mutex> lock(mutex_);
    return states_;
  }
  std::vector<process_status_t> statuses() {
    std::lock_guard<std::mutex> lock(mutex_);
    return statuses_;
  }
  std::size_t ir_count() {
    std::lock_guard<std::mutex> lock(mutex_);
    return ir_.size();
  }
  std::size_t status_count() {
    std::lock_guard<std::mutex> lock(mutex_);
    return statuses_.size();
  }
  void publish(const gripper_command_t& c) {
    const auto signed_c = harvest::testing::as_sent_by_its_sender(c);
    lcm_.publish("GRIPPER_COMMAND", &signed_c);
  }

 private:
  void on_ir(const lcm::ReceiveBuffer*, const std::string&, const ir_range_t* m) {
    std::lock_guard<std::mutex> lock(mutex_);
    ir_.push_back(*m);
  }
  void on_state(const lcm::ReceiveBuffer*, const std::string&, const gripper_state_t* m) {
    std::lock_guard<std::mutex> lock(mutex_);
    states_.push_back(*m);
  }
  void on_status(const lcm::ReceiveBuffer*, const std::string&, const process_status_t* m) {
    std::lock_guard<std::mutex> lock(mutex_);
    statuses_.push_back(*m);
  }
  lcm::LCM lcm_;
  std::mutex mutex_;
  std::vector<ir_range_t> ir_;
  std::vector<gripper_state_t> states_;
  std::vector<process_status_t> statuses_;
  std::atomic<bool> stop_{false};
  std::thread thread_;
};

int64_t counter(const process_status_t& s, const std::string& name) {
  for (int i = 0; i < s.num_counters; ++i)
    if (s.counter_names[i] == name) return s.counter_values[i];
  return 0;
}

template <class T, class Pred>
bool any_since(const std::vector<T>& v, std::size_t from, Pred p) {
  for (std::size_t i = from; i < v.size(); ++i)
    if (p(v[i])) return true;
  return false;
}

std::unique_ptr<ht::ChildProcess> start_bridge(const std::string& url, const ht::TempDir& dir,
                                               const std::vector<std::string>& sets) {
  std::vector<std::string> argv{ht::bin("harvest-ee-bridge"), "--config",
                                ht::source_path("config/endeffector/ee-bridge.yaml"), "--lcm-url", url};
  for (const auto& s : sets) {
    argv.push_back("--set");
    argv.push_back(s);
  }
  return std::make_unique<ht::ChildProcess>(argv, dir / "bridge.txt");
}

gripper_command_t command(int8_t action, float force_n) {
  gripper_command_t c{};
  c.action = action;
  c.force_n = force_n;
  c.position = 0;
  c.header.source_seq = -1;
  return c;
}

}  // namespace

TEST(EeBridgeProcess, StreamsEveryIrSampleAndRoundTripsGripperCommands) {
  const std::string url = ht::unique_lcm_url();
  ht::TempDir dir;
  DeviceDouble dev;
  Bus bus(url);
  auto bridge = start_bridge(url, dir, {"link.tcp.port=" + std::to_string(dev.port())});

  // IR through the shipped calibration: 249 counts is about 0.10 m.
  ASSERT_TRUE(ht::eventually([&] { return bus.ir_count() >= 150; }, 15s)) << bridge->output();
  const auto first = bus.ir();
  ASSERT_EQ(first.back().validity, kIrValid) << bridge->output();
  EXPECT_EQ(first.back().raw, kRaw);
  EXPECT_NEAR(first.back().range_m, 0.100, 0.005);

  // Close on the fruit and open again; the board sees exactly these commands.
  ASSERT_TRUE(ht::eventually([&] { return !bus.states().empty() && bus.states().back().connected; }, 5s));
  bus.publish(command(gripper_command_t::ACTION_CLOSE, 6.5f));
  ASSERT_TRUE(ht::eventually([&] { return bus.states().back().state == kGsHolding; }, 10s)) << bridge->output();
  EXPECT_NEAR(bus.states().back().position, 0.4, 1e-3);
  EXPECT_NEAR(bus.states().back().force_n, 6.5, 1e-3);
  bus.publish(command(gripper_command_t::ACTION_OPEN, 0));
  ASSERT_TRUE(ht::eventually([&] { return bus.states().back().state == kGsOpen; }, 10s)) << bridge->output();
  EXPECT_NEAR(bus.states().back().position, 1.0, 1e-3);
  const auto goals = dev.goals();
  ASSERT_EQ(goals.size(), 2u);
  EXPECT_EQ(goals[0].kind, ee::GripperGoal::Kind::kClose);
  EXPECT_NEAR(goals[0].force_n, 6.5, 1e-9);
  EXPECT_EQ(goals[1].kind, ee::GripperGoal::Kind::kOpen);

  // Quiet the board, then every IR sample it sent must have arrived as one valid IR_RANGE.
  dev.with([](ee::BoardEmulator& b, auto&) {
    b.set_silent(true);
    return 0;
  });
  const int64_t sent = dev.ir_samples();
  const auto valid = [&] {
    int64_t n = 0;
    for (const auto& m : bus.ir()) n += m.validity == kIrValid;
    return n;
  };
  EXPECT_TRUE(ht::eventually([&] { return valid() == sent; }, 5s)) << valid() << " of " << sent;
  // The board's rate (100 Hz) survives the trip: stamps of the valid samples, >= 50 Hz.
  std::vector<int64_t> t;
  for (const auto& m : bus.ir())
    if (m.validity == kIrValid) t.push_back(m.header.utime);
  ASSERT_GE(t.size(), 150u);
  const double hz = static_cast<double>(t.size() - 1) / rt::to_seconds(t.back() - t.front());
  EXPECT_GE(hz, 50.0) << t.size() << " samples";
  std::cout << "IR: " << sent << " samples sent by the board, " << valid() << " valid IR_RANGE received, " << hz
            << " Hz by their stamps\n";
  EXPECT_EQ(bridge->stop(), 0) << bridge->output();
}

TEST(EeBridgeProcess, DeviceClosingMidFrameVanishingAndComingBack) {
  const std::string url = ht::unique_lcm_url();
  ht::TempDir dir;
  DeviceDouble dev;
  Bus bus(url);
  auto bridge = start_bridge(url, dir, {"link.tcp.port=" + std::to_string(dev.port())});
  const std::string endpoint = "tcp:127.0.0.1:" + std::to_string(dev.port());
  ASSERT_TRUE(ht::eventually([&] { return bus.ir_count() >= 20; }, 15s)) << bridge->output();

  // 1. Half a frame, then the connection closes; the listener stays: the bridge reconnects at once.
  dev.with([](ee::BoardEmulator&, auto& server) {
    server->close_mid_frame(rt::wall_time_now());
    return 0;
  });
  ASSERT_TRUE(ht::eventually([&] { return dev.connections() >= 2; }, 5s)) << bridge->output();
  ASSERT_TRUE(ht::eventually(
      [&] {
        const auto s = bus.statuses();
        return !s.empty() && counter(s.back(), "disconnects") >= 1 && counter(s.back(), "truncated") >= 1 &&
               counter(s.back(), "connects") >= 2;
      },
      5s))
      << bridge->output();
  std::size_t mark = bus.ir_count();
  ASSERT_TRUE(ht::eventually([&] { return bus.ir_count() >= mark + 20; }, 5s));
  EXPECT_EQ(bus.ir().back().validity, kIrValid);

  // 2. The device vanishes: reported on PROCESS_STATUS and as NO_DATA, and the
  //    loop stays alive (heartbeats keep coming) while connects are refused.
  dev.unplug();
  const std::size_t status_mark = bus.status_count();
  mark = bus.ir_count();
  ASSERT_TRUE(ht::eventually(
      [&] {
        return any_since(bus.statuses(), status_mark, [&](const process_status_t& s) {
          return s.state == kPsError && s.message.find("no link to " + endpoint) != std::string::npos;
        });
      },
      10s))
      << bridge->output();
  EXPECT_TRUE(ht::eventually([&] { return bus.status_count() >= status_mark + 3; }, 10s));
  EXPECT_TRUE(any_since(bus.ir(), mark, [](const ir_range_t& m) { return m.validity == kIrNoData; }));
  EXPECT_TRUE(any_since(bus.states(), 0, [](const gripper_state_t& m) { return m.state == kGsDisconnected; }));
  EXPECT_TRUE(bridge->running());

  // 3. It comes back on the same port: the bridge finds it (back-off capped at 2 s) and resumes.
  dev.plug_in();
  mark = bus.ir_count();
  ASSERT_TRUE(ht::eventually(
      [&] { return any_since(bus.ir(), mark, [](const ir_range_t& m) { return m.validity == kIrValid; }); }, 10s))
      << bridge->output();
  const std::size_t back_mark = bus.status_count();
  EXPECT_TRUE(ht::eventually(
      [&] { return any_since(bus.statuses(), back_mark, [](const process_status_t& s) { return s.state == kPsOk; }); },
      5s))
      << bridge->output();
  EXPECT_EQ(bridge->stop(), 0) << bridge->output();
}

TEST(EeBridgeProcess, SilentDeviceIsReportedAndRecovers) {
  const std::string url = ht::unique_lcm_url();
  ht::TempDir dir;
  DeviceDouble dev;
  Bus bus(url);
  auto bridge = start_bridge(url, dir, {"link.tcp.port=" + std::to_string(dev.port())});
  ASSERT_TRUE(ht::eventually([&] { return bus.ir_count() >= 20; }, 15s)) << bridge->output();

  dev.with([](ee::BoardEmulator& b, auto&) {
    b.set_silent(true);  // the connection stays up, nothing comes out
    return 0;
  });
  std::size_t mark = bus.ir_count();
  const std::size_t status_mark = bus.status_count();
  ASSERT_TRUE(ht::eventually(
      [&] { return any_since(bus.ir(), mark, [](const ir_range_t& m) { return m.validity == kIrNoData; }); }, 5s))
      << bridge->output();
  // Reported on the heartbeat: degraded ("no telemetry") or, after 1 s, error ("board silent").
  ASSERT_TRUE(ht::eventually(
      [&] {
        const auto s = bus.statuses();
        return any_since(s, status_mark,
                         [](const process_status_t& p) {
                           return (p.state == kPsDegraded && p.message.find("no telemetry") != std::string::npos) ||
                                  (p.state == kPsError && p.message.find("board silent") != std::string::npos);
                         }) &&
               counter(s.back(), "silences") >= 1;
      },
      10s))
      << bridge->output();
  EXPECT_EQ(bus.states().back().state, kGsDisconnected);
  EXPECT_TRUE(ht::eventually([&] { return dev.connections() >= 2; }, 5s));  // dropped and reconnected

  dev.with([](ee::BoardEmulator& b, auto&) {
    b.set_silent(false);
    return 0;
  });
  mark = bus.ir_count();
  ASSERT_TRUE(ht::eventually([&] { return bus.ir_count() >= mark + 10 && bus.ir().back().validity == kIrValid; }, 10s))
      << bridge->output();
  const std::size_t back_mark = bus.status_count();
  EXPECT_TRUE(ht::eventually(
      [&] { return any_since(bus.statuses(), back_mark, [](const process_status_t& s) { return s.state == kPsOk; }); },
      5s))
      << bridge->output();
  EXPECT_EQ(bridge->stop(), 0) << bridge->output();
}

TEST(EeBridgeProcess, SerialPortThatDoesNotExistIsAClearRepeatedError) {
  const std::string url = ht::unique_lcm_url();
  ht::TempDir dir;
  Bus bus(url);
  auto bridge = start_bridge(url, dir, {"link.transport=serial", "link.serial.port=/dev/ttyNOPE"});
  ASSERT_TRUE(ht::eventually(
      [&] {
        return any_since(bus.statuses(), 0, [](const process_status_t& s) {
          return s.state == kPsError &&
                 s.message.find("serial port '/dev/ttyNOPE': no such device") != std::string::npos;
        });
      },
      10s))
      << bridge->output();
  // No crash: it keeps publishing NO_DATA and retrying.
  EXPECT_TRUE(ht::eventually([&] { return bus.ir_count() >= 5; }, 5s));
  for (const auto& m : bus.ir()) EXPECT_EQ(m.validity, kIrNoData);
  EXPECT_TRUE(bridge->running());
  EXPECT_EQ(bridge->stop(), 0);
  const std::string out = bridge->output();
  EXPECT_NE(out.find("serial port '/dev/ttyNOPE'"), std::string::npos) << out;
  for (const auto& s : bus.statuses())
    if (s.state == kPsError) std::cout << "PROCESS_STATUS message: " << s.message << "\n";
}
