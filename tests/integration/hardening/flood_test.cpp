// Issue 16 item 2: the control loop's period holds whatever arrives.
// harvest-robot-link and harvest-sim-drives run as processes on a private LCM
// URL (ttl=0) and virtual CAN bus; this test listens to the bus and times the
// link's SYNC frames (0x080, 100 Hz: one per control step), first at rest,
// then while it floods the link for 3 s as fast as one thread can publish
// with the most expensive messages we could construct:
//   - pose goals signed by the bound controller (the worst a buggy controller
//     can send: they pass the MAC check) that no joint solution reaches, each
//     with a new goal id (every one starts a dry run and a sliced IK search),
//   - signed pose goals slower than the minimum speed (the dry run of 1e5+
//     steps that once stalled the loop for 1 s), and the slowest accepted
//     one (a dry run of ~12,000 steps, which the link runs in slices),
//   - signed joint goals with NaN and with 1e8 rad,
//   - unsigned 1e9 m/s twists, forged RESET_FAULT and e-stop clears,
//   - ROBOT_COMMAND claiming num_joints = 1e8, and 60 kB of random bytes.
// SYNC must keep its period within 2x: the median interval under flood at most
// twice the configured period, at most 5 % of the time in gaps longer than
// that, and at least half the expected number of SYNC frames sent (the shared
// 2-core test machine preempts any process now and then, so single gaps are
// printed, not asserted). The test machine's host also freezes its vCPUs for
// up to ~130 ms when busy (a flood makes it busy): time when a probe saw a CPU
// frozen (HostFreezes) is not the link's and is taken out of the gaps. The link stays up with the same pid, nothing
// faults, nothing but the signed slowest goal could move the arm, and the
// refusals are counted.
#include <gtest/gtest.h>
#include <poll.h>
#include <unistd.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdio>
#include <harvest/emergency_stop_t.hpp>
#include <harvest/operator_command_t.hpp>
#include <harvest/process_status_t.hpp>
#include <harvest/robot_command_t.hpp>
#include <harvest/robot_state_t.hpp>
#include <lcm/lcm-cpp.hpp>
#include <mutex>
#include <optional>
#include <random>
#include <thread>

#include "arm_watch.hpp"
#include "can/can_bus.hpp"
#include "host_freezes.hpp"
#include "runtime/channels.hpp"
#include "runtime/clock.hpp"
#include "runtime/log_io.hpp"
#include "signing.hpp"
#include "test_support.hpp"

namespace ht = harvest::testing;
namespace ch = harvest::channels;
namespace rt = harvest::rt;
using namespace harvest;
using namespace std::chrono_literals;

namespace {

constexpr int64_t kSyncPeriodUs = 10'000;  // config/arm/robot_link.yaml sync_rate_hz: 100
constexpr int32_t kFlagDriveFault = 1 << 0, kFlagHeartbeatLost = 1 << 2, kFlagPdoLost = 1 << 3;

// Receive times of the SYNC frames on the bus, from a thread of its own.
class SyncClock {
 public:
  explicit SyncClock(const std::string& bus_spec) : bus_(can::open_bus(bus_spec)) {
    bus_->set_filters({{0x080, 0x7FF}});
    thread_ = std::thread([this] {
      while (!stop_) {
        pollfd p{bus_->fd(), POLLIN, 0};
        if (::poll(&p, 1, 20) <= 0) continue;
        while (auto f = bus_->receive()) {
          if (f->id != 0x080 || f->error) continue;
          const int64_t t = f->timestamp_us ? f->timestamp_us : rt::wall_time_now();
          std::lock_guard<std::mutex> lock(mutex_);
          times_.push_back(t);
        }
      }
    });
  }
  ~SyncClock() {
    stop_ = true;
    thread_.join();
  }
  std::vector<int64_t> between(int64_t from, int64_t to) {
    std::lock_guard<std::mutex> lock(mutex_);
    std::vector<int64_t> out;
    for (int64_t t : times_)
      if (t >= from && t < to) out.push_back(t);
    return out;
  }

 private:
  std::unique_ptr<can::CanBus> bus_;
  std::mutex mutex_;
  std::vector<int64_t> times_;
  std::atomic<bool> stop_{false};
  std::thread thread_;
};

struct Period {
  std::size_t frames = 0;
  double expected = 0, median_ms = 0, p99_ms = 0, max_ms = 0;
  double stalled = 0;  // share of the window spent in gaps longer than 2 periods, host freezes taken out
  double stalled_raw = 0;  // the same with the freezes in
  double frozen = 0;       // share of the window in which the host had a CPU frozen
};

Period period_of(const std::vector<int64_t>& t, int64_t from, int64_t to, const ht::HostFreezes& host) {
  Period p;
  p.frames = t.size();
  p.expected = static_cast<double>(to - from) / kSyncPeriodUs;
  const auto window = static_cast<double>(to - from);
  p.frozen = static_cast<double>(host.frozen_between(from, to)) / window;
  std::vector<std::pair<int64_t, int64_t>> spans;  // [previous SYNC, next SYNC)
  for (std::size_t i = 1; i < t.size(); ++i) spans.emplace_back(t[i - 1], t[i]);
  if (t.empty()) spans.emplace_back(from, to);
  std::vector<int64_t> gaps;
  for (const auto& [a, b] : spans) {
    const int64_t g = b - a;
    gaps.push_back(g);
    if (g > 2 * kSyncPeriodUs) p.stalled_raw += static_cast<double>(g) / window;
    const int64_t own = g - host.frozen_between(a, b);
    if (own > 2 * kSyncPeriodUs) p.stalled += static_cast<double>(own) / window;
  }
  std::sort(gaps.begin(), gaps.end());
  p.median_ms = gaps[gaps.size() / 2] / 1000.0;
  p.p99_ms = gaps[std::min(gaps.size() - 1, gaps.size() * 99 / 100)] / 1000.0;
  p.max_ms = gaps.back() / 1000.0;
  return p;
}

void print(const char* what, const Period& p) {
  std::printf(
      "%s: %zu SYNC frames of %.0f expected, interval median %.2f ms, p99 %.2f ms, max %.2f ms, %.1f %% of the "
      "time in gaps over 2 periods (%.1f %% with the host's freezes in; a CPU frozen %.1f %% of the time)\n",
      what, p.frames, p.expected, p.median_ms, p.p99_ms, p.max_ms, 100.0 * p.stalled, 100.0 * p.stalled_raw,
      100.0 * p.frozen);
}

// The flood's messages, already encoded where they need no fresh signature.
class Flood {
 public:
  explicit Flood(const robot_state_t& at_rest) {
    // A pose no joint solution reaches: far toward the tree, the gripper
    // turned back toward the base (as in ArmProcesses.UnreachablePoseGoal...).
    unreachable_.type = robot_command_t::TYPE_POSE_GOAL;
    unreachable_.validity_us = 200'000;
    unreachable_.pose_goal.position[0] = -0.3;
    unreachable_.pose_goal.position[1] = 1.25;
    unreachable_.pose_goal.position[2] = -0.3;
    unreachable_.pose_goal.orientation[0] = 0.0;
    unreachable_.pose_goal.orientation[1] = 1.0;
    // A pose goal 0.3 m away at 1e-6 m/s: 3e5 s of dry run if it were run.
    crawl_.type = robot_command_t::TYPE_POSE_GOAL;
    crawl_.validity_us = 200'000;
    crawl_.pose_goal = at_rest.tool_pose;
    crawl_.pose_goal.position[2] += 0.3;
    crawl_.max_linear_speed = 1e-6;
    // The slowest pose goal accepted: just above the minimum speeds
    // (config/arm/robot_link.yaml), 0.3 m and 2.5 rad away: a dry run of
    // about 12,000 control steps, which the link must not run in one go.
    slowest_ = crawl_;
    slowest_.max_linear_speed = 0.0101;
    slowest_.max_angular_speed = 0.0201;
    const Eigen::Quaterniond q(at_rest.tool_pose.orientation[0], at_rest.tool_pose.orientation[1],
                               at_rest.tool_pose.orientation[2], at_rest.tool_pose.orientation[3]);
    const Eigen::Quaterniond turned = q * Eigen::AngleAxisd(2.5, Eigen::Vector3d::UnitZ());
    slowest_.pose_goal.orientation[0] = turned.w();
    slowest_.pose_goal.orientation[1] = turned.x();
    slowest_.pose_goal.orientation[2] = turned.y();
    slowest_.pose_goal.orientation[3] = turned.z();
    joint_.type = robot_command_t::TYPE_JOINT_GOAL;
    joint_.validity_us = 200'000;
    joint_.num_joints = at_rest.num_joints;
    joint_.joint_goal.assign(static_cast<std::size_t>(at_rest.num_joints), NAN);

    robot_command_t twist{};
    twist.type = robot_command_t::TYPE_TWIST;
    twist.validity_us = 500'000;
    twist.twist.linear[0] = 1e9;
    fixed_.push_back({ch::kRobotCommand, rt::encode(twist)});
    operator_command_t reset{};
    reset.command = operator_command_t::RESET_FAULT;
    reset.source = "attacker";
    fixed_.push_back({ch::kOperatorCommand, rt::encode(reset)});
    emergency_stop_t clear{};
    clear.engaged = 0;
    clear.source = "attacker";
    fixed_.push_back({ch::kEmergencyStop, rt::encode(clear)});
    auto huge = rt::encode(twist);  // num_joints = 1e8 with no data
    const std::size_t at = huge.size() - static_cast<std::size_t>(twist.auth._getEncodedSizeNoHash()) - 24 - 4;
    huge[at] = 0x05;
    huge[at + 1] = 0xF5;
    huge[at + 2] = 0xE1;
    huge[at + 3] = 0x00;
    fixed_.push_back({ch::kRobotCommand, huge});
    std::mt19937 rng(16);
    std::vector<uint8_t> noise(60'000);
    for (auto& b : noise) b = static_cast<uint8_t>(rng());
    fixed_.push_back({ch::kRobotCommand, noise});
  }

  // Publishes message number k of the cycle.
  void send(lcm::LCM& lcm, std::size_t k) {
    const std::size_t kinds = 5 + fixed_.size();
    const std::size_t kind = k % kinds;
    auto publish = [&](robot_command_t c) {
      c.header.seq = static_cast<int64_t>(k);
      c.goal_id = static_cast<int64_t>(k) + 1;  // every goal a new one
      c = ht::as_sent_by_its_sender(c);
      lcm.publish(ch::kRobotCommand, &c);
    };
    if (kind == 0) return publish(unreachable_);
    if (kind == 1) return publish(crawl_);
    if (kind == 2) return publish(joint_);
    if (kind == 3) {
      robot_command_t far = joint_;
      std::fill(far.joint_goal.begin(), far.joint_goal.end(), 1e8);
      return publish(far);
    }
    if (kind == 4) return publish(slowest_);
    const auto& [channel, bytes] = fixed_[kind - 5];
    lcm.publish(channel, bytes.data(), static_cast<unsigned>(bytes.size()));
  }

 private:
  robot_command_t unreachable_{}, crawl_{}, slowest_{}, joint_{};
  std::vector<std::pair<std::string, std::vector<uint8_t>>> fixed_;
};

TEST(Flood, TheLinksSyncKeepsItsPeriodWithin2xAndTheArmStaysStill) {
  ht::TempDir tmp;
  const int pid = static_cast<int>(::getpid());
  const std::string bus = "udp_multicast:239.74.166." + std::to_string(10 + pid % 200) + ":" +
                          std::to_string(57000 + (pid * 13) % 4000) + "?ttl=0";
  const std::string url = ht::unique_lcm_url();
  ht::HostFreezes host;
  SyncClock sync(bus);
  ht::ArmWatch watch(url);
  ASSERT_TRUE(watch.good());
  // The drives are hardware: real-time beside the link, which handles the
  // flood at its own real-time priority (config/arm/robot_link.yaml).
  ht::ChildProcess drives(ht::realtime({ht::bin("harvest-sim-drives"), "--config",
                                        ht::source_path("config/arm/sim_drives.yaml"), "--set", "bus=" + bus,
                                        "--lcm-url", url, "--no-netcheck"},
                                       70),
                          tmp / "sim-drives.log");
  // The drives' own deadlines relaxed as in ArmProcesses: on the loaded test
  // machine a process can be descheduled for longer than 25 ms with no flood.
  ht::ChildProcess link(
      {ht::bin("harvest-robot-link"), "--config", ht::source_path("config/arm/robot_link.yaml"), "--set", "bus=" + bus,
       "--set", "can.pdo_timeout_ms=300", "--set", "can.drive_rpdo_timeout_ms=200", "--set",
       "can.drive_heartbeat_timeout_ms=300", "--lcm-url", url, "--no-netcheck"},
      tmp / "robot-link.log");
  auto outputs = [&] { return "--- robot link:\n" + link.output() + "--- sim drives:\n" + drives.output(); };
  ASSERT_TRUE(ht::eventually(
      [&] {
        const auto s = watch.state();
        return s && s->mode == +robot_state_t::MODE_IDLE && watch.status("robot-link");
      },
      20s))
      << outputs();
  std::this_thread::sleep_for(500ms);

  const robot_state_t before = *watch.state();
  const process_status_t status_before = *watch.status("robot-link");
  const int64_t rest_from = rt::wall_time_now();
  std::this_thread::sleep_for(1s);
  const int64_t flood_from = rt::wall_time_now();

  Flood flood(before);
  lcm::LCM attacker(url);
  ASSERT_TRUE(attacker.good());
  std::size_t sent = 0;
  while (rt::wall_time_now() - flood_from < 3'000'000) flood.send(attacker, sent++);
  const int64_t flood_to = rt::wall_time_now();
  std::this_thread::sleep_for(300ms);

  const Period rest = period_of(sync.between(rest_from, flood_from), rest_from, flood_from, host);
  const Period flooded = period_of(sync.between(flood_from, flood_to), flood_from, flood_to, host);
  std::printf("flood: %zu messages in %.2f s (%.0f per second)\n", sent, (flood_to - flood_from) / 1e6,
              sent / ((flood_to - flood_from) / 1e6));
  print("at rest", rest);
  print("under flood", flooded);
  // Within 2x: the median interval, and all but 5 % of the time (a stall in
  // a handler shows as long gaps: 7 % of one run with the dry run unsliced;
  // the scheduler of a loaded machine alone makes a few; the host's freezes,
  // 6.9 % of one CI run's flood with a 113 ms one, are taken out).
  EXPECT_LE(flooded.median_ms, 2.0 * kSyncPeriodUs / 1000.0);
  EXPECT_LE(flooded.stalled, 0.05);
  EXPECT_GE(static_cast<double>(flooded.frames), 0.5 * flooded.expected);

  // Up with the same pid, never faulted, the arm where it was.
  ASSERT_TRUE(link.running()) << outputs();
  const robot_state_t after = *watch.state();
  EXPECT_GT(after.header.seq, before.header.seq);
  for (const auto& s : watch.states_since(flood_from))
    ASSERT_EQ(s.fault_flags & (kFlagDriveFault | kFlagHeartbeatLost | kFlagPdoLost), 0) << s.fault_text;
  EXPECT_NE(after.mode, +robot_state_t::MODE_FAULT) << after.fault_text;
  // Unsigned and invalid commands move nothing; the signed slowest goal may
  // have started between two newer goals: at most its 0.0101 m/s.
  double moved = 0;
  for (int k = 0; k < 3; ++k)
    moved = std::max(moved, std::abs(after.tool_pose.position[k] - before.tool_pose.position[k]));
  EXPECT_LT(moved, 0.0101 * (rt::wall_time_now() - flood_from) / 1e6) << "the tool moved " << moved << " m";
  std::printf("tool moved %.2f mm\n", 1000.0 * moved);

  ASSERT_TRUE(ht::eventually(
      [&] {
        const auto s = watch.status("robot-link");
        return s && s->header.utime > status_before.header.utime + 1'000'000;
      },
      5s));
  const process_status_t status_after = *watch.status("robot-link");
  EXPECT_EQ(status_after.pid, status_before.pid);
  EXPECT_GT(status_after.decode_errors, status_before.decode_errors) << "malformed commands counted";
  EXPECT_GT(ht::counter_sum(status_after, "robot_command_refused"), ht::counter_sum(status_before, "robot_command_refused"))
      << "unsigned twists counted";
  EXPECT_GT(after.num_limit_events, before.num_limit_events) << "signed goals refused and counted";
  std::printf("robot link: %lld malformed dropped, %lld unsigned commands refused, %d limit events\n",
              static_cast<long long>(status_after.decode_errors - status_before.decode_errors),
              static_cast<long long>(ht::counter_sum(status_after, "robot_command_refused") -
                                     ht::counter_sum(status_before, "robot_command_refused")),
              after.num_limit_events - before.num_limit_events);

  EXPECT_EQ(link.stop(10s), 0) << outputs();
  EXPECT_EQ(drives.stop(10s), 0) << outputs();
}

}  // namespace
