// harvest-sim in hardware mode "devices" with the field's harvest-robot-link
// and harvest-ee-bridge as separate processes, each on its shipped
// configuration, over real LCM, a virtual CAN bus (udp_multicast) and TCP of
// their own: a twist moves the simulated tool (SIM_TRUTH) and the robot link
// sees the same motion through the drives; IR_RANGE from the bridge follows
// the true distance to the fruit ahead; a gripper command reaches the
// simulated gripper and its state comes back through the board.
#include <arpa/inet.h>
#include <gtest/gtest.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <Eigen/Core>
#include <atomic>
#include <filesystem>
#include <fstream>
#include <harvest/gripper_command_t.hpp>
#include <harvest/gripper_state_t.hpp>
#include <harvest/ir_range_t.hpp>
#include <harvest/robot_command_t.hpp>
#include <harvest/robot_state_t.hpp>
#include <harvest/sim_truth_t.hpp>
#include <lcm/lcm-cpp.hpp>
#include <mutex>
#include <optional>
#include <thread>

#include "runtime/channels.hpp"
#include "signing.hpp"
#include "sim/ports.hpp"
#include "test_support.hpp"

namespace ht = harvest::testing;
namespace ch = harvest::channels;
using harvest::gripper_state_t;
using harvest::ir_range_t;
using harvest::robot_state_t;
using harvest::sim_truth_t;
using namespace std::chrono_literals;

namespace {

Eigen::Vector3d position(const harvest::pose_t& p) { return {p.position[0], p.position[1], p.position[2]}; }

// One fruit 200 mm straight ahead of the start pose, no canopy: the IR sees
// the fruit, and nothing else is in the way. The arm's true mounting is 10 mm
// off along base x (the software believes it is at the origin).
constexpr const char* kScenario = R"(name: devices_test
seed: 7
time_limit_s: 600
fruit:
  - {position_mm: [-400, 900, -300], diameter_mm: 70}
cameras:
  fixed: {image_width: 160, image_height: 120, rate_hz: 10, noise_std: 1.0}
  hand: {image_width: 160, image_height: 120, rate_hz: 10, noise_std: 1.0}
  fixed_extrinsic_truth: {rotation: [0, 1, 0, 0, 0, 1, -1, 0, 0], translation_mm: [-241.3, 228.6, -400.5]}
arm:
  start_tool_position_mm: [-400, 700, -300]
  start_look_at_mm: [-400, 1000, -300]
  mounting_truth: {translation_mm: [10, 0, 0]}
ir: {noise_std: 1.0}
)";

class SimDevices : public ::testing::Test {
 protected:
  // Scenario text and whether SetUp waits for the robot to be ready.
  virtual std::string scenario() const { return kScenario; }
  virtual bool wait_ready() const { return true; }

  void SetUp() override {
    url_ = ht::unique_lcm_url();
    bus_ = ht::unique_can_bus();
    port_ = harvest::sim::free_port(false);
    ASSERT_GT(port_, 0);
    { std::ofstream(tmp_ / "scenario.yaml") << scenario(); }
    lcm_ = std::make_unique<lcm::LCM>(url_);
    ASSERT_TRUE(lcm_->good());
    lcm_->subscribe(ch::kRobotState, &SimDevices::on_state, this);
    lcm_->subscribe("SIM_TRUTH", &SimDevices::on_truth, this);
    lcm_->subscribe(ch::kIrRange, &SimDevices::on_ir, this);
    lcm_->subscribe(ch::kGripperState, &SimDevices::on_gripper, this);
    listener_ = std::thread([this] {
      while (!stop_) lcm_->handleTimeout(20);
    });

    const std::vector<std::string> common{"--lcm-url", url_, "--no-netcheck"};
    auto args = [&](std::vector<std::string> a) {
      a.insert(a.end(), common.begin(), common.end());
      return a;
    };
    sim_.emplace(args({ht::bin("harvest-sim"), "--config", ht::source_path("config/sim/sim-devices.yaml"), "--set",
                       "scenario=" + (tmp_ / "scenario.yaml").string(), "--set", "stop_when_done=false", "--set",
                       "devices.bus=" + bus_, "--set", "devices.board.port=" + std::to_string(port_)}),
                 tmp_ / "sim.log");
    ASSERT_TRUE(ht::eventually([&] { return truth().has_value(); }, 15s)) << outputs();
    // The drives' own 25 ms RPDO deadline would stop the arm when the shared,
    // loaded test machine stalls the link; these tests are about the devices.
    link_.emplace(
        args({ht::bin("harvest-robot-link"), "--config", ht::source_path("config/arm/robot_link.yaml"), "--set",
              "bus=" + bus_, "--set", "can.drive_rpdo_timeout_ms=200", "--set", "can.drive_heartbeat_timeout_ms=300"}),
        tmp_ / "robot-link.log");
    std::vector<std::string> bridge{ht::bin("harvest-ee-bridge"), "--config",
                                    ht::source_path("config/endeffector/ee-bridge.yaml"), "--set",
                                    "link.tcp.port=" + std::to_string(port_)};
    // The shipped bridge configuration names its IR calibration file; without
    // one the bridge uses its default curve.
    if (!std::filesystem::exists(ht::source_path("config/endeffector/ir_calibration.yaml"))) {
      bridge.push_back("--set");
      bridge.push_back("ir_calibration_file=\"\"");
    }
    bridge_.emplace(args(bridge), tmp_ / "ee-bridge.log");
    if (!wait_ready()) return;
    ASSERT_TRUE(ht::eventually(
        [&] {
          const auto s = latest(states_);
          return s && s->mode == robot_state_t::MODE_IDLE;
        },
        20s))
        << "the drives never became enabled\n"
        << outputs();
    ASSERT_TRUE(ht::eventually(
        [&] {
          const auto g = latest(grippers_);
          return g && g->connected && g->state == gripper_state_t::STATE_OPEN;
        },
        10s))
        << "the bridge never reached the board\n"
        << outputs();
  }

  void TearDown() override {
    stop_commands();
    for (auto* p : {&link_, &bridge_, &sim_}) {
      if (!*p) continue;
      const bool was_running = (*p)->running();
      const int rc = (*p)->stop(10s);
      if (was_running) {
        EXPECT_EQ(rc, 0) << outputs();
      }
    }
    stop_ = true;
    if (listener_.joinable()) listener_.join();
  }

  std::string outputs() const {
    std::string s;
    auto add = [&](const char* name, const std::optional<ht::ChildProcess>& p) {
      s += std::string("--- ") + name + ":\n" + (p ? p->output() : "");
    };
    add("sim", sim_);
    add("robot link", link_);
    add("ee bridge", bridge_);
    return s;
  }

  template <class T>
  std::optional<T> latest(const std::vector<T>& v) {
    std::lock_guard<std::mutex> lock(mutex_);
    if (v.empty()) return std::nullopt;
    return v.back();
  }
  std::optional<sim_truth_t> truth() { return latest(truths_); }
  template <class T>
  std::size_t count(const std::vector<T>& v) {
    std::lock_guard<std::mutex> lock(mutex_);
    return v.size();
  }
  template <class T>
  bool wait_for(const std::vector<T>& v, const std::function<bool(const T&)>& pred, std::chrono::milliseconds timeout,
                std::size_t from = 0) {
    return ht::eventually(
        [&] {
          std::lock_guard<std::mutex> lock(mutex_);
          for (std::size_t i = from; i < v.size(); ++i)
            if (pred(v[i])) return true;
          return false;
        },
        timeout);
  }

  void on_state(const lcm::ReceiveBuffer*, const std::string&, const robot_state_t* m) { add(states_, *m); }
  void on_truth(const lcm::ReceiveBuffer*, const std::string&, const sim_truth_t* m) { add(truths_, *m); }
  void on_ir(const lcm::ReceiveBuffer*, const std::string&, const ir_range_t* m) { add(irs_, *m); }
  void on_gripper(const lcm::ReceiveBuffer*, const std::string&, const gripper_state_t* m) { add(grippers_, *m); }
  template <class T>
  void add(std::vector<T>& v, const T& m) {
    std::lock_guard<std::mutex> lock(mutex_);
    v.push_back(m);
  }

  template <class Msg>
  void send(const std::string& channel, const Msg& m) {
    std::lock_guard<std::mutex> lock(send_mutex_);
    const Msg signed_msg = harvest::testing::as_sent_by_its_sender(m);
    lcm_->publish(channel, &signed_msg);
  }

  void start_twist(double vx, double vy, double vz) {
    stop_commands();
    commanding_ = true;
    commander_ = std::thread([this, vx, vy, vz] {
      harvest::robot_command_t c{};
      c.type = harvest::robot_command_t::TYPE_TWIST;
      c.validity_us = 100'000;
      c.twist.linear[0] = vx;
      c.twist.linear[1] = vy;
      c.twist.linear[2] = vz;
      int64_t seq = 0;
      while (commanding_) {
        c.header.seq = seq++;
        send(ch::kRobotCommand, c);
        std::this_thread::sleep_for(20ms);
      }
    });
  }
  void stop_commands() {
    commanding_ = false;
    if (commander_.joinable()) commander_.join();
  }

  // Mean over the IR readings published after `from` (at least n of them).
  std::optional<double> mean_ir(std::size_t from, std::size_t n) {
    if (!ht::eventually([&] { return count(irs_) >= from + n; }, 5s)) return std::nullopt;
    std::lock_guard<std::mutex> lock(mutex_);
    double sum = 0;
    for (std::size_t i = from; i < from + n; ++i) {
      if (irs_[i].validity != ir_range_t::VALID) return std::nullopt;
      sum += irs_[i].range_m;
    }
    return sum / static_cast<double>(n);
  }

  // A truth snapshot and robot state taken with the arm at rest.
  struct AtRest {
    sim_truth_t truth;
    robot_state_t state;
  };
  std::optional<AtRest> at_rest() {
    const std::size_t s0 = count(states_);
    if (!wait_for<robot_state_t>(
            states_, [](const robot_state_t& s) { return s.mode == robot_state_t::MODE_IDLE; }, 10s, s0))
      return std::nullopt;
    const std::size_t t0 = count(truths_);
    if (!ht::eventually([&] { return count(truths_) > t0 + 1; }, 5s)) return std::nullopt;
    return AtRest{*truth(), *latest(states_)};
  }

  ht::TempDir tmp_;
  std::string url_, bus_;
  int port_ = 0;
  std::unique_ptr<lcm::LCM> lcm_;
  std::thread listener_, commander_;
  std::atomic<bool> stop_{false}, commanding_{false};
  std::mutex mutex_, send_mutex_;
  std::vector<robot_state_t> states_;
  std::vector<sim_truth_t> truths_;
  std::vector<ir_range_t> irs_;
  std::vector<gripper_state_t> grippers_;
  std::optional<ht::ChildProcess> sim_, link_, bridge_;
};

TEST_F(SimDevices, TwistMovesTheSimulatedToolIrFollowsTheSceneAndTheGripperCloses) {
  // At the start: the true tool is at the scenario's start pose; the robot
  // link, which believes the arm sits at the origin, sees it 10 mm off.
  const auto a = at_rest();
  ASSERT_TRUE(a) << outputs();
  const Eigen::Vector3d start(-0.400, 0.700, -0.300);
  EXPECT_LT((position(a->truth.tool_pose) - start).norm(), 1e-3) << position(a->truth.tool_pose).transpose();
  const Eigen::Vector3d mount = position(a->truth.tool_pose) - position(a->state.tool_pose);
  EXPECT_LT((mount - Eigen::Vector3d(0.010, 0, 0)).norm(), 1e-3) << mount.transpose();

  // IR: the bridge's range (its calibration of the board's raw counts) is the
  // true distance from the sensor to the fruit ahead.
  const double true_before = a->truth.ir_true_range_m;
  ASSERT_GT(true_before, 0.1) << "the fruit must be in the sensor's view";
  const auto ir_before = mean_ir(count(irs_), 20);
  ASSERT_TRUE(ir_before) << "IR not valid with a fruit ahead\n" << outputs();
  EXPECT_NEAR(*ir_before, true_before, 0.01);

  // A twist towards the fruit (base +y) until the true tool has moved 50 mm.
  start_twist(0.0, 0.05, 0.0);
  const double y0 = position(a->truth.tool_pose).y();
  ASSERT_TRUE(ht::eventually([&] { return position(truth()->tool_pose).y() > y0 + 0.05; }, 10s)) << outputs();
  stop_commands();
  const auto b = at_rest();
  ASSERT_TRUE(b) << outputs();
  const Eigen::Vector3d moved = position(b->truth.tool_pose) - position(a->truth.tool_pose);
  EXPECT_GT(moved.y(), 0.05);
  EXPECT_LT(std::hypot(moved.x(), moved.z()), 0.1 * moved.y()) << moved.transpose();
  // The robot link saw the same motion through the drives.
  const Eigen::Vector3d seen = position(b->state.tool_pose) - position(a->state.tool_pose);
  EXPECT_LT((seen - moved).norm(), 1e-3) << seen.transpose() << " vs " << moved.transpose();
  // Nearer the fruit: the true range shrank by the motion and the IR follows.
  EXPECT_NEAR(b->truth.ir_true_range_m, true_before - moved.y(), 2e-3);
  const auto ir_after = mean_ir(count(irs_), 20);
  ASSERT_TRUE(ir_after) << outputs();
  EXPECT_NEAR(*ir_after, b->truth.ir_true_range_m, 0.01);
  EXPECT_LT(*ir_after, *ir_before - 0.03);

  // The gripper: a close command goes bridge -> board -> simulated fingers.
  const std::size_t g0 = count(grippers_);
  harvest::gripper_command_t close{};
  close.action = harvest::gripper_command_t::ACTION_CLOSE;
  close.force_n = 12.0f;
  send(ch::kGripperCommand, close);
  ASSERT_TRUE(wait_for<gripper_state_t>(
      grippers_, [](const gripper_state_t& g) { return g.state == gripper_state_t::STATE_CLOSING; }, 5s, g0))
      << outputs();
  // Nothing between the fingers (the fruit is 150 mm ahead): closed on nothing.
  ASSERT_TRUE(wait_for<gripper_state_t>(
      grippers_, [](const gripper_state_t& g) { return g.state == gripper_state_t::STATE_CLOSED; }, 5s, g0))
      << outputs();
  const std::size_t t0 = count(truths_);
  ASSERT_TRUE(ht::eventually([&] { return count(truths_) > t0 + 1; }, 5s));
  const sim_truth_t closed = *truth();
  EXPECT_EQ(closed.gripper_opening, 0.0f);
  ASSERT_EQ(closed.num_fruits, 1);
  EXPECT_EQ(closed.fruits[0].state, 0) << "still on the tree";
  EXPECT_EQ(closed.fruits[0].grasp_attempts, 0);
}

// Faults from the scenario: a drive and the board fall silent a few seconds
// into the run; the field processes notice it as they would on the robot.
class SimDeviceFaults : public SimDevices {
 protected:
  std::string scenario() const override {
    return std::string(kScenario) +
           "faults: {drive_fault_joint: 3, drive_silent_start_s: 8, board_silent_start_s: 8}\n";
  }
  bool wait_ready() const override { return false; }
};

TEST_F(SimDeviceFaults, SilentDriveAndBoardFromTheScenarioAreSeenByRobotLinkAndBridge) {
  constexpr int32_t kFlagHeartbeatLost = 1 << 2, kFlagPdoLost = 1 << 3;
  ASSERT_TRUE(wait_for<robot_state_t>(
      states_,
      [](const robot_state_t& s) {
        return s.mode == robot_state_t::MODE_FAULT && (s.fault_flags & (kFlagHeartbeatLost | kFlagPdoLost)) &&
               s.fault_text.find("joint 3") != std::string::npos;
      },
      30s))
      << (latest(states_) ? latest(states_)->fault_text : "no robot state") << "\n"
      << outputs();
  ASSERT_TRUE(wait_for<ir_range_t>(
      irs_, [](const ir_range_t& m) { return m.validity == ir_range_t::NO_DATA; }, 30s))
      << outputs();
  ASSERT_TRUE(wait_for<gripper_state_t>(
      grippers_, [](const gripper_state_t& g) { return !g.connected; }, 30s))
      << outputs();
  // Before the faults the board was talking: there were real readings.
  EXPECT_TRUE(wait_for<ir_range_t>(
      irs_, [](const ir_range_t& m) { return m.validity == ir_range_t::VALID && m.raw > 0; }, 1s));
  EXPECT_NE(sim_->output().find("fault injection: joint 3 drive silent"), std::string::npos) << outputs();
}

// Two runs on one machine must not share the virtual CAN bus or the board's
// port (their drives would answer each other's link, their bridges each
// other's board): a simulator finding either taken refuses to start and says
// which, and how to give it its own.
TEST(SimPorts, ABusOrBoardPortAnotherRunHoldsIsRefusedClearly) {
  ht::TempDir tmp;
  { std::ofstream(tmp / "scenario.yaml") << kScenario; }
  const auto start_sim = [&](const std::string& bus, int port, const std::string& out) {
    ht::ChildProcess sim(
        {ht::bin("harvest-sim"), "--config", ht::source_path("config/sim/sim-devices.yaml"), "--set",
         "scenario=" + (tmp / "scenario.yaml").string(), "--set", "devices.bus=" + bus, "--set",
         "devices.board.port=" + std::to_string(port), "--lcm-url", ht::unique_lcm_url(), "--no-netcheck"},
        tmp / out);
    const int code = sim.wait(30s);
    return std::make_pair(code, sim.output());
  };
  // Another run's bus: a socket on its UDP port, bound as the virtual CAN bus binds (SO_REUSEADDR).
  const int udp = ::socket(AF_INET, SOCK_DGRAM, 0);
  const int one = 1;
  ::setsockopt(udp, SOL_SOCKET, SO_REUSEADDR, &one, sizeof one);
  sockaddr_in a{};
  a.sin_family = AF_INET;
  a.sin_addr.s_addr = htonl(INADDR_ANY);
  socklen_t len = sizeof a;
  ASSERT_EQ(::bind(udp, reinterpret_cast<sockaddr*>(&a), sizeof a), 0);
  ASSERT_EQ(::getsockname(udp, reinterpret_cast<sockaddr*>(&a), &len), 0);
  const int bus_port = ntohs(a.sin_port);
  EXPECT_FALSE(harvest::sim::port_free(bus_port, true));
  const std::string bus = "udp_multicast:239.74.164.9:" + std::to_string(bus_port) + "?ttl=0";
  const auto [bus_code, bus_out] = start_sim(bus, harvest::sim::free_port(false), "bus.log");
  EXPECT_NE(bus_code, 0) << bus_out;
  EXPECT_NE(bus_out.find("virtual CAN bus " + bus + ": UDP port " + std::to_string(bus_port) +
                         " is already in use on this machine"),
            std::string::npos)
      << bus_out;
  ::close(udp);
  EXPECT_TRUE(harvest::sim::port_free(bus_port, true));

  // Another run's board: a listener on its TCP port.
  const int tcp = ::socket(AF_INET, SOCK_STREAM, 0);
  a.sin_port = 0;
  a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  len = sizeof a;
  ASSERT_EQ(::bind(tcp, reinterpret_cast<sockaddr*>(&a), sizeof a), 0);
  ASSERT_EQ(::listen(tcp, 1), 0);
  ASSERT_EQ(::getsockname(tcp, reinterpret_cast<sockaddr*>(&a), &len), 0);
  const int board_port = ntohs(a.sin_port);
  const auto [board_code, board_out] = start_sim(ht::unique_can_bus(), board_port, "board.log");
  EXPECT_NE(board_code, 0) << board_out;
  EXPECT_NE(board_out.find("board server 127.0.0.1:" + std::to_string(board_port) +
                           ": Address already in use: another simulator (or ser2net) holds the port"),
            std::string::npos)
      << board_out;
  ::close(tcp);
}

}  // namespace
