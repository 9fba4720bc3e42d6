// harvest-robot-link and harvest-sim-drives as separate processes on the
// python-can compatible udp_multicast virtual CAN bus, over real LCM: a twist
// moves the tool at the commanded velocity; the watchdog, a drive fault, a
// lost heartbeat and an emergency stop each stop the arm; both processes
// start, run and stop cleanly; a pose goal out of reach is refused without
// disturbing the SYNC rate while its IK runs.
#include <gtest/gtest.h>
#include <unistd.h>

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <atomic>
#include <harvest/emergency_stop_t.hpp>
#include <harvest/operator_command_t.hpp>
#include <harvest/process_status_t.hpp>
#include <harvest/robot_command_t.hpp>
#include <harvest/robot_state_t.hpp>
#include <harvest/sim_drive_fault_t.hpp>
#include <lcm/lcm-cpp.hpp>
#include <map>
#include <mutex>
#include <optional>
#include <thread>

#include "runtime/channels.hpp"
#include "signing.hpp"
#include "test_support.hpp"

namespace ht = harvest::testing;
namespace ch = harvest::channels;
using harvest::robot_state_t;
using namespace std::chrono_literals;

namespace {

constexpr int32_t kFlagDriveFault = 1 << 0, kFlagEmcy = 1 << 1, kFlagHeartbeatLost = 1 << 2, kFlagPdoLost = 1 << 3,
                  kFlagEstop = 1 << 4, kFlagCommandStale = 1 << 5, kFlagRefused = 1 << 7, kFlagForeign = 1 << 10;

Eigen::Vector3d tool_position(const robot_state_t& s) {
  return {s.tool_pose.position[0], s.tool_pose.position[1], s.tool_pose.position[2]};
}

class ArmProcesses : public ::testing::Test {
 protected:
  void SetUp() override {
    url_ = ht::unique_lcm_url();
    bus_ = ht::unique_can_bus();
    lcm_ = std::make_unique<lcm::LCM>(url_);
    ASSERT_TRUE(lcm_->good());
    lcm_->subscribe(ch::kRobotState, &ArmProcesses::on_state, this);
    listener_ = std::thread([this] {
      while (!stop_) lcm_->handleTimeout(20);
    });
    drives_.emplace(std::vector<std::string>{ht::bin("harvest-sim-drives"), "--config",
                                             ht::source_path("config/arm/sim_drives.yaml"), "--set", "bus=" + bus_,
                                             "--lcm-url", url_, "--no-netcheck"},
                    tmp_ / "sim-drives.log");
    link_.emplace(
        std::vector<std::string>{ht::bin("harvest-robot-link"), "--config",
                                 ht::source_path("config/arm/robot_link.yaml"), "--set", "bus=" + bus_,
                                 // Two processes per test, several tests at once on a shared
                                 // 2-core CI machine: a PDO gap of 100 ms (the shipped watchdog,
                                 // tested on a manual clock in arm_test) happens there without
                                 // any fault. These tests are about the stop paths. So
                                 // would the drives' own 25 ms RPDO deadline, tested on a
                                 // manual clock and by robot_link_kill_test.
                                 "--set", "can.pdo_timeout_ms=300", "--set", "can.drive_rpdo_timeout_ms=200", "--set",
                                 "can.drive_heartbeat_timeout_ms=300", "--lcm-url", url_, "--no-netcheck"},
        tmp_ / "robot-link.log");
    ASSERT_TRUE(wait_for([](const robot_state_t& s) { return s.mode == +robot_state_t::MODE_IDLE; }, 15s))
        << "the drives never became enabled\n"
        << outputs();
  }

  void TearDown() override {
    stop_commands();
    // Robot link first (it stops and disables the drives), then the drives.
    if (link_) {
      const bool was_running = link_->running();
      const int rc = link_->stop(10s);
      if (was_running) {
        EXPECT_EQ(rc, 0) << outputs();
        EXPECT_NE(link_->output().find("disabling the drives"), std::string::npos) << outputs();
      }
    }
    if (drives_) {
      const bool was_running = drives_->running();
      const int rc = drives_->stop(10s);
      if (was_running) {
        EXPECT_EQ(rc, 0) << outputs();
      }
    }
    stop_ = true;
    if (listener_.joinable()) listener_.join();
  }

  std::string outputs() const {
    return "--- robot link:\n" + (link_ ? link_->output() : "") + "--- sim drives:\n" +
           (drives_ ? drives_->output() : "");
  }

  void on_state(const lcm::ReceiveBuffer*, const std::string&, const robot_state_t* s) {
    std::lock_guard<std::mutex> lock(mutex_);
    states_.push_back(*s);
  }

  std::optional<robot_state_t> latest() {
    std::lock_guard<std::mutex> lock(mutex_);
    if (states_.empty()) return std::nullopt;
    return states_.back();
  }
  std::size_t count() {
    std::lock_guard<std::mutex> lock(mutex_);
    return states_.size();
  }
  // The first state published after `index` that satisfies pred.
  bool wait_for(const std::function<bool(const robot_state_t&)>& pred, std::chrono::milliseconds timeout,
                std::size_t from = 0) {
    return ht::eventually(
        [&] {
          std::lock_guard<std::mutex> lock(mutex_);
          for (std::size_t i = from; i < states_.size(); ++i)
            if (pred(states_[i])) return true;
          return false;
        },
        timeout);
  }

  template <class Msg>
  void send(const std::string& channel, const Msg& m) {
    std::lock_guard<std::mutex> lock(send_mutex_);
    const Msg signed_msg = harvest::testing::as_sent_by_its_sender(m);
    lcm_->publish(channel, &signed_msg);
  }

  // Sends a twist every 20 ms from a thread, as the servo controller does.
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

  void inject(int8_t kind, int32_t joint, int32_t error_code = 0) {
    harvest::sim_drive_fault_t f{};
    f.kind = kind;
    f.joint = joint;
    f.error_code = error_code;
    send("SIM_DRIVE_FAULT", f);
  }

  // Moving, then `stop_it`; checks the arm stops (commanded and measured joint
  // velocities zero, tool still) with `flag` set and `mode`.
  void expect_stop(const std::function<void()>& stop_it, int32_t flag, int8_t mode) {
    start_twist(0.0, 0.05, 0.05);
    ASSERT_TRUE(wait_for([](const robot_state_t& s) { return s.mode == +robot_state_t::MODE_MOVING; }, 5s))
        << outputs();
    std::this_thread::sleep_for(300ms);
    const std::size_t from = count();
    stop_it();
    ASSERT_TRUE(wait_for([&](const robot_state_t& s) { return (s.fault_flags & flag) && s.mode == mode; }, 5s, from))
        << latest()->fault_text << "\n"
        << outputs();
    // The commands keep coming; the arm must come to rest and stay there.
    ASSERT_TRUE(wait_for(
        [&](const robot_state_t& s) {
          return Eigen::Map<const Eigen::VectorXd>(s.joint_velocity.data(), s.num_joints).norm() < 1e-6 &&
                 Eigen::Map<const Eigen::VectorXd>(s.joint_velocity_cmd.data(), s.num_joints).norm() == 0.0;
        },
        5s, from))
        << outputs();
    const robot_state_t a = *latest();
    std::this_thread::sleep_for(300ms);
    const robot_state_t b = *latest();
    EXPECT_GT(b.header.seq, a.header.seq) << "still publishing";
    EXPECT_EQ(b.mode, mode) << b.fault_text;
    EXPECT_TRUE(b.fault_flags & flag) << b.fault_text;
    EXPECT_LT((tool_position(b) - tool_position(a)).norm(), 1e-6);
    for (int j = 0; j < b.num_joints; ++j) {
      EXPECT_EQ(b.joint_velocity_cmd[j], 0.0);
      EXPECT_LT(std::abs(b.joint_velocity[j]), 1e-6);
    }
  }

  ht::TempDir tmp_;
  std::string url_, bus_;
  std::unique_ptr<lcm::LCM> lcm_;
  std::thread listener_, commander_;
  std::atomic<bool> stop_{false}, commanding_{false};
  std::mutex mutex_, send_mutex_;
  std::vector<robot_state_t> states_;
  std::optional<ht::ChildProcess> drives_, link_;
};

TEST_F(ArmProcesses, TwistMovesTheToolAtTheCommandedVelocityAndTheWatchdogStopsIt) {
  const Eigen::Vector3d v(0.04, 0.03, -0.05);
  start_twist(v.x(), v.y(), v.z());
  ASSERT_TRUE(wait_for([](const robot_state_t& s) { return s.mode == +robot_state_t::MODE_MOVING; }, 5s)) << outputs();
  std::this_thread::sleep_for(300ms);
  const robot_state_t a = *latest();
  std::this_thread::sleep_for(1000ms);
  const robot_state_t b = *latest();
  ASSERT_EQ(b.mode, +robot_state_t::MODE_MOVING) << b.fault_text;
  const Eigen::Vector3d measured =
      (tool_position(b) - tool_position(a)) / (static_cast<double>(b.header.utime - a.header.utime) * 1e-6);
  EXPECT_LT((measured - v).norm(), 0.05 * v.norm()) << "measured " << measured.transpose();
  EXPECT_EQ(b.fault_flags, 0) << b.fault_text;

  // The controller goes quiet: a controlled stop after the 100 ms validity.
  const std::size_t from = count();
  stop_commands();
  ASSERT_TRUE(
      wait_for([](const robot_state_t& s) { return s.command_stale && (s.fault_flags & kFlagCommandStale); }, 3s, from))
      << outputs();
  ASSERT_TRUE(wait_for([](const robot_state_t& s) { return s.mode == +robot_state_t::MODE_IDLE; }, 3s, from))
      << outputs();
  const robot_state_t c = *latest();
  std::this_thread::sleep_for(300ms);
  const robot_state_t d = *latest();
  EXPECT_LT((tool_position(d) - tool_position(c)).norm(), 1e-6);
  EXPECT_EQ(d.mode, +robot_state_t::MODE_IDLE) << "a stale command is no fault: " << d.fault_text;
  EXPECT_EQ(d.fault_flags & (kFlagDriveFault | kFlagHeartbeatLost | kFlagEstop), 0);
}

TEST_F(ArmProcesses, DriveFaultStopsTheArmUntilReset) {
  expect_stop([this] { inject(harvest::sim_drive_fault_t::KIND_FAULT, 3, 0x2310); }, kFlagDriveFault | kFlagEmcy,
              +robot_state_t::MODE_FAULT);
  EXPECT_NE(latest()->fault_text.find("joint 3"), std::string::npos) << latest()->fault_text;
  // An explicit reset brings it back.
  harvest::operator_command_t reset{};
  reset.command = harvest::operator_command_t::RESET_FAULT;
  reset.source = "test";
  const std::size_t from = count();
  send(ch::kOperatorCommand, reset);
  EXPECT_TRUE(wait_for([](const robot_state_t& s) { return s.mode == +robot_state_t::MODE_MOVING; }, 5s, from))
      << latest()->fault_text;
}

TEST_F(ArmProcesses, HeartbeatLossStopsTheArm) {
  expect_stop([this] { inject(harvest::sim_drive_fault_t::KIND_HEARTBEAT_OFF, 5); }, kFlagHeartbeatLost,
              +robot_state_t::MODE_FAULT);
  EXPECT_NE(latest()->fault_text.find("joint 5 (node 5): heartbeat lost"), std::string::npos) << latest()->fault_text;
}

TEST_F(ArmProcesses, EmergencyStopStopsTheArm) {
  harvest::emergency_stop_t e{};
  e.engaged = true;
  e.source = "test";
  e.reason = "red button";
  expect_stop([&] { send(ch::kEmergencyStop, e); }, kFlagEstop, +robot_state_t::MODE_ESTOP);
  EXPECT_NE(latest()->fault_text.find("red button"), std::string::npos) << latest()->fault_text;
}

// Command authority over real processes (issue 16 item 4, docs/security.md):
// an attacker on the host without the key publishes over LCM what it can make
// or capture: unsigned twists, twists signed with another key or as another
// sender, a 1 h old signed twist, a captured signed twist replayed, an e-stop
// clear and a RESET_FAULT signed by nobody (source "attacker"). The link
// stays alive, the arm does not move, and each refusal is counted on
// PROCESS_STATUS. An unsigned e-stop engage still stops it.
TEST_F(ArmProcesses, CommandAuthorityRefusesForgedCommandsOverLcm) {
  // The link's counters as its PROCESS_STATUS reports them.
  struct StatusWatch {
    std::mutex mutex;
    std::map<std::string, int64_t> counters;
    void on_status(const lcm::ReceiveBuffer*, const std::string&, const harvest::process_status_t* m) {
      if (m->process != "robot-link") return;
      std::lock_guard<std::mutex> lock(mutex);
      for (int i = 0; i < m->num_counters; ++i) counters[m->counter_names[i]] = m->counter_values[i];
    }
  } watch;
  lcm::LCM status_lcm(url_);
  ASSERT_TRUE(status_lcm.good());
  status_lcm.subscribe(ch::kProcessStatus, &StatusWatch::on_status, &watch);
  std::atomic<bool> listening{true};
  std::thread status_thread([&] {
    while (listening) status_lcm.handleTimeout(20);
  });
  const auto counter = [&](const std::string& name) {
    std::lock_guard<std::mutex> lock(watch.mutex);
    return watch.counters.count(name) ? watch.counters.at(name) : int64_t{0};
  };

  harvest::robot_command_t twist{};
  twist.type = harvest::robot_command_t::TYPE_TWIST;
  twist.validity_us = 100'000;
  twist.twist.linear[2] = 0.381;
  harvest::rt::SystemClock wall;
  harvest::rt::ManualClock hour_ago(harvest::rt::wall_time_now() - 3600 * harvest::rt::kSecond);
  ht::CommandSigner other_key(ht::kController, nullptr,
                              harvest::security::generate_key(harvest::security::KeyKind::sim));
  ht::CommandSigner impostor("attacker");
  ht::CommandSigner old(ht::kController, &hour_ago);
  const auto captured = ht::live_controller()(twist);
  // The captured one is obeyed once (the real controller sent it), then stopped by the controller.
  {
    std::lock_guard<std::mutex> lock(send_mutex_);
    lcm_->publish(ch::kRobotCommand, &captured);
  }
  std::this_thread::sleep_for(30ms);
  harvest::robot_command_t stop{};
  stop.type = harvest::robot_command_t::TYPE_STOP;
  const std::size_t stopped_from = count();
  send(ch::kRobotCommand, stop);
  ASSERT_TRUE(wait_for([](const robot_state_t& s) { return s.mode == +robot_state_t::MODE_IDLE; }, 5s, stopped_from));
  std::this_thread::sleep_for(200ms);  // at rest
  const robot_state_t before = *latest();
  const int pid = link_->pid();

  lcm::LCM attacker(url_);
  ASSERT_TRUE(attacker.good());
  harvest::emergency_stop_t clear{};
  clear.clear = true;
  clear.source = "attacker";
  harvest::operator_command_t reset{};
  reset.command = harvest::operator_command_t::RESET_FAULT;
  reset.source = "attacker";
  for (int i = 0; i < 4; ++i) {  // the captured one again, inside its validity window
    attacker.publish(ch::kRobotCommand, &captured);
    std::this_thread::sleep_for(50ms);
  }
  for (int i = 0; i < 16; ++i) {  // then what it can make without the key
    const harvest::robot_command_t forged[] = {twist, other_key(twist), impostor(twist), old(twist)};
    attacker.publish(ch::kRobotCommand, &forged[i % 4]);
    if (i % 4 == 0) {
      attacker.publish(ch::kEmergencyStop, &clear);
      attacker.publish(ch::kOperatorCommand, &reset);
    }
    std::this_thread::sleep_for(50ms);
  }
  std::this_thread::sleep_for(1500ms);  // PROCESS_STATUS comes once a second
  const robot_state_t after = *latest();
  EXPECT_TRUE(link_->running()) << outputs();
  EXPECT_EQ(link_->pid(), pid);
  EXPECT_GT(after.header.seq, before.header.seq) << "still publishing";
  const double moved = (tool_position(after) - tool_position(before)).norm();
  std::printf(
      "[ forged commands ] tool moved %.3g m; refused: unsigned %lld, bad MAC %lld, unknown sender %lld, "
      "stale %lld, replayed %lld, e-stop clear %lld, RESET_FAULT %lld\n",
      moved, (long long)counter("robot_command_unsigned"), (long long)counter("robot_command_bad_mac"),
      (long long)counter("robot_command_unknown_sender"), (long long)counter("robot_command_stale"),
      (long long)counter("robot_command_replayed"), (long long)counter("emergency_stop_clear_refused"),
      (long long)counter("reset_fault_refused"));
  EXPECT_LT(moved, 1e-6) << "a forged command moved the arm";
  EXPECT_EQ(after.mode, +robot_state_t::MODE_IDLE) << after.fault_text;
  // UDP on loopback may drop a datagram under load: most of each kind arrive.
  for (const char* c : {"robot_command_unsigned", "robot_command_bad_mac", "robot_command_unknown_sender",
                        "robot_command_stale", "robot_command_replayed"})
    EXPECT_GE(counter(c), 3) << c;
  EXPECT_GE(counter("emergency_stop_clear_refused"), 3);
  EXPECT_GE(counter("reset_fault_refused"), 3);

  // An e-stop engage needs no key.
  harvest::emergency_stop_t engage{};
  engage.engaged = true;
  engage.source = "anyone";
  engage.reason = "unsigned engage";
  const std::size_t engage_from = count();
  attacker.publish(ch::kEmergencyStop, &engage);
  EXPECT_TRUE(wait_for([](const robot_state_t& s) { return s.mode == +robot_state_t::MODE_ESTOP; }, 5s, engage_from))
      << outputs();
  listening = false;
  status_thread.join();
}

// A pose goal the straight path cannot complete and no IK solution reaches
// (far toward the tree, the gripper turned back toward the base): the link
// dry-runs it, then runs the IK in slices after each SYNC for 60 periods and
// refuses it. Meanwhile the link keeps running its SYNC (the longest gap
// between states is printed: on the shared, loaded machine the scheduler
// alone makes gaps of 100 ms and more, so it is not asserted), nothing faults
// and the arm does not move.
TEST_F(ArmProcesses, UnreachablePoseGoalIsRefusedWhileTheLinkKeepsRunning) {
  const robot_state_t before = *latest();
  const Eigen::Quaterniond home(before.tool_pose.orientation[0], before.tool_pose.orientation[1],
                                before.tool_pose.orientation[2], before.tool_pose.orientation[3]);
  const Eigen::Quaterniond back = Eigen::AngleAxisd(M_PI, Eigen::Vector3d::UnitX()) * home;
  const std::size_t from = count();
  commanding_ = true;
  commander_ = std::thread([this, back] {
    harvest::robot_command_t c{};
    c.type = harvest::robot_command_t::TYPE_POSE_GOAL;
    c.validity_us = 200'000;
    c.goal_id = 1;
    c.pose_goal.position[0] = -0.3;
    c.pose_goal.position[1] = 1.25;
    c.pose_goal.position[2] = -0.3;
    c.pose_goal.orientation[0] = back.w();
    c.pose_goal.orientation[1] = back.x();
    c.pose_goal.orientation[2] = back.y();
    c.pose_goal.orientation[3] = back.z();
    int64_t seq = 0;
    while (commanding_) {
      c.header.seq = seq++;
      send(ch::kRobotCommand, c);
      std::this_thread::sleep_for(20ms);
    }
  });
  ASSERT_TRUE(wait_for([](const robot_state_t& s) { return (s.fault_flags & kFlagRefused) != 0; }, 5s, from))
      << outputs();
  std::this_thread::sleep_for(300ms);
  stop_commands();
  const robot_state_t after = *latest();
  EXPECT_NE(after.fault_text.find("pose goal not reachable"), std::string::npos) << after.fault_text;
  EXPECT_EQ(after.num_limit_events, before.num_limit_events + 1);
  EXPECT_LT((tool_position(after) - tool_position(before)).norm(), 1e-6) << "the arm held still";
  std::lock_guard<std::mutex> lock(mutex_);
  int64_t longest = 0;
  for (std::size_t i = from + 1; i < states_.size(); ++i) {
    longest = std::max(longest, states_[i].header.utime - states_[i - 1].header.utime);
    EXPECT_EQ(states_[i].fault_flags & (kFlagDriveFault | kFlagHeartbeatLost | kFlagPdoLost), 0)
        << states_[i].fault_text;
  }
  std::printf("longest SYNC gap while planning: %.1f ms\n", longest / 1000.0);
}

// python-can (not our code) decodes the CANopen traffic of the two processes
// with the standard layouts (the link's own heartbeat too), then stops drive
// 4 with its own NMT frame: the robot link sees another master on its bus and
// stops the arm.
TEST_F(ArmProcesses, PythonCanPeerReadsOurCanopenTrafficAndItsNmtStopIsHandled) {
  const std::string spec = bus_.substr(bus_.find(':') + 1, bus_.find('?') - bus_.find(':') - 1);  // group:port
  const std::string group = spec.substr(0, spec.find(':')), port = spec.substr(spec.find(':') + 1);
  const std::size_t from = count();
  ht::ChildProcess peer(
      {"/usr/bin/python3", ht::source_path("tests/integration/arm/python_can_canopen_peer.py"), group, port, "7", "4"},
      tmp_ / "peer.log");
  ASSERT_EQ(peer.wait(15s), 0) << peer.output() << outputs();
  ASSERT_TRUE(wait_for(
      [](const robot_state_t& s) { return (s.fault_flags & kFlagForeign) && s.mode == robot_state_t::MODE_FAULT; }, 5s,
      from))
      << peer.output() << outputs();
  EXPECT_NE(latest()->fault_text.find("joint 4 (node 4): NMT stop from another master"), std::string::npos)
      << latest()->fault_text;
}

// In the field the bus is socketcan:can0; a missing interface (or, here, a
// kernel without CAN) ends the process at once with a message naming it.
TEST(RobotLinkProcess, MissingCanInterfaceIsAClearErrorNamingIt) {
  ht::TempDir tmp;
  ht::ChildProcess link({ht::bin("harvest-robot-link"), "--config", ht::source_path("config/arm/robot_link.yaml"),
                         "--set", "bus=socketcan:nosuchcan3", "--lcm-url", ht::unique_lcm_url(), "--no-netcheck"},
                        tmp / "robot-link.log");
  const int rc = link.wait(10s);
  EXPECT_NE(rc, 0) << link.output();
  EXPECT_NE(rc, -1) << "still running\n" << link.output();
  EXPECT_NE(link.output().find("socketcan:nosuchcan3"), std::string::npos) << link.output();
}

// --check-config validates everything a start would, touching no bus: a
// default validity above the maximum and an unknown bus transport are
// configuration errors (exit 2) that name the key; so is a controller box
// exceeding the robot link's.
TEST(RobotLinkProcess, CheckConfigRefusesBadValiditiesAndUnknownBusTransports) {
  ht::TempDir tmp;
  const auto check = [&](const std::string& process, const std::string& config, const std::string& assignment) {
    ht::ChildProcess p({ht::bin(process), "--config", ht::source_path(config), "--set", assignment, "--check-config",
                        "--lcm-url", ht::unique_lcm_url(), "--no-netcheck"},
                       tmp / (process + ".log"));
    const int rc = p.wait(10s);
    return std::make_pair(rc, p.output());
  };
  auto [ok, ok_out] = check("harvest-robot-link", "config/arm/robot_link.yaml", "limits.max_validity_ms=100");
  EXPECT_EQ(ok, 0) << ok_out;
  auto [rc1, out1] = check("harvest-robot-link", "config/arm/robot_link.yaml", "limits.max_validity_ms=50");
  EXPECT_EQ(rc1, 2) << out1;
  EXPECT_NE(out1.find("default_validity_ms"), std::string::npos) << out1;
  auto [rc2, out2] = check("harvest-robot-link", "config/arm/robot_link.yaml", "bus=vcan:can0");
  EXPECT_EQ(rc2, 2) << out2;
  EXPECT_NE(out2.find("unknown transport 'vcan'"), std::string::npos) << out2;
  auto [rc3, out3] = check("harvest-sim-drives", "config/arm/sim_drives.yaml", "bus=udp_multicast:239.1.2.3:7?ttl=x");
  EXPECT_EQ(rc3, 2) << out3;
  EXPECT_NE(out3.find("bad ttl 'x'"), std::string::npos) << out3;
  auto [rc5, out5] = check("harvest-robot-link", "config/arm/robot_link.yaml", "can.drive_communication_error=reset");
  EXPECT_EQ(rc5, 2) << out5;
  EXPECT_NE(out5.find("one of {pre_operational, operational, stopped, leave}, got 'reset'"), std::string::npos) << out5;
  // A controller workspace outside the link's envelope: refused at start.
  auto [rc4, out4] = check("harvest-servo-controller", "config/servo/controller.yaml", "workspace.max=[0.8, 1.4, 0.3]");
  EXPECT_EQ(rc4, 2) << out4;
  EXPECT_NE(out4.find("inside the robot envelope's"), std::string::npos) << out4;
}

}  // namespace
