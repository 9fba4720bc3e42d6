// Issue 16's malformed-datagram attacks against the real field process set
// (config/sets/sim.yaml: the simulator plays only the hardware; robot link on
// the virtual CAN bus, end-effector bridge on TCP, both detectors, the
// reconstructor and the servo controller, all under harvest-launch), on a
// private LCM URL (ttl=0), CAN group and board port:
//   - the 58-byte EMERGENCY_STOP whose header.frame_id length is 0 (on main
//     it killed robot-link, servo-controller and ee-bridge at once),
//   - ROBOT_COMMAND with num_joints = -1 and = 1e8 and no data (a twist: were
//     it ever obeyed, the arm would move),
//   - images declaring size = 1e8 on both camera channels,
//   - a zero-length string on every other channel the set subscribes,
//     PROCESS_STATUS (the launcher's) among them.
// Afterwards every process is alive with the pid it had, the arm has not
// moved, each process counts the drops (malformed.<CHANNEL>), and no process
// allocated for the declared counts (peak resident memory).
#include <gtest/gtest.h>
#include <signal.h>

#include <atomic>
#include <cmath>
#include <fstream>
#include <harvest/emergency_stop_t.hpp>
#include <harvest/fruit_detections_t.hpp>
#include <harvest/gripper_command_t.hpp>
#include <harvest/gripper_state_t.hpp>
#include <harvest/harvest_status_t.hpp>
#include <harvest/image_t.hpp>
#include <harvest/ir_range_t.hpp>
#include <harvest/operator_command_t.hpp>
#include <harvest/process_status_t.hpp>
#include <harvest/robot_command_t.hpp>
#include <harvest/robot_state_t.hpp>
#include <harvest/targets_t.hpp>
#include <iostream>
#include <lcm/lcm-cpp.hpp>
#include <map>
#include <mutex>
#include <optional>
#include <sstream>
#include <thread>

#include "arm_watch.hpp"
#include "demo/set_rewrite.hpp"
#include "runtime/log_io.hpp"
#include "test_support.hpp"

namespace ht = harvest::testing;
namespace rt = harvest::rt;
using namespace harvest;
using namespace std::chrono_literals;

namespace {

// Peak resident set of a process [kB].
long peak_rss_kb(int pid) {
  std::ifstream f("/proc/" + std::to_string(pid) + "/status");
  std::string line;
  while (std::getline(f, line))
    if (line.rfind("VmHWM:", 0) == 0) return std::stol(line.substr(6));
  return -1;
}

// A message of type T with header.frame_id's length set to 0 (its bytes
// dropped): fingerprint 8, utime 8, seq 8, then the length.
template <class T>
std::vector<uint8_t> zero_frame_id(T m) {
  m.header.frame_id = "x";
  auto b = rt::encode(m);
  b[24] = b[25] = b[26] = b[27] = 0;
  b.erase(b.begin() + 28, b.begin() + 30);
  return b;
}

// ROBOT_COMMAND, a 0.1 m/s twist, with num_joints = n and no joint data.
std::vector<uint8_t> command_with_joint_count(int32_t n) {
  robot_command_t c{};
  c.header.frame_id = "base";
  c.type = robot_command_t::TYPE_TWIST;
  c.validity_us = 500'000;
  c.twist.linear[2] = 0.1;
  c.num_joints = 0;
  auto b = rt::encode(c);
  // num_joints sits before the three trailing 8-byte fields and the auth block.
  const std::size_t at = b.size() - static_cast<std::size_t>(c.auth._getEncodedSizeNoHash()) - 24 - 4;
  for (int i = 0; i < 4; ++i)
    b[at + static_cast<std::size_t>(i)] = static_cast<uint8_t>(static_cast<uint32_t>(n) >> (24 - 8 * i));
  return b;
}

// An image declaring 1e8 bytes of data and carrying 64.
std::vector<uint8_t> image_claiming_1e8() {
  image_t m{};
  m.header.frame_id = "camera";
  m.encoding = image_t::ENCODING_MONO8;
  m.width = m.height = m.stride = 8;
  m.size = 64;
  m.data.assign(64, 128);
  auto b = rt::encode(m);
  const std::size_t at = b.size() - 64 - 4;  // size precedes data
  const uint32_t n = 100'000'000;
  for (int i = 0; i < 4; ++i) b[at + static_cast<std::size_t>(i)] = static_cast<uint8_t>(n >> (24 - 8 * i));
  return b;
}

}  // namespace

TEST(MalformedAttack, EveryProcessOfTheFieldSetSurvivesCountsAndTheArmStaysStill) {
  ht::TempDir dir;
  const std::string url = ht::unique_lcm_url();
  const int salt = static_cast<int>(::getpid() % 2000);
  const std::string bus =
      "udp_multicast:239.74.164." + std::to_string(10 + salt % 200) + ":" + std::to_string(47000 + salt) + "?ttl=0";
  const std::string port = std::to_string(23000 + salt);

  demo::SetRewrite rw;
  rw.set_file = ht::source_path("config/sets/sim.yaml");
  rw.bin_dir = ht::bin_dir();
  rw.extra_args["sim"] = {"--set", "devices.bus=" + bus, "--set", "devices.board.port=" + port};
  // A stall of the link on the loaded test machine must not trip the drives' own deadlines.
  rw.extra_args["robot-link"] = {"--set", "bus=" + bus,
                                 "--set", "can.drive_rpdo_timeout_ms=200",
                                 "--set", "can.drive_heartbeat_timeout_ms=300",
                                 "--set", "can.pdo_timeout_ms=300"};
  rw.extra_args["ee-bridge"] = {"--set", "link.tcp.port=" + port};
  std::ofstream(dir / "set.yaml") << demo::rewrite_set(rw);

  ht::ArmWatch watch(url);
  ASSERT_TRUE(watch.good());
  ht::ChildProcess launch(
      {ht::bin("harvest-launch"), (dir / "set.yaml").string(), "--lcm-url", url, "--no-table", "--instance", "launch"},
      dir / "launch.log");

  const std::vector<std::string> instances = {"launch",         "sim",           "robot-link",    "ee-bridge",
                                              "detector-fixed", "detector-hand", "reconstructor", "servo-controller"};
  ASSERT_TRUE(ht::eventually(
      [&] {
        const auto s = watch.statuses();
        for (const auto& i : instances)
          if (!s.count(i)) return false;
        const auto st = watch.state();
        return st && st->mode == +robot_state_t::MODE_IDLE;
      },
      90s))
      << launch.output();
  std::this_thread::sleep_for(1s);
  const auto before = watch.statuses();
  const robot_state_t state_before = *watch.state();
  std::map<std::string, long> rss_before;
  for (const auto& i : instances) rss_before[i] = peak_rss_kb(before.at(i).pid);

  // The attacks, each three times (UDP may drop one).
  const std::vector<std::pair<std::string, std::vector<uint8_t>>> attacks = {
      {"EMERGENCY_STOP",
       [] {
         emergency_stop_t e{};
         e.engaged = 1;
         e.reason = "ab";
         return zero_frame_id(e);
       }()},
      {"ROBOT_COMMAND", command_with_joint_count(-1)},
      {"ROBOT_COMMAND", command_with_joint_count(100'000'000)},
      {"CAMERA_FIXED", image_claiming_1e8()},
      {"CAMERA_HAND", image_claiming_1e8()},
      {"PROCESS_STATUS", zero_frame_id(process_status_t{})},
      {"OPERATOR_COMMAND", zero_frame_id(operator_command_t{})},
      {"GRIPPER_COMMAND", zero_frame_id(gripper_command_t{})},
      {"GRIPPER_STATE", zero_frame_id(gripper_state_t{})},
      {"IR_RANGE", zero_frame_id(ir_range_t{})},
      {"ROBOT_STATE", zero_frame_id(robot_state_t{})},
      {"FRUIT_FIXED", zero_frame_id(fruit_detections_t{})},
      {"FRUIT_HAND", zero_frame_id(fruit_detections_t{})},
      {"TARGETS", zero_frame_id(targets_t{})},
      {"HARVEST_STATUS", zero_frame_id(harvest_status_t{})},
  };
  // The 58-byte packet, 53 bytes longer with the (empty) auth block.
  ASSERT_EQ(attacks[0].second.size(), 58u + 53u);
  for (int round = 0; round < 3; ++round)
    for (const auto& [channel, bytes] : attacks) {
      watch.publish(channel, bytes);
      std::this_thread::sleep_for(5ms);
    }

  // Who must have dropped what, by the subscriptions of each process.
  const std::map<std::string, std::vector<std::string>> expected = {
      {"launch", {"PROCESS_STATUS"}},
      {"robot-link", {"EMERGENCY_STOP", "ROBOT_COMMAND", "OPERATOR_COMMAND"}},
      {"servo-controller", {"EMERGENCY_STOP", "TARGETS", "ROBOT_STATE", "IR_RANGE", "GRIPPER_STATE"}},
      {"ee-bridge", {"EMERGENCY_STOP", "GRIPPER_COMMAND"}},
      {"detector-fixed", {"CAMERA_FIXED"}},
      {"detector-hand", {"CAMERA_HAND"}},
      {"reconstructor", {"FRUIT_FIXED", "FRUIT_HAND", "ROBOT_STATE", "HARVEST_STATUS"}},
      {"sim", {"HARVEST_STATUS"}},
  };
  auto all_counted = [&] {
    const auto s = watch.statuses();
    for (const auto& [instance, channels] : expected)
      for (const auto& c : channels)
        if (ht::counter_sum(s.at(instance), "malformed." + c) < 1) return false;
    return true;
  };
  const bool counted = ht::eventually(all_counted, 10s);
  const auto after = watch.statuses();
  for (const auto& [instance, channels] : expected)
    for (const auto& c : channels)
      EXPECT_GE(ht::counter_sum(after.at(instance), "malformed." + c), 1) << instance << " did not count " << c;
  ASSERT_TRUE(counted) << launch.output();

  for (const auto& i : instances) {
    EXPECT_EQ(after.at(i).pid, before.at(i).pid) << i << " was restarted";
    EXPECT_EQ(::kill(after.at(i).pid, 0), 0) << i << " is gone";
    EXPECT_GT(after.at(i).uptime_us, before.at(i).uptime_us) << i;
    EXPECT_EQ(ht::counter_sum(after.at(i), "handler_errors."), 0) << i;
    // 1e8 joints would be 800 MB, a 1e8-byte image 100 MB.
    const long grew_kb = peak_rss_kb(after.at(i).pid) - rss_before[i];
    std::cout << i << ": pid " << after.at(i).pid << ", " << after.at(i).decode_errors
              << " malformed dropped, peak memory +" << grew_kb << " kB\n";
    EXPECT_LT(grew_kb, 40'000) << i << " peak memory grew by " << grew_kb << " kB";
  }
  EXPECT_GE(after.at("robot-link").decode_errors, 3 * 3);
  EXPECT_GE(ht::counter_sum(after.at("robot-link"), "malformed.ROBOT_COMMAND"), 3);

  // The arm did not move and nothing was accepted as a command.
  std::this_thread::sleep_for(500ms);
  const robot_state_t state_after = *watch.state();
  EXPECT_GT(state_after.header.seq, state_before.header.seq);
  EXPECT_EQ(state_after.mode, +robot_state_t::MODE_IDLE) << state_after.fault_text;
  EXPECT_EQ(state_after.last_command_seq, state_before.last_command_seq);
  double moved = 0;
  for (int k = 0; k < 3; ++k)
    moved = std::max(moved, std::abs(state_after.tool_pose.position[k] - state_before.tool_pose.position[k]));
  EXPECT_LT(moved, 1e-6) << "the tool moved " << moved << " m";

  EXPECT_TRUE(launch.running());
  EXPECT_EQ(launch.stop(30s, SIGINT), 0) << launch.output();
  // The launcher says "<name> exited with code N after T" for an exit
  // before the stop ("... stopped (exited with code 0)" at the stop).
  const std::string out = launch.output();
  std::istringstream lines(out);
  for (std::string line; std::getline(lines, line);)
    EXPECT_FALSE((line.find("exited with code") != std::string::npos || line.find("killed by") != std::string::npos) &&
                 line.find(" after ") != std::string::npos)
        << line;
}
