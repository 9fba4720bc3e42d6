// RobotLinkNode on a manual clock against simulated CiA 402 drives
// (lib/simdrive) on the in-memory CAN bus: motion, limits, and every stop path
// of the motion safety, observed through ROBOT_STATE and the drives' truth.
#include "arm/robot_link_node.hpp"

#include <fmt/format.h>
#include <gtest/gtest.h>
#include <spdlog/sinks/ostream_sink.h>
#include <spdlog/spdlog.h>

#include <Eigen/SVD>
#include <cmath>
#include <functional>
#include <harvest/emergency_stop_t.hpp>
#include <harvest/operator_command_t.hpp>
#include <harvest/robot_command_t.hpp>
#include <harvest/robot_state_t.hpp>
#include <memory>
#include <numbers>
#include <sstream>
#include <tuple>

#include "arm/cartesian_control.hpp"
#include "arm_goals.hpp"
#include "can/memory_bus.hpp"
#include "canopen/protocol.hpp"
#include "geometry/pose_msg.hpp"
#include "runtime/channels.hpp"
#include "runtime/log_io.hpp"
#include "runtime/sim_runner.hpp"
#include "signing.hpp"
#include "simdrive/sim_drives_node.hpp"

namespace harvest::arm {
namespace {

namespace ch = harvest::channels;
using harvest::robot_state_t;

constexpr rt::Micros kStart = 1'700'000'000'000'000;

// A CanBus that forwards to an endpoint owned by a MemoryWire. It reports a
// (never polled) descriptor so the node registers its reader with watch_fd,
// which the rig calls whenever frames may be waiting, as the live runner does.
class BusRef final : public can::CanBus {
 public:
  static constexpr int kFakeFd = 1000;
  explicit BusRef(can::CanBus& bus) : bus_(bus) {}
  void send(const can::CanFrame& f) override { bus_.send(f); }
  std::optional<can::CanFrame> receive() override { return bus_.receive(); }
  int fd() const override { return kFakeFd; }
  void set_filters(const std::vector<can::CanFilter>& f) override { bus_.set_filters(f); }
  can::BusState state() const override { return bus_.state(); }
  std::string describe() const override { return bus_.describe(); }

 private:
  can::CanBus& bus_;
};

RobotLinkConfig default_config() {
  auto doc = config::Document::load_file("config/arm/robot_link.yaml");
  RobotLinkConfig c = RobotLinkConfig::from_config(doc.root());
  doc.check_unused();
  return c;
}

// Robot link node on the one in-memory runner (rt::SimRunner, replay's
// delivery order) + simulated drives on its clock: each millisecond the
// node's timers (SYNC every 10 ms) fire at their due times, then the drives
// step and the node's CAN descriptor is offered to it.
class Rig final : public rt::SimRunner {
 public:
  // `before_link` runs on the drives before the robot link is on the bus.
  explicit Rig(RobotLinkConfig config, const std::function<void(simdrive::SimDriveSet&)>& before_link = {})
      : rt::SimRunner(kStart), model_(config.model) {
    auto& drive_end = wire_.attach();
    // The drives the robot link is configured for, read as harvest-sim-drives reads its drive file.
    std::string drives_yaml = "drives:\n";
    for (const auto& d : config.can.drives)
      drives_yaml += "  - {node_id: " + std::to_string(d.node_id) +
                     ", counts_per_radian: " + std::to_string(d.counts_per_radian) +
                     ", zero_offset_counts: " + std::to_string(d.zero_offset_counts) + "}\n";
    auto drives_doc = config::Document::load_string(drives_yaml);
    auto dc = simdrive::sim_drive_configs(model_, drives_doc.root(), 1.5, 3.0);
    for (std::size_t i = 0; i < dc.size(); ++i) {
      dc[i].initial_position = config.model.home[static_cast<Eigen::Index>(i)];
      dc[i].sync_timeout_us = 100'000;  // the drives' own communication watchdog
    }
    drives_ = std::make_unique<simdrive::SimDriveSet>(drive_end, dc);
    if (before_link) before_link(*drives_);
    auto& link_end = wire_.attach();
    node_ = std::make_unique<RobotLinkNode>(std::move(config), std::make_unique<BusRef>(link_end));
    add(*node_);
    SimRunner::start();
  }

  void publish_bytes(const std::string& channel, const void* data, std::size_t size) override {
    const auto* p = static_cast<const uint8_t*>(data);
    if (channel == ch::kRobotState) {
      states_.push_back(*rt::decode<robot_state_t>(std::vector<uint8_t>(p, p + size)));
      if (on_state_) on_state_(states_.back());
    }
    SimRunner::publish_bytes(channel, data, size);
  }
  void watch_fd(int fd, std::function<void()> on_readable) override {
    EXPECT_EQ(fd, BusRef::kFakeFd);
    SimRunner::watch_fd(fd, std::move(on_readable));
  }

  // Commands go in signed as the shipped config expects: motion by the
  // controller, the rest by an operator (docs/security.md).
  template <class Msg>
  void inject(const std::string& channel, Msg msg) {
    if constexpr (std::is_same_v<Msg, harvest::robot_command_t>)
      msg = controller_(msg);
    else if constexpr (std::is_same_v<Msg, harvest::operator_command_t> ||
                       std::is_same_v<Msg, harvest::emergency_stop_t>)
      msg = operator_(msg);
    inject_as_is(channel, msg);
  }
  template <class Msg>
  void inject_as_is(const std::string& channel, const Msg& msg) {
    SimRunner::inject(channel, msg);
  }

  // Runs for `seconds` of simulated time; `each_ms` (if set) runs every millisecond first.
  void run(double seconds, const std::function<void()>& each_ms = {}) {
    const rt::Micros end = now() + rt::from_seconds(seconds);
    while (now() < end) step(each_ms);
  }
  // The link falls silent (its process killed): none of its timers fires
  // again, its bus is not read; only the drives go on.
  void run_without_link(double seconds, const std::function<void()>& each_ms = {}) {
    timers_ = rt::TimerQueue();
    unwatch_fd(BusRef::kFakeFd);
    const rt::Micros end = now() + rt::from_seconds(seconds);
    while (now() < end) step(each_ms);
  }
  // Another device on the bus (another master, an attacker) sends a frame.
  void forge(uint32_t id, std::vector<uint8_t> data) {
    if (intruder_ == nullptr) intruder_ = &wire_.attach();
    can::CanFrame f;
    f.id = id;
    f.dlc = static_cast<uint8_t>(data.size());
    std::copy(data.begin(), data.end(), f.data.begin());
    intruder_->send(f);
  }
  // Runs until pred() or `max_seconds`; returns pred().
  bool run_until(const std::function<bool()>& pred, double max_seconds, const std::function<void()>& each_ms = {}) {
    const rt::Micros end = now() + rt::from_seconds(max_seconds);
    while (!pred() && now() < end) step(each_ms);
    return pred();
  }

  bool enabled_and_idle() const { return !states_.empty() && states_.back().mode == +robot_state_t::MODE_IDLE; }
  void start() {
    ASSERT_TRUE(run_until([this] { return enabled_and_idle(); }, 5.0)) << describe_last();
  }

  std::string describe_last() const {
    if (states_.empty()) return "no ROBOT_STATE yet";
    const auto& s = states_.back();
    return "mode " + std::to_string(s.mode) + " flags " + std::to_string(s.fault_flags) + " text '" + s.fault_text +
           "'";
  }

  RobotLinkNode& node() { return *node_; }
  simdrive::SimDriveSet& drives() { return *drives_; }
  const kinematics::ArmModel& model() const { return model_; }
  const std::vector<robot_state_t>& states() const { return states_; }
  const robot_state_t& last() const { return states_.back(); }
  void on_state(std::function<void(const robot_state_t&)> f) { on_state_ = std::move(f); }
  double max_true_speed() const {
    double m = 0.0;
    for (std::size_t i = 0; i < drives_->size(); ++i) m = std::max(m, std::abs(drives_->drive(i).velocity()));
    return m;
  }

 private:
  void step(const std::function<void()>& each_ms) {
    SimRunner::run_until(now() + 1000);
    drives_->advance(now());
    drives_->drain(now());
    poll();
    if (each_ms) each_ms();
    drives_->drain(now());
    poll();
  }

  kinematics::ArmModel model_;
  can::MemoryWire wire_;
  can::MemoryBus* intruder_ = nullptr;
  std::unique_ptr<simdrive::SimDriveSet> drives_;
  std::unique_ptr<RobotLinkNode> node_;
  harvest::testing::CommandSigner controller_{harvest::testing::kController, &clock()};
  harvest::testing::CommandSigner operator_{harvest::testing::kOperator, &clock()};
  std::vector<robot_state_t> states_;
  std::function<void(const robot_state_t&)> on_state_;
};

harvest::robot_command_t twist_command(double vx, double vy, double vz, double wx = 0, double wy = 0, double wz = 0) {
  harvest::robot_command_t c{};
  c.type = harvest::robot_command_t::TYPE_TWIST;
  c.validity_us = 100'000;
  c.twist.linear[0] = vx;
  c.twist.linear[1] = vy;
  c.twist.linear[2] = vz;
  c.twist.angular[0] = wx;
  c.twist.angular[1] = wy;
  c.twist.angular[2] = wz;
  return c;
}

// Sends `cmd` every 20 ms (the servo controller's rate).
std::function<void()> every_20ms(Rig& rig, harvest::robot_command_t cmd) {
  return [&rig, cmd, n = 0]() mutable {
    if (n++ % 20 == 0) rig.inject(ch::kRobotCommand, cmd);
  };
}

Eigen::Vector3d position(const harvest::pose_t& p) { return {p.position[0], p.position[1], p.position[2]}; }
Eigen::Quaterniond orientation(const harvest::pose_t& p) {
  return {p.orientation[0], p.orientation[1], p.orientation[2], p.orientation[3]};
}
Eigen::VectorXd joints(const robot_state_t& s) {
  return Eigen::Map<const Eigen::VectorXd>(s.joint_position.data(), s.num_joints);
}

harvest::emergency_stop_t estop(bool engaged, bool clear) {
  harvest::emergency_stop_t e{};
  e.engaged = engaged;
  e.clear = clear;
  e.source = "test";
  e.reason = engaged ? "button" : "released";
  return e;
}

harvest::operator_command_t reset_fault() {
  harvest::operator_command_t o{};
  o.command = harvest::operator_command_t::RESET_FAULT;
  o.source = "test";
  return o;
}

bool all_drives_in(const robot_state_t& s, canopen::Cia402State st) {
  for (auto d : s.drive_state)
    if (d != static_cast<int8_t>(st)) return false;
  return !s.drive_state.empty();
}

// Tool displacement per second between two states (header.utime is the sample time).
Eigen::Vector3d measured_velocity(const robot_state_t& a, const robot_state_t& b) {
  return (position(b.tool_pose) - position(a.tool_pose)) / rt::to_seconds(b.header.utime - a.header.utime);
}

TEST(RobotLinkNode, EnablesAllDrivesAndPublishesToolAndCameraPoses) {
  Rig rig(default_config());
  rig.start();
  const auto& s = rig.last();
  EXPECT_EQ(s.num_joints, 7);
  EXPECT_TRUE(all_drives_in(s, canopen::Cia402State::kOperationEnabled));
  EXPECT_EQ(s.fault_flags, 0) << s.fault_text;
  EXPECT_FALSE(s.command_stale) << "no command yet is not a stale command";
  for (std::size_t i = 0; i < rig.drives().size(); ++i)
    EXPECT_NEAR(s.joint_position[i], rig.drives().drive(i).position(), 1e-5);
  EXPECT_EQ(s.header.frame_id, "base");
  // One state per SYNC period (100 Hz), sample times one period apart.
  const auto& prev = rig.states()[rig.states().size() - 2];
  EXPECT_EQ(s.header.utime - prev.header.utime, 10'000);
  EXPECT_EQ(s.header.seq, prev.header.seq + 1);
  // Poses are the model's FK of the reported joints: TCP 190.5 mm beyond the
  // flange along the flange z axis (the approach axis), camera optical frame.
  const Eigen::VectorXd q = joints(s);
  const Eigen::Isometry3d flange = kinematics::flange_pose(rig.model(), q);
  const Eigen::Vector3d tcp = position(s.tool_pose);
  EXPECT_LT((tcp - (flange.translation() + 0.1905 * flange.linear().col(2))).norm(), 1e-9);
  const Eigen::Matrix3d tool_r = orientation(s.tool_pose).toRotationMatrix();
  EXPECT_LT((tool_r.col(2) - flange.linear().col(2)).norm(), 1e-9) << "tool z is the approach axis";
  const Eigen::Isometry3d cam = kinematics::camera_pose(rig.model(), q);
  EXPECT_LT((position(s.camera_pose) - cam.translation()).norm(), 1e-9);
  EXPECT_TRUE(orientation(s.camera_pose).toRotationMatrix().isApprox(cam.linear(), 1e-9));
  // Home: inside the workspace, approach axis toward the tree (+y).
  EXPECT_TRUE(default_config().workspace.contains(tcp)) << tcp.transpose();
  EXPECT_GT(tool_r.col(2).y(), 0.99);
}

// A drive that is slow to send its first PDO after the first SYNC (a busy
// drive or bus at start) is waited for up to boot_timeout; the 100 ms PDO
// watchdog starts with the first PDO. (Loaded CI machines showed this: the
// link latched "no PDO" 110 ms after enabling and never came up.)
TEST(RobotLinkNode, FirstPdoLateAtStartIsWaitedFor) {
  Rig rig(default_config());
  // Drive 1 goes silent the moment it is started (NMT operational: SYNC and
  // PDOs begin), for 160 ms: longer than the PDO watchdog (100 ms), shorter
  // than the heartbeat timeout (200 ms), which keeps watching.
  int silent_ms = -1;
  ASSERT_TRUE(rig.run_until([&] { return rig.enabled_and_idle(); }, 5.0,
                            [&] {
                              if (silent_ms < 0 &&
                                  rig.drives().drive(0).nmt_state() == canopen::NmtState::kOperational) {
                                rig.drives().drive(0).set_silent(true);
                                silent_ms = 0;
                              } else if (silent_ms >= 0 && ++silent_ms == 160) {
                                rig.drives().drive(0).set_silent(false);
                              }
                            }))
      << rig.describe_last();
  EXPECT_GE(silent_ms, 160);
  EXPECT_EQ(rig.last().fault_flags & kFlagPdoLost, 0) << rig.last().fault_text;
}

// A drive that missed the NMT start (a lost frame at start-up: it stays
// pre-operational and never sends a PDO) is started again from its heartbeat.
TEST(RobotLinkNode, DriveThatMissedTheNmtStartIsStartedAgain) {
  Rig rig(default_config());
  bool knocked_back = false;
  ASSERT_TRUE(rig.run_until(
      [&] { return rig.enabled_and_idle(); }, 5.0,
      [&] {
        auto& d = rig.drives().drive(0);
        if (!knocked_back && d.nmt_state() == canopen::NmtState::kOperational) {
          d.handle_frame(canopen::nmt_frame(canopen::NmtCommand::kEnterPreOperational, d.config().node_id), rig.now());
          knocked_back = true;
        }
      }))
      << rig.describe_last();
  EXPECT_TRUE(knocked_back);
  EXPECT_EQ(rig.last().fault_flags, 0) << rig.last().fault_text;
}

TEST(RobotLinkNode, BringsDrivesFromAnyStateToOperationEnabled) {
  // A previous run left the drives operational: one enabled, one quick-stopped, one faulted.
  Rig rig(default_config(), [](simdrive::SimDriveSet& d) {
    using canopen::controlword::kEnableOperation;
    const auto all = [&](const can::CanFrame& f) {
      for (std::size_t i = 0; i < d.size(); ++i) d.drive(i).handle_frame(f, kStart);
    };
    d.advance(kStart);
    all(canopen::nmt_frame(canopen::NmtCommand::kStart, 0));
    for (uint8_t node : {1, 2}) {
      for (uint16_t cw : {canopen::controlword::kShutdown, canopen::controlword::kSwitchOn, kEnableOperation}) {
        d.drive(node - 1u).handle_frame(
            canopen::sdo::initiate_download_expedited(node, canopen::od::kControlword, 0, cw, 2), kStart);
        all(canopen::sync_frame());
      }
    }
    d.drive(1).handle_frame(
        canopen::sdo::initiate_download_expedited(2, canopen::od::kControlword, 0, canopen::controlword::kQuickStop, 2),
        kStart);
    all(canopen::sync_frame());
    d.drive(3).inject_fault(0x5114);
  });
  ASSERT_EQ(rig.drives().drive(0).state(), canopen::Cia402State::kOperationEnabled);
  ASSERT_EQ(rig.drives().drive(1).state(), canopen::Cia402State::kQuickStopActive);
  ASSERT_EQ(rig.drives().drive(3).state(), canopen::Cia402State::kFault);
  rig.start();
  EXPECT_TRUE(all_drives_in(rig.last(), canopen::Cia402State::kOperationEnabled)) << rig.describe_last();
  EXPECT_EQ(rig.last().fault_flags, 0) << rig.last().fault_text;
}

TEST(RobotLinkNode, TwistMovesTheToolAtTheCommandedVelocity) {
  Rig rig(default_config());
  rig.start();
  const Eigen::Vector3d v(0.05, 0.03, -0.04);
  const auto cmd = every_20ms(rig, twist_command(v.x(), v.y(), v.z()));
  rig.run(0.3, cmd);  // ramp up
  const robot_state_t a = rig.last();
  const Eigen::Quaterniond qa = orientation(a.tool_pose);
  rig.run(1.0, cmd);
  const robot_state_t b = rig.last();
  EXPECT_EQ(b.mode, +robot_state_t::MODE_MOVING) << rig.describe_last();
  const Eigen::Vector3d measured = measured_velocity(a, b);
  EXPECT_LT((measured - v).norm(), 0.01 * v.norm()) << measured.transpose();
  EXPECT_LT(orientation(b.tool_pose).angularDistance(qa), 1e-3) << "no angular velocity was commanded";
  const Eigen::Vector3d reported(b.tool_twist.linear[0], b.tool_twist.linear[1], b.tool_twist.linear[2]);
  EXPECT_LT((reported - v).norm(), 0.02 * v.norm()) << reported.transpose();
  EXPECT_EQ(b.fault_flags, 0) << b.fault_text;
  EXPECT_GE(b.last_command_seq, 0);
}

TEST(RobotLinkNode, SixAxisArmFollowsATwistToo) {
  RobotLinkConfig c = default_config();
  c.model = kinematics::ArmModel::load("config/arm/six_axis.yaml");
  c.can.drives.resize(6);
  // Its home is away from singularities (smallest singular value of J well above the damping threshold).
  const Eigen::JacobiSVD<Eigen::MatrixXd> svd(kinematics::tool_jacobian(c.model, c.model.home));
  EXPECT_GT(svd.singularValues().minCoeff(), 0.05);
  Rig rig(std::move(c));
  rig.start();
  ASSERT_EQ(rig.last().num_joints, 6);
  const Eigen::Vector3d v(0.03, -0.04, 0.02);  // toward the shoulder, away from the stretched-arm singularity
  const auto cmd = every_20ms(rig, twist_command(v.x(), v.y(), v.z()));
  rig.run(0.3, cmd);
  const robot_state_t a = rig.last();
  rig.run(1.0, cmd);
  const robot_state_t b = rig.last();
  EXPECT_EQ(b.mode, +robot_state_t::MODE_MOVING) << rig.describe_last();
  const Eigen::Vector3d measured = measured_velocity(a, b);
  EXPECT_LT((measured - v).norm(), 0.01 * v.norm())
      << measured.transpose() << " " << rig.describe_last() << " q " << joints(b).transpose();
  EXPECT_LT(orientation(b.tool_pose).angularDistance(orientation(a.tool_pose)), 1e-3);
}

TEST(RobotLinkNode, AngularTwistRotatesTheToolAboutItsCentre) {
  Rig rig(default_config());
  rig.start();
  const Eigen::Vector3d w(0.0, 0.2, 0.1);
  const auto cmd = every_20ms(rig, twist_command(0, 0, 0, w.x(), w.y(), w.z()));
  rig.run(0.3, cmd);
  const robot_state_t a = rig.last();
  rig.run(1.0, cmd);
  const robot_state_t b = rig.last();
  const Eigen::AngleAxisd rot(orientation(b.tool_pose) * orientation(a.tool_pose).inverse());
  const Eigen::Vector3d measured = rot.angle() * rot.axis() / rt::to_seconds(b.header.utime - a.header.utime);
  EXPECT_LT((measured - w).norm(), 0.01 * w.norm()) << measured.transpose();
  EXPECT_LT((position(b.tool_pose) - position(a.tool_pose)).norm(), 1e-3) << "the TCP stays put";
}

TEST(RobotLinkNode, StaleCommandGivesAControlledStopNotAFault) {
  Rig rig(default_config());
  rig.start();
  auto cmd = twist_command(0.0, 0.0, 0.1);
  cmd.validity_us = 100'000;
  rig.run(0.5, every_20ms(rig, cmd));
  ASSERT_EQ(rig.last().mode, +robot_state_t::MODE_MOVING) << rig.describe_last();
  rig.inject(ch::kRobotCommand, cmd);  // the last one
  const std::size_t moving_until = rig.states().size();
  // Commands stop arriving.
  rig.run(0.09);
  EXPECT_FALSE(rig.last().command_stale) << "still within the 100 ms validity";
  EXPECT_NE(rig.last().joint_velocity_cmd, std::vector<double>(7, 0.0));
  rig.run(0.02);
  EXPECT_TRUE(rig.last().command_stale);
  EXPECT_TRUE(rig.last().fault_flags & kFlagCommandStale);
  ASSERT_TRUE(rig.run_until([&] { return rig.last().mode == +robot_state_t::MODE_IDLE; }, 2.0)) << rig.describe_last();
  EXPECT_LT(rig.max_true_speed(), 1e-9);
  // Controlled: the joint commands ramp down within the acceleration limits, no jump to zero.
  const double dt = 0.01;
  const Eigen::VectorXd amax = rig.model().max_acceleration();
  int ramp_cycles = 0;
  for (std::size_t k = moving_until; k < rig.states().size(); ++k) {
    const auto& p = rig.states()[k - 1].joint_velocity_cmd;
    const auto& c = rig.states()[k].joint_velocity_cmd;
    bool changed = false;
    for (int j = 0; j < 7; ++j) {
      EXPECT_LE(std::abs(c[j] - p[j]), amax[j] * dt * (1 + 1e-9)) << "joint " << j << " state " << k;
      changed = changed || c[j] != p[j];
    }
    ramp_cycles += changed;
  }
  EXPECT_GE(ramp_cycles, 2);
  EXPECT_NE(rig.last().mode, +robot_state_t::MODE_FAULT);
  // A new command moves again, without any reset.
  rig.run(0.3, every_20ms(rig, cmd));
  EXPECT_EQ(rig.last().mode, +robot_state_t::MODE_MOVING) << rig.describe_last();
  EXPECT_FALSE(rig.last().command_stale);
}

TEST(RobotLinkNode, StopCommandStopsAtOnceWithinTheAccelerationLimits) {
  Rig rig(default_config());
  rig.start();
  auto twist = twist_command(0.05, 0.0, 0.05);
  twist.validity_us = 1'000'000;  // the watchdog alone would take a second
  rig.run(0.5, every_20ms(rig, twist));
  ASSERT_EQ(rig.last().mode, +robot_state_t::MODE_MOVING);
  harvest::robot_command_t stop{};
  stop.type = harvest::robot_command_t::TYPE_STOP;
  const std::size_t from = rig.states().size();
  // The STOP is resent like any command; it must not be taken for motion.
  ASSERT_TRUE(rig.run_until([&] { return rig.last().mode == +robot_state_t::MODE_IDLE; }, 1.0, every_20ms(rig, stop)))
      << rig.describe_last();
  EXPECT_LT(rig.states().size() - from, 30u) << "at once, not when the twist expires";
  EXPECT_LT(rig.max_true_speed(), 1e-9);
  EXPECT_FALSE(rig.last().command_stale) << "a stop is not a stale command";
  EXPECT_EQ(rig.last().fault_flags, 0) << rig.last().fault_text;
  const Eigen::VectorXd amax = rig.model().max_acceleration();
  for (std::size_t k = from; k < rig.states().size(); ++k)
    for (int j = 0; j < 7; ++j)
      EXPECT_LE(std::abs(rig.states()[k].joint_velocity_cmd[j] - rig.states()[k - 1].joint_velocity_cmd[j]),
                amax[j] * 0.01 * (1 + 1e-9));
}

// Runs a moving arm into `inject`, then checks: all drives stop, the state
// shows `flag`, the fault latches (commands ignored) until RESET_FAULT.
void expect_fault_stop(const std::function<void(Rig&)>& inject, int32_t flag, const std::string& text,
                       const std::function<void(Rig&)>& repair = {}) {
  Rig rig(default_config());
  rig.start();
  const auto cmd = every_20ms(rig, twist_command(0.0, 0.05, 0.05));
  rig.run(0.5, cmd);
  ASSERT_EQ(rig.last().mode, +robot_state_t::MODE_MOVING) << rig.describe_last();
  ASSERT_GT(rig.max_true_speed(), 0.01);
  inject(rig);
  ASSERT_TRUE(rig.run_until([&] { return (rig.last().fault_flags & flag) != 0; }, 0.5, cmd)) << rig.describe_last();
  EXPECT_EQ(rig.last().mode, +robot_state_t::MODE_FAULT) << rig.describe_last();
  EXPECT_NE(rig.last().fault_text.find(text), std::string::npos) << rig.last().fault_text;
  EXPECT_EQ(rig.last().joint_velocity_cmd, std::vector<double>(7, 0.0));
  // Every drive ramps to rest (quick stop) while commands keep arriving.
  rig.run(0.5, cmd);
  EXPECT_LT(rig.max_true_speed(), 1e-9);
  for (std::size_t i = 0; i < rig.drives().size(); ++i) {
    const auto st = rig.drives().drive(i).state();
    EXPECT_TRUE(st == canopen::Cia402State::kQuickStopActive || st == canopen::Cia402State::kFault ||
                st == canopen::Cia402State::kSwitchOnDisabled)
        << "drive " << i << " in " << canopen::to_string(st);
  }
  const Eigen::Vector3d held = position(rig.last().tool_pose);
  rig.run(0.5, cmd);
  EXPECT_EQ(rig.last().mode, +robot_state_t::MODE_FAULT) << "latched";
  EXPECT_LT((position(rig.last().tool_pose) - held).norm(), 1e-6);
  if (repair) {
    repair(rig);
    rig.run(0.1, cmd);  // whatever the drive says when it is back is seen before the reset
  }
  // Only an operator re-enables the drives: an unsigned RESET_FAULT, or one
  // signed by the controller, leaves the fault latched (and is counted).
  harvest::testing::CommandSigner controller(harvest::testing::kController, &rig.clock());
  rig.inject_as_is(ch::kOperatorCommand, reset_fault());
  rig.inject_as_is(ch::kOperatorCommand, controller(reset_fault()));
  rig.run(0.3, cmd);
  EXPECT_EQ(rig.last().mode, +robot_state_t::MODE_FAULT) << "an unauthorised RESET_FAULT re-enabled the drives";
  const auto& counters = rig.node().stats().counters;
  EXPECT_EQ(counters.count("reset_fault_refused") ? counters.at("reset_fault_refused") : 0, 2);
  rig.inject(ch::kOperatorCommand, reset_fault());
  ASSERT_TRUE(rig.run_until([&] { return rig.last().mode == +robot_state_t::MODE_MOVING; }, 2.0, cmd))
      << rig.describe_last();
  EXPECT_EQ(rig.last().fault_flags & flag, 0);
}

TEST(RobotLinkNode, DriveFaultQuickStopsEveryDriveUntilReset) {
  expect_fault_stop([](Rig& r) { r.drives().drive(2).inject_fault(0x2310); }, kFlagDriveFault | kFlagEmcy,
                    "joint 3 (node 3)");
}

TEST(RobotLinkNode, DriveFaultSetsBothFaultAndEmcyFlags) {
  Rig rig(default_config());
  rig.start();
  rig.drives().drive(6).inject_fault(0x2310);
  ASSERT_TRUE(rig.run_until([&] { return rig.last().mode == +robot_state_t::MODE_FAULT; }, 0.5));
  rig.run(0.1);
  EXPECT_TRUE(rig.last().fault_flags & kFlagDriveFault);
  EXPECT_TRUE(rig.last().fault_flags & kFlagEmcy);
  EXPECT_EQ(rig.last().drive_error_code[6], 0x2310);
  EXPECT_EQ(rig.last().drive_state[6], static_cast<int8_t>(canopen::Cia402State::kFault));
  EXPECT_NE(rig.last().fault_text.find("0x2310"), std::string::npos) << rig.last().fault_text;
}

TEST(RobotLinkNode, HeartbeatLossStopsTheArm) {
  expect_fault_stop([](Rig& r) { r.drives().drive(4).set_heartbeat_enabled(false); }, kFlagHeartbeatLost,
                    "joint 5 (node 5): heartbeat lost",
                    [](Rig& r) { r.drives().drive(4).set_heartbeat_enabled(true); });
}

TEST(RobotLinkNode, EachFaultCauseIsReportedOnce) {
  Rig rig(default_config());
  rig.start();
  rig.drives().drive(3).set_silent(true);  // no PDO, then no heartbeat: two causes, latched one after the other
  ASSERT_TRUE(rig.run_until([&] { return (rig.last().fault_flags & kFlagHeartbeatLost) != 0; }, 1.0));
  rig.run(0.2);
  const std::string& text = rig.last().fault_text;
  for (const std::string cause : {"joint 4 (node 4): no PDO from the drive", "joint 4 (node 4): heartbeat lost"}) {
    const auto first = text.find(cause);
    ASSERT_NE(first, std::string::npos) << text;
    EXPECT_EQ(text.find(cause, first + 1), std::string::npos) << "twice: " << text;
  }
}

TEST(RobotLinkNode, PdoLossStopsTheArm) {
  expect_fault_stop([](Rig& r) { r.drives().drive(0).set_silent(true); }, kFlagPdoLost, "joint 1 (node 1): no PDO",
                    [](Rig& r) { r.drives().drive(0).set_silent(false); });
}

// ---- CAN peers checked (issue 16): frames and states the link did not cause.

TEST(RobotLinkNode, ForgedRpdoFromAnotherMasterStopsTheArmUntilReset) {
  expect_fault_stop(
      [](Rig& r) {
        r.forge(0x203, {0x0F, 0x00, 0x10, 0x27, 0x00, 0x00});
      },
      kFlagForeign, "joint 3 (node 3): an RPDO 0x203 we did not send (another master on the bus)");
}

// Stopped or reset by another master's NMT frame: RESET_FAULT runs that
// drive's start-up again (a reset drive has lost its configuration) and the
// arm moves again.
TEST(RobotLinkNode, NmtStopOrResetByAnotherMasterStopsTheArmAndResetFaultRestartsTheDrive) {
  expect_fault_stop(
      [](Rig& r) {
        r.forge(0x000, {0x02, 4});
      },
      kFlagForeign, "joint 4 (node 4): NMT stop from another master");
  expect_fault_stop(
      [](Rig& r) {
        r.forge(0x000, {0x81, 4});
      },
      kFlagForeign, "joint 4 (node 4): NMT reset node from another master");
  expect_fault_stop(
      [](Rig& r) {
        r.forge(0x000, {0x82, 0});
      },
      kFlagForeign, "NMT reset communication from another master for all nodes");
}

TEST(RobotLinkNode, HeartbeatSayingADriveLeftOperationalOrRebootedStopsTheArm) {
  expect_fault_stop([](Rig& r) { r.forge(0x706, {0x04}); }, kFlagNmtLeft,
                    "joint 6 (node 6): left operational (heartbeat: stopped)");
  expect_fault_stop([](Rig& r) { r.forge(0x706, {0x7F}); }, kFlagNmtLeft,
                    "joint 6 (node 6): left operational (heartbeat: pre-operational)");
  expect_fault_stop([](Rig& r) { r.forge(0x706, {0x00}); }, kFlagNmtLeft,
                    "joint 6 (node 6): rebooted (boot-up message)");
}

TEST(RobotLinkNode, DriveStateChangeWithoutACommandStopsTheArm) {
  expect_fault_stop([](Rig& r) { r.drives().drive(1).local_disable(); }, kFlagUncommanded,
                    "joint 2 (node 2): state changed from operation enabled to switch on disabled without a command");
}

TEST(RobotLinkNode, OneForgedEmcyStillFaultsTheArm) {
  expect_fault_stop(
      [](Rig& r) {
        r.forge(0x082, {0x10, 0x23, 0x01, 0, 0, 0, 0, 0});
      },
      kFlagEmcy, "joint 2 (node 2): EMCY 0x2310 current");
}

// The manual-clock twin of tests/integration/arm/robot_link_kill_test: the
// link stops (no RPDO, SYNC or heartbeat any more) right after a SYNC while
// the tool moves at the speed limit, in each of six directions from home at
// two moments; the drives' RPDO deadline (25 ms) and quick stop (10x the joint
// acceleration limits) stop every joint within 100 ms and the tool within
// 20 mm of the last frame. The worst case is printed.
TEST(RobotLinkNode, DrivesStopThemselvesWhenTheLinkFallsSilent) {
  double worst_ms = 0.0, worst_mm = 0.0;
  for (const Eigen::Vector3d& dir :
       std::vector<Eigen::Vector3d>{{1, 0, 0}, {-1, 0, 0}, {0, 1, 0}, {0, -1, 0}, {0, 0, 1}, {0, 0, -1}}) {
    for (const double moving : {0.4, 0.5}) {
      Rig rig(default_config());
      rig.start();
      const Eigen::Vector3d v = 0.381 * dir;
      const auto cmd = every_20ms(rig, twist_command(v.x(), v.y(), v.z()));
      rig.run(moving, cmd);
      const std::size_t n = rig.states().size();
      rig.run_until([&] { return rig.states().size() > n; }, 0.02, cmd);  // a SYNC just went out
      const auto& s = rig.last();
      // Within 10 %: toward -z the shoulder roll meets its 60 deg/s by 0.5 s from the home posture shipped since
      // 2026-12-07, and the link slows the tool to 0.35 m/s.
      ASSERT_NEAR(Eigen::Vector3d(s.tool_twist.linear[0], s.tool_twist.linear[1], s.tool_twist.linear[2]).norm(), 0.381,
                  0.04)
          << dir.transpose() << " after " << moving << " s";
      const auto tool = [&]() -> Eigen::Vector3d {  // a copy: translation() is a view of the temporary pose
        Eigen::VectorXd q(7);
        for (int i = 0; i < 7; ++i) q[i] = rig.drives().drive(static_cast<std::size_t>(i)).position();
        return kinematics::tool_pose(rig.model(), q).translation();
      };
      const rt::Micros last_frame = rig.now();
      Eigen::Vector3d last = tool();
      double travel = 0.0;
      rt::Micros at_rest = 0;
      rig.run_without_link(0.3, [&] {
        const Eigen::Vector3d p = tool();
        travel += (p - last).norm();
        last = p;
        if (at_rest == 0 && rig.max_true_speed() == 0.0) at_rest = rig.now();
      });
      ASSERT_GT(at_rest, 0) << "still moving 300 ms later";
      const double stop_ms = rt::to_seconds(at_rest - last_frame) * 1000.0;
      EXPECT_LE(stop_ms, 100.0) << dir.transpose() << " after " << moving << " s";
      EXPECT_LE(travel, 0.020) << dir.transpose() << " after " << moving << " s";
      worst_ms = std::max(worst_ms, stop_ms);
      worst_mm = std::max(worst_mm, 1000.0 * travel);
      for (std::size_t i = 0; i < rig.drives().size(); ++i)
        EXPECT_EQ(rig.drives().drive(i).state(), canopen::Cia402State::kQuickStopActive) << "joint " << i + 1;
    }
  }
  std::printf(
      "link silent at 0.381 m/s (12 motions): every joint at rest within %.0f ms, tool travel at most %.1f mm\n",
      worst_ms, worst_mm);
}

TEST(RobotLinkNode, EmergencyStopIsImmediateAndLatchesUntilCleared) {
  Rig rig(default_config());
  rig.start();
  const auto cmd = every_20ms(rig, twist_command(0.05, 0.0, 0.05));
  rig.run(0.5, cmd);
  ASSERT_EQ(rig.last().mode, +robot_state_t::MODE_MOVING);
  const std::size_t before = rig.states().size();
  rig.inject(ch::kEmergencyStop, estop(true, false));
  rig.run(0.011, cmd);  // the next SYNC
  ASSERT_GT(rig.states().size(), before);
  const auto& first = rig.states()[before];
  EXPECT_EQ(first.mode, +robot_state_t::MODE_ESTOP);
  EXPECT_TRUE(first.fault_flags & kFlagEstop);
  EXPECT_EQ(first.joint_velocity_cmd, std::vector<double>(7, 0.0));
  EXPECT_NE(first.fault_text.find("button"), std::string::npos) << first.fault_text;
  rig.run(0.3, cmd);
  EXPECT_LT(rig.max_true_speed(), 1e-9);
  EXPECT_TRUE(all_drives_in(rig.last(), canopen::Cia402State::kQuickStopActive)) << rig.describe_last();
  // A fault reset does not release it; only a clear does.
  rig.inject(ch::kOperatorCommand, reset_fault());
  rig.inject(ch::kEmergencyStop, estop(false, false));
  rig.run(0.3, cmd);
  EXPECT_EQ(rig.last().mode, +robot_state_t::MODE_ESTOP);
  EXPECT_LT(rig.max_true_speed(), 1e-9);
  rig.inject(ch::kEmergencyStop, estop(false, true));
  ASSERT_TRUE(rig.run_until([&] { return rig.last().mode == +robot_state_t::MODE_MOVING; }, 2.0, cmd))
      << rig.describe_last();
  EXPECT_EQ(rig.last().fault_flags & kFlagEstop, 0);
}

// Command authority (docs/security.md, issue 16 item 4): motion only from the
// bound controller, signed with the robot's key, fresh and never twice;
// RESET_FAULT and an e-stop clear only from an operator; an e-stop engage
// from anyone. Every refusal is counted by reason and moves nothing.
TEST(RobotLinkNode, ObeysOnlySignedFreshCommandsFromWhomItIsBoundTo) {
  Rig rig(default_config());
  rig.start();
  const auto twist = twist_command(0.0, 0.0, 0.1);
  harvest::testing::CommandSigner impostor("someone-else", &rig.clock());
  harvest::testing::CommandSigner wrong_key(harvest::testing::kController, &rig.clock(),
                                            security::generate_key(security::KeyKind::sim));
  harvest::testing::CommandSigner controller(harvest::testing::kController, &rig.clock());
  const auto stale = [&] {
    rt::ManualClock past(rig.now() - 2 * rt::kSecond);  // signed 2 s ago (window 1 s)
    return harvest::testing::CommandSigner(harvest::testing::kController, &past)(twist);
  }();
  const auto captured = controller(twist);
  rig.inject_as_is(ch::kRobotCommand, captured);  // obeyed once ...
  rig.run(0.02);
  rig.inject(ch::kRobotCommand, twist_command(0, 0, 0));  // ... and stopped again by the controller
  rig.run(0.5);
  ASSERT_LT(rig.max_true_speed(), 1e-9);
  const auto before = rig.node().stats().counters;
  const auto rose = [&](const std::string& c) {
    const auto& after = rig.node().stats().counters;
    return (after.count(c) ? after.at(c) : 0) - (before.count(c) ? before.at(c) : 0);
  };
  const Eigen::Vector3d at_rest = position(rig.last().tool_pose);
  // The captured command again, within its validity window: a replay.
  rig.run(0.5, [&, n = 0]() mutable {
    if (n++ % 100 == 0) rig.inject_as_is(ch::kRobotCommand, captured);
  });
  EXPECT_EQ(rose("robot_command_replayed"), 5);
  // What an attacker without the key can make, 10 of each.
  rig.run(1.0, [&, n = 0]() mutable {
    switch (n++ % 100) {
      case 0:
        rig.inject_as_is(ch::kRobotCommand, twist);
        break;  // unsigned
      case 25:
        rig.inject_as_is(ch::kRobotCommand, impostor(twist));
        break;  // not the bound controller
      case 50:
        rig.inject_as_is(ch::kRobotCommand, wrong_key(twist));
        break;  // another key
      case 75:
        rig.inject_as_is(ch::kRobotCommand, stale);
        break;  // signed 2 s ago
    }
  });
  EXPECT_LT(rig.max_true_speed(), 1e-9) << "a refused command moved the arm";
  EXPECT_LT((position(rig.last().tool_pose) - at_rest).norm(), 1e-9) << "a refused command moved the arm";
  EXPECT_EQ(rig.last().mode, +robot_state_t::MODE_IDLE) << rig.describe_last();
  EXPECT_EQ(rose("robot_command_unsigned"), 10);
  EXPECT_EQ(rose("robot_command_unknown_sender"), 10);
  EXPECT_EQ(rose("robot_command_bad_mac"), 10);
  EXPECT_EQ(rose("robot_command_stale"), 10);
  EXPECT_EQ(rose("robot_command_refused"), 45);

  // E-stop: engaged by anyone, unsigned; cleared only by an operator's signature.
  rig.inject_as_is(ch::kEmergencyStop, estop(true, false));
  rig.run(0.05);
  ASSERT_EQ(rig.last().mode, +robot_state_t::MODE_ESTOP);
  rig.inject_as_is(ch::kEmergencyStop, estop(false, true));              // unsigned clear
  rig.inject_as_is(ch::kEmergencyStop, controller(estop(false, true)));  // the controller may not clear it
  rig.run(0.3);
  EXPECT_EQ(rig.last().mode, +robot_state_t::MODE_ESTOP);
  EXPECT_EQ(rose("emergency_stop_clear_refused"), 2);
  rig.inject(ch::kEmergencyStop, estop(false, true));  // an operator's
  ASSERT_TRUE(rig.run_until([&] { return rig.last().mode == +robot_state_t::MODE_IDLE; }, 2.0)) << rig.describe_last();
}

TEST(RobotLinkNode, LinearSpeedIsLimitedAndReported) {
  RobotLinkConfig c = default_config();
  c.limits.linear_speed = 0.2;  // well within what the joints can do here
  Rig rig(std::move(c));
  rig.start();
  const auto cmd = every_20ms(rig, twist_command(0.0, 0.0, 0.5));  // 0.5 m/s asked, 0.2 allowed
  rig.run(0.3, cmd);
  const robot_state_t a = rig.last();
  rig.run(0.5, cmd);
  const robot_state_t b = rig.last();
  const Eigen::Vector3d v = measured_velocity(a, b);
  EXPECT_NEAR(v.z(), 0.2, 0.002) << v.transpose();
  EXPECT_LT(v.head<2>().norm(), 0.005);
  EXPECT_TRUE(b.fault_flags & kFlagLimited);
  EXPECT_GE(b.num_limit_events, 1);
  EXPECT_NE(b.fault_text.find("linear speed"), std::string::npos) << b.fault_text;
  EXPECT_EQ(b.mode, +robot_state_t::MODE_MOVING);
}

// Two limits taking turns with every command (seen on the tree: linear, then
// angular speed) are each an event on the robot state, but the log gets at
// most one line a second, saying how many events it stands for.
TEST(RobotLinkNode, LimitsThatComeAndGoAreLoggedAtMostOnceASecond) {
  std::ostringstream captured;
  const auto previous = spdlog::default_logger();
  spdlog::set_default_logger(
      std::make_shared<spdlog::logger>("capture", std::make_shared<spdlog::sinks::ostream_sink_st>(captured)));
  RobotLinkConfig c = default_config();
  c.limits.linear_speed = 0.2;
  c.limits.angular_speed = 0.3;
  Rig rig(std::move(c));
  rig.start();
  const auto linear = twist_command(0.0, 0.0, 0.5);                  // 2.5x the limit: clipped
  const auto angular = twist_command(0.0, 0.0, 0.0, 0.0, 0.0, 0.8);  // 2.7x
  const int32_t before = rig.last().num_limit_events;
  rig.run(3.0, [&rig, &linear, &angular, n = 0]() mutable {
    if (n % 20 == 0) rig.inject(ch::kRobotCommand, (n / 20) % 2 ? angular : linear);
    ++n;
  });
  spdlog::set_default_logger(previous);
  const std::string log = captured.str();
  int lines = 0;
  for (std::size_t at = log.find("command limited"); at != std::string::npos; at = log.find("command limited", at + 1))
    ++lines;
  EXPECT_GE(rig.last().num_limit_events - before, 50) << "each change of limit is still an event";
  EXPECT_GE(lines, 2);
  EXPECT_LE(lines, 4) << log;
  EXPECT_NE(log.find("limit events not logged"), std::string::npos) << log;
}

TEST(RobotLinkNode, WorkspaceBoundaryIsNeverCrossed) {
  RobotLinkConfig c = default_config();
  const Eigen::Vector3d home_tcp = kinematics::tool_pose(c.model, c.model.home).translation();
  c.workspace.max.z() = home_tcp.z() + 0.05;
  const double wall = c.workspace.max.z();
  Rig rig(std::move(c));
  rig.start();
  double highest = -1e9;
  rig.on_state([&](const robot_state_t& s) { highest = std::max(highest, s.tool_pose.position[2]); });
  rig.run(1.5, every_20ms(rig, twist_command(0.0, 0.02, 0.2)));
  EXPECT_LE(highest, wall + 1e-3);
  EXPECT_GT(highest, wall - 2e-3) << "it did get to the boundary";
  EXPECT_TRUE(rig.last().fault_flags & kFlagLimited);
  EXPECT_NE(rig.last().fault_text.find("workspace boundary in z"), std::string::npos) << rig.last().fault_text;
  EXPECT_FALSE(rig.last().fault_flags & kFlagJointLimit) << "the boundary is no joint limit";
  // Motion along the boundary goes on.
  const robot_state_t a = rig.last();
  rig.run(0.5, every_20ms(rig, twist_command(0.0, 0.02, 0.2)));
  EXPECT_NEAR(measured_velocity(a, rig.last()).y(), 0.02, 0.002);
}

// A narrow range for the shoulder roll and a twist that needs it, from the home posture: the joint runs into
// each end of the range in turn. The limiter measures the room from where the command in flight leaves the joint
// (a drive applies a command at the next SYNC) and brakes in whole periods: no joint passes its limit, and no
// command changes faster than the acceleration limit (before that, 1-3 mrad past, braking faster than it).
TEST(RobotLinkNode, JointLimitsAreRespected) {
  RobotLinkConfig c = default_config();
  auto& j1 = c.model.joints[0];
  j1.min = c.model.home[0] - 0.03;
  j1.max = c.model.home[0] + 0.03;
  const kinematics::Jacobian jac = kinematics::tool_jacobian(c.model, c.model.home);
  const Eigen::Vector3d dir = jac.col(0).head<3>().normalized();
  const Eigen::VectorXd vmax = c.model.max_velocity(), amax = c.model.max_acceleration();
  const double upper = j1.max;
  Rig rig(std::move(c));
  rig.start();
  double highest = -1e9;
  bool within = true;
  std::vector<double> prev(7, 0.0);
  rig.on_state([&](const robot_state_t& s) {
    highest = std::max(highest, s.joint_position[0]);
    for (int j = 0; j < 7; ++j) {
      within = within && rig.model().joints[j].min - 1e-6 <= s.joint_position[j] &&
               s.joint_position[j] <= rig.model().joints[j].max + 1e-6;
      within = within && std::abs(s.joint_velocity_cmd[j]) <= vmax[j] + 1e-9;
      within = within && std::abs(s.joint_velocity_cmd[j] - prev[j]) <= amax[j] * 0.01 * (1 + 1e-9);
    }
    prev = s.joint_velocity_cmd;
  });
  rig.run(2.0, every_20ms(rig, twist_command(0.1 * dir.x(), 0.1 * dir.y(), 0.1 * dir.z())));
  EXPECT_TRUE(within);
  EXPECT_LE(highest, upper + 1e-6);
  EXPECT_GT(highest, upper - 2 * vmax[0] * 0.01) << "the joint did get to its limit (within two periods' motion)";
  EXPECT_EQ(rig.last().mode, +robot_state_t::MODE_MOVING) << rig.describe_last();
}

// One Cartesian step with a joint braking for its limit while a command is in flight: the IK holds the joint at
// the speed the limiter allows (both measure the room from where the command in flight leaves it), so the tool
// still gets the twist. With the IK measuring from the joint as read, the limiter slowed the held joint further
// and the tool went off its twist (by 3 % of it here).
TEST(CartesianStep, AJointHeldForItsLimitGivesTheLimiterNothingToClip) {
  RobotLinkConfig c = default_config();
  c.workspace = Workspace{};  // +-2 m: no face near (home is near the configured top)
  Eigen::VectorXd q = c.model.home;
  q[0] = c.model.joints[0].max - 0.05 * std::numbers::pi / 180.0;
  const double dt = 0.01;
  const kinematics::Twist twist = 0.4 * kinematics::tool_jacobian(c.model, q).col(0);  // 0.33 m/s, 0.4 rad/s
  const Eigen::Isometry3d tool = kinematics::tool_pose(c.model, q);
  // Steady braking: the command in flight is the one this step would give (a fixed point).
  Eigen::VectorXd previous = kinematics::joint_velocity_for_twist(c.model, q, twist);
  for (int k = 0; k < 30; ++k)
    previous = kinematics::joint_velocity_within_limits(c.model, q, twist, dt, {}, nullptr, &previous);
  const CartesianStep step = cartesian_step(c, q, tool, twist, previous, dt);
  EXPECT_FALSE(step.clip.clipped) << step.clip.reason;
  EXPECT_TRUE(step.position_clipped);
  EXPECT_LT(step.qdot[0], 0.05) << "joint 1 is held";
  EXPECT_LT((kinematics::tool_jacobian(c.model, q) * step.qdot - twist).norm(), 1e-3 * twist.norm());
  EXPECT_LE(q[0] + previous[0] * dt + step.qdot[0] * dt, c.model.joints[0].max);
}

// A joint braking for its position limit (held at its stopping speed, the
// others making up the twist) is reported as such: kFlagJointLimit, which the
// servo controller reads (home before the next fruit).
TEST(RobotLinkNode, AJointBrakingForItsLimitIsReported) {
  RobotLinkConfig c = default_config();
  c.model.joints[0].max = c.model.home[0] + 0.002;  // joint 1 starts 2 mrad below its limit
  const Eigen::Vector3d dir = kinematics::tool_jacobian(c.model, c.model.home).col(0).head<3>().normalized();
  const double upper = c.model.joints[0].max;
  Rig rig(std::move(c));
  rig.start();
  EXPECT_FALSE(rig.last().fault_flags & kFlagJointLimit);
  bool flagged = false;
  double highest = -1e9;
  rig.on_state([&](const robot_state_t& s) {
    flagged = flagged || (s.fault_flags & kFlagJointLimit) != 0;
    highest = std::max(highest, s.joint_position[0]);
  });
  rig.run(1.0, every_20ms(rig, twist_command(0.05 * dir.x(), 0.05 * dir.y(), 0.05 * dir.z())));
  EXPECT_TRUE(flagged) << rig.describe_last();
  EXPECT_LE(highest, upper + 1e-6);  // 1.25 mrad past when the room was measured from the joint as read
  EXPECT_TRUE(rig.last().fault_flags & kFlagLimited);
}

TEST(RobotLinkNode, PoseGoalIsReachedOnASmoothTrajectory) {
  RobotLinkConfig c = default_config();
  const double vmax = c.limits.linear_speed;
  Rig rig(std::move(c));
  rig.start();
  const auto& s0 = rig.last();
  Eigen::Vector3d goal_p = position(s0.tool_pose) + Eigen::Vector3d(0.10, 0.15, -0.05);
  Eigen::Quaterniond goal_q = Eigen::AngleAxisd(0.2, Eigen::Vector3d::UnitX()) * orientation(s0.tool_pose);
  harvest::robot_command_t cmd{};
  cmd.type = harvest::robot_command_t::TYPE_POSE_GOAL;
  cmd.validity_us = 200'000;
  cmd.goal_id = 42;
  for (int i = 0; i < 3; ++i) cmd.pose_goal.position[i] = goal_p[i];
  cmd.pose_goal.orientation[0] = goal_q.w();
  cmd.pose_goal.orientation[1] = goal_q.x();
  cmd.pose_goal.orientation[2] = goal_q.y();
  cmd.pose_goal.orientation[3] = goal_q.z();
  double peak = 0.0;
  rig.on_state([&](const robot_state_t& s) {
    peak =
        std::max(peak, Eigen::Vector3d(s.tool_twist.linear[0], s.tool_twist.linear[1], s.tool_twist.linear[2]).norm());
  });
  rig.run(3.0, every_20ms(rig, cmd));
  const auto& s = rig.last();
  EXPECT_LT((position(s.tool_pose) - goal_p).norm(), 1e-3);
  EXPECT_LT(orientation(s.tool_pose).angularDistance(goal_q), 5e-3);
  EXPECT_LE(peak, vmax * 1.02);
  EXPECT_GT(peak, 0.05);
  EXPECT_EQ(s.fault_flags, 0) << s.fault_text;
}

TEST(RobotLinkNode, JointGoalIsReached) {
  Rig rig(default_config());
  rig.start();
  Eigen::VectorXd goal = rig.model().home;
  goal[1] += 0.2;
  goal[3] -= 0.15;
  goal[6] += 0.3;
  harvest::robot_command_t cmd{};
  cmd.type = harvest::robot_command_t::TYPE_JOINT_GOAL;
  cmd.validity_us = 200'000;
  cmd.goal_id = 7;
  cmd.num_joints = 7;
  cmd.joint_goal.assign(goal.data(), goal.data() + 7);
  rig.run(2.0, every_20ms(rig, cmd));
  EXPECT_LT((joints(rig.last()) - goal).cwiseAbs().maxCoeff(), 1e-3);
  EXPECT_EQ(rig.last().fault_flags, 0) << rig.last().fault_text;
}

TEST(RobotLinkNode, CommandsOutsideLimitsAreRefusedAndReported) {
  Rig rig(default_config());
  rig.start();
  const Eigen::Vector3d start = position(rig.last().tool_pose);
  harvest::robot_command_t pose{};
  pose.type = harvest::robot_command_t::TYPE_POSE_GOAL;
  pose.pose_goal.position[0] = 5.0;  // far outside the workspace
  pose.pose_goal.orientation[0] = 1.0;
  rig.inject(ch::kRobotCommand, pose);
  rig.run(0.2);
  EXPECT_TRUE(rig.last().fault_flags & kFlagRefused);
  EXPECT_EQ(rig.last().num_limit_events, 1);
  EXPECT_NE(rig.last().fault_text.find("outside the workspace"), std::string::npos) << rig.last().fault_text;
  harvest::robot_command_t joint{};
  joint.type = harvest::robot_command_t::TYPE_JOINT_GOAL;
  joint.num_joints = 7;
  joint.joint_goal.assign(7, 0.0);
  joint.joint_goal[1] = 3.0;  // beyond +-120 deg
  rig.inject(ch::kRobotCommand, joint);
  joint.num_joints = 6;
  joint.joint_goal.assign(6, 0.0);
  rig.inject(ch::kRobotCommand, joint);
  rig.run(0.2);
  EXPECT_EQ(rig.last().num_limit_events, 3);
  EXPECT_NE(rig.last().fault_text.find("6 joints"), std::string::npos) << rig.last().fault_text;
  EXPECT_LT((position(rig.last().tool_pose) - start).norm(), 1e-6) << "nothing moved";
  EXPECT_EQ(rig.last().mode, +robot_state_t::MODE_IDLE);
}

// ---- Bounded work and garbage commands (issue 16).

harvest::robot_command_t pose_goal_command(const robot_state_t& from, const Eigen::Vector3d& offset, int64_t goal_id,
                                           double max_linear_speed) {
  harvest::robot_command_t cmd{};
  cmd.type = harvest::robot_command_t::TYPE_POSE_GOAL;
  cmd.validity_us = 200'000;
  cmd.goal_id = goal_id;
  const Eigen::Vector3d p = position(from.tool_pose) + offset;
  for (int i = 0; i < 3; ++i) cmd.pose_goal.position[i] = p[i];
  for (int i = 0; i < 4; ++i) cmd.pose_goal.orientation[i] = from.tool_pose.orientation[i];
  cmd.max_linear_speed = max_linear_speed;
  return cmd;
}

int64_t counter(RobotLinkNode& node, const std::string& name) {
  const auto& c = node.stats().counters;
  const auto it = c.find(name);
  return it == c.end() ? 0 : it->second;
}

// A 1e9 m/s twist is garbage, not a request for full speed: refused (the arm
// holds), where 2.5x the limit is still clipped and obeyed.
TEST(RobotLinkNode, NonPhysicalTwistIsRefusedNotClippedAndObeyed) {
  Rig rig(default_config());
  rig.start();
  const Eigen::Vector3d start = position(rig.last().tool_pose);
  for (const auto& garbage :
       {twist_command(1e9, 0.0, 0.0), twist_command(0.0, 0.0, 1.2), twist_command(0.0, 0.0, 0.0, 0.0, 5.0, 0.0)}) {
    const int64_t refused = counter(rig.node(), "commands_refused");
    rig.run(0.3, every_20ms(rig, garbage));
    EXPECT_GE(counter(rig.node(), "commands_refused"), refused + 10);
    EXPECT_TRUE(rig.last().fault_flags & kFlagRefused);
    EXPECT_NE(rig.last().fault_text.find("is not physical"), std::string::npos) << rig.last().fault_text;
    EXPECT_LT((position(rig.last().tool_pose) - start).norm(), 1e-6) << "the arm held";
    EXPECT_EQ(rig.last().mode, +robot_state_t::MODE_IDLE);
  }
  rig.run(0.5, every_20ms(rig, twist_command(0.0, 0.0, 0.9)));  // 2.4x: clipped to 0.381 and obeyed
  EXPECT_GT((position(rig.last().tool_pose) - start).norm(), 0.05);
  EXPECT_NE(rig.last().fault_text.find("linear speed limited"), std::string::npos) << rig.last().fault_text;
}

// A pose goal capped below the documented minimum speed would run its dry
// run for hours (and overflow the step count below 1e-9 m/s): refused at
// once with the reason, the arm holds; so are negative and NaN caps.
TEST(RobotLinkNode, PoseGoalSlowerThanTheMinimumIsRefusedWithItsReason) {
  Rig rig(default_config());
  rig.start();
  const robot_state_t s0 = rig.last();
  int64_t id = 100;
  for (const double speed : {1e-4, 1e-5, 1e-12, 1e-300, -0.1, std::nan("")}) {
    const int32_t events = rig.last().num_limit_events;
    rig.inject(ch::kRobotCommand, pose_goal_command(s0, {0.1, 0.0, 0.0}, ++id, speed));
    rig.run(0.05);
    EXPECT_TRUE(rig.last().fault_flags & kFlagRefused) << speed;
    EXPECT_EQ(rig.last().num_limit_events, events + 1) << speed;
    const std::string why = speed > 0 ? "below the minimum 0.01 m/s (limits.min_goal_linear_speed)"
                                      : "must be 0 (the link's limits) or a positive speed";
    EXPECT_NE(rig.last().fault_text.find(why), std::string::npos) << speed << ": " << rig.last().fault_text;
  }
  harvest::robot_command_t turn = pose_goal_command(s0, {0.0, 0.0, 0.0}, ++id, 0.0);
  turn.max_angular_speed = 0.001;
  rig.inject(ch::kRobotCommand, turn);
  rig.run(0.05);
  EXPECT_NE(rig.last().fault_text.find("below the minimum 0.02 rad/s"), std::string::npos) << rig.last().fault_text;
  EXPECT_LT((position(rig.last().tool_pose) - position(s0.tool_pose)).norm(), 1e-6) << "the arm held";
  EXPECT_EQ(counter(rig.node(), "pose_goals_cartesian"), 0) << "nothing was planned";
}

TEST(RobotLinkNode, PoseGoalLongerThanTheMaximumDurationIsRefused) {
  RobotLinkConfig c = default_config();
  c.dry_run.max_duration = 5.0;
  Rig rig(std::move(c));
  rig.start();
  rig.inject(ch::kRobotCommand, pose_goal_command(rig.last(), {0.2, 0.0, 0.0}, 7, 0.02));  // 10 s and more
  rig.run(0.05);
  EXPECT_TRUE(rig.last().fault_flags & kFlagRefused);
  EXPECT_NE(rig.last().fault_text.find("more than the 5 s a goal may take"), std::string::npos)
      << rig.last().fault_text;
}

// The dry run of a long slow goal (0.1 m at 0.02 m/s: 5.6 s, 560 steps plus
// settling) is not done in one go: at most steps_per_period steps in the
// command's handler and then after each SYNC, the arm holding meanwhile; then
// the goal runs as it would have.
TEST(RobotLinkNode, LongPoseGoalIsDryRunInSlicesThenRuns) {
  RobotLinkConfig c = default_config();
  const int per_period = c.dry_run.steps_per_period;
  Rig rig(std::move(c));
  rig.start();
  const robot_state_t s0 = rig.last();
  const auto cmd = pose_goal_command(s0, {0.0, 0.1, 0.0}, 9, 0.02);
  rig.inject(ch::kRobotCommand, cmd);
  EXPECT_EQ(counter(rig.node(), "pose_goals_cartesian"), 0) << "decided within the handler";
  const std::size_t at_goal = rig.states().size();
  ASSERT_TRUE(
      rig.run_until([&] { return counter(rig.node(), "pose_goals_cartesian") == 1; }, 2.0, every_20ms(rig, cmd)));
  EXPECT_GE(rig.states().size() - at_goal, static_cast<std::size_t>(560 / per_period))
      << "periods between the goal and its decision";
  EXPECT_LT((position(rig.last().tool_pose) - position(s0.tool_pose)).norm(), 1e-3) << "held while planning";
  rig.run(2.0, every_20ms(rig, cmd));
  const Eigen::Vector3d moved = position(rig.last().tool_pose) - position(s0.tool_pose);
  EXPECT_NEAR(moved.y(), 0.02 * 2.0, 0.01) << moved.transpose() << " (cruising at 0.02 m/s)";
  EXPECT_EQ(rig.last().mode, +robot_state_t::MODE_MOVING) << rig.last().fault_text;
}

// In slices or at once, the dry run is the same computation.
TEST(PoseGoalDryRunner, InSlicesEqualsAllAtOnce) {
  const RobotLinkConfig c = default_config();
  const Eigen::Isometry3d start = kinematics::tool_pose(c.model, c.model.home);
  Eigen::Isometry3d goal = start;
  goal.translation() += Eigen::Vector3d(0.05, 0.1, -0.05);
  goal.linear() = Eigen::AngleAxisd(0.6, Eigen::Vector3d::UnitY()).toRotationMatrix() * start.linear();
  const CartesianTrajectory path(start, goal, {0.381, 1.0, 1.0, 3.0});
  const Eigen::VectorXd zero = Eigen::VectorXd::Zero(c.model.dof());
  const PoseGoalDryRun whole = dry_run_pose_goal(c, path, c.model.home, zero, c.dry_run);
  PoseGoalDryRunner sliced(c, path, c.model.home, zero, c.dry_run);
  int slices = 1;
  while (!sliced.run(37)) ++slices;
  EXPECT_GT(slices, 2);
  EXPECT_EQ(sliced.result().steps, whole.steps);
  EXPECT_EQ(sliced.result().q, whole.q);
  EXPECT_EQ(sliced.result().position_error, whole.position_error);
  EXPECT_EQ(sliced.result().reached, whole.reached);
  EXPECT_TRUE(sliced.run(1)) << "a finished dry run stays finished";
}

// A stray publisher's refused commands (50 a second) are each counted, but
// logged at most once a second with how many the line stands for.
TEST(RobotLinkNode, RefusalsAreLoggedAtMostOnceASecondWithACount) {
  std::ostringstream captured;
  const auto previous = spdlog::default_logger();
  spdlog::set_default_logger(
      std::make_shared<spdlog::logger>("capture", std::make_shared<spdlog::sinks::ostream_sink_st>(captured)));
  Rig rig(default_config());
  rig.start();
  const int64_t before = counter(rig.node(), "commands_refused");
  rig.run(3.0, every_20ms(rig, twist_command(1e9, 0.0, 0.0)));
  spdlog::set_default_logger(previous);
  const std::string log = captured.str();
  int lines = 0;
  for (std::size_t at = log.find("refused"); at != std::string::npos; at = log.find("refused", at + 1)) ++lines;
  EXPECT_GE(counter(rig.node(), "commands_refused") - before, 140);
  EXPECT_GE(lines, 2);
  EXPECT_LE(lines, 4) << log;
  EXPECT_NE(log.find("limit events not logged"), std::string::npos) << log;
}

// ---- Pose goals: the Cartesian dry run, the joint-space fallback, refusal.

harvest::robot_command_t pose_goal_command(const Eigen::Isometry3d& goal, int64_t goal_id) {
  harvest::robot_command_t cmd{};
  cmd.type = harvest::robot_command_t::TYPE_POSE_GOAL;
  cmd.validity_us = 200'000;
  cmd.goal_id = goal_id;
  cmd.pose_goal = geometry::to_pose(goal);
  return cmd;
}

struct GoalRun {
  double position_error = 0.0, orientation_error = 0.0;  // at the end
  bool stalled = false;      // by the servo controller's rule: 2 s without 2 mm or 0.01 rad of progress
  double reached_at = -1.0;  // [s] first within 5 mm, 0.02 rad (the controller's tolerances), -1 never
};

// Sends the pose goal every 20 ms (as the servo controller does) until the
// tool is within the controller's tolerances, the controller would have
// given up on a stall, or `seconds` have passed.
GoalRun run_pose_goal(Rig& rig, const Eigen::Isometry3d& goal, int64_t goal_id, double seconds) {
  GoalRun out;
  const auto cmd = every_20ms(rig, pose_goal_command(goal, goal_id));
  const rt::Micros start = rig.now();
  double best_p = 1e9, best_r = 1e9;
  rt::Micros progress_at = start;
  const auto errors = [&](const robot_state_t& s) {
    return std::pair{(position(s.tool_pose) - goal.translation()).norm(),
                     orientation(s.tool_pose).angularDistance(Eigen::Quaterniond(goal.linear()))};
  };
  rig.run_until(
      [&] {
        if (rig.states().empty()) return false;
        const auto [p, r] = errors(rig.last());
        if (p <= 0.005 && r <= 0.02) {
          out.reached_at = rt::to_seconds(rig.now() - start);
          return true;
        }
        // As HarvestMachine::goal_stalled: the best distance moves only by a step of progress.
        if (p < best_p - 0.002) {
          best_p = p;
          progress_at = rig.now();
        }
        if (r < best_r - 0.01) {
          best_r = r;
          progress_at = rig.now();
        }
        out.stalled = rig.now() - progress_at > rt::from_seconds(2.0);
        return out.stalled;
      },
      seconds, cmd);
  std::tie(out.position_error, out.orientation_error) = errors(rig.last());
  return out;
}

int64_t counter(Rig& rig, const std::string& name) {
  const auto& c = rig.node().stats().counters;
  const auto it = c.find(name);
  return it == c.end() ? 0 : it->second;
}

// A re-orientation from home that the Cartesian path cannot complete but
// the arm can reach: searched over a small grid of aim points (above and
// beside the tool), the first whose plan from home is joint space and whose
// Cartesian execution on the rig (fallback off) really stalls by the
// controller's rule. Searched once, shared by the tests below.
struct StuckCase {
  Eigen::Vector3d aim;
  Eigen::Isometry3d goal;
  GoalRun cartesian;  // on the rig with the fallback off
  PoseGoalPlan plan;  // from home, fallback on
};
const StuckCase& stuck_reorientation() {
  static const StuckCase found = [] {
    const RobotLinkConfig c = default_config();
    const Eigen::Isometry3d home = kinematics::tool_pose(c.model, c.model.home);
    const Eigen::VectorXd rest = Eigen::VectorXd::Zero(c.model.dof());
    for (double z : {-0.3, -0.4, -0.5})
      for (double y : {1.0, 1.3, 0.9, 0.8}) {
        StuckCase k;
        k.aim = Eigen::Vector3d(-0.8, y, z);
        k.goal = aim_goal(home, k.aim);
        k.plan = plan_pose_goal(c, CartesianTrajectory(home, k.goal, goal_limits(c)), c.model.home, rest);
        if (k.plan.way != PoseGoalPlan::Way::kJointSpace) continue;
        RobotLinkConfig off = default_config();
        off.pose_goal_joint_fallback = false;
        Rig rig(std::move(off));
        rig.start();
        k.cartesian = run_pose_goal(rig, k.goal, 1, 10.0);
        if (k.cartesian.stalled) return k;
      }
    ADD_FAILURE() << "no stuck but reachable re-orientation in the grid";
    return StuckCase{};
  }();
  return found;
}

TEST(RobotLinkNode, ReorientationTheCartesianPathCannotCompleteIsDoneInJointSpace) {
  const StuckCase& k = stuck_reorientation();
  ASSERT_EQ(k.plan.way, PoseGoalPlan::Way::kJointSpace) << k.plan.why;
  // It really is stuck the Cartesian way: the dry run stops short at joint
  // limits, and so does the arm (the controller would give the fruit up).
  EXPECT_FALSE(k.plan.dry_run.reached);
  EXPECT_GT(k.plan.dry_run.position_clipped_steps, 0);
  EXPECT_TRUE(k.cartesian.stalled);
  EXPECT_TRUE(k.cartesian.position_error > 0.005 || k.cartesian.orientation_error > 0.02)
      << k.cartesian.position_error << " m " << k.cartesian.orientation_error << " rad";

  Rig rig(default_config());
  rig.start();
  // Resent every 20 ms with a new seq each time, the same goal_id.
  harvest::robot_command_t cmd = pose_goal_command(k.goal, 77);
  cmd.header.seq = 100;
  int ms = 0;
  const auto send = [&] {
    if (ms++ % 20 == 0) {
      rig.inject(ch::kRobotCommand, cmd);
      ++cmd.header.seq;
    }
  };
  bool echoed = true, no_fault = true;
  double fastest = 0.0, fastest_turn = 0.0;  // measured tool speeds
  rig.on_state([&](const robot_state_t& s) {
    echoed = echoed && s.last_command_seq == cmd.header.seq - 1;  // every accepted resend is echoed
    no_fault = no_fault && (s.fault_flags & (kFlagRefused | kFlagDriveFault | kFlagCommandStale)) == 0;
    fastest = std::max(fastest,
                       Eigen::Vector3d(s.tool_twist.linear[0], s.tool_twist.linear[1], s.tool_twist.linear[2]).norm());
    fastest_turn =
        std::max(fastest_turn,
                 Eigen::Vector3d(s.tool_twist.angular[0], s.tool_twist.angular[1], s.tool_twist.angular[2]).norm());
  });
  const double limit = 0.5 + k.plan.joints->duration() + 1.0;  // IK slices, the motion, settling
  const bool reached = rig.run_until(
      [&] {
        return (position(rig.last().tool_pose) - k.goal.translation()).norm() < 1e-3 &&
               orientation(rig.last().tool_pose).angularDistance(Eigen::Quaterniond(k.goal.linear())) < 5e-3;
      },
      limit, send);
  EXPECT_TRUE(reached) << "aim (" << k.aim.transpose() << "): " << k.plan.why << "; at "
                       << position(rig.last().tool_pose).transpose();
  rig.run(0.5, send);
  EXPECT_LT((position(rig.last().tool_pose) - k.goal.translation()).norm(), 1e-3);
  EXPECT_LT(orientation(rig.last().tool_pose).angularDistance(Eigen::Quaterniond(k.goal.linear())), 5e-3);
  EXPECT_TRUE(echoed);
  EXPECT_TRUE(no_fault) << rig.describe_last();
  // The tool's speed limits hold in joint space too (5 % for tracking).
  const RobotLinkConfig c = default_config();
  EXPECT_LE(fastest, 1.05 * c.limits.linear_speed) << "m/s";
  EXPECT_LE(fastest_turn, 1.05 * c.limits.angular_speed) << "rad/s";
  EXPECT_EQ(counter(rig, "pose_goals_joint_space"), 1) << "planned once, not on every resend";
  EXPECT_EQ(counter(rig, "pose_goals_cartesian"), 0);
}

TEST(RobotLinkNode, ReachableShortPoseGoalStaysOnTheStraightLine) {
  Rig rig(default_config());
  rig.start();
  const Eigen::Vector3d start = position(rig.last().tool_pose);
  Eigen::Isometry3d goal = Eigen::Isometry3d::Identity();
  // Every joint under its speed limit on the way. Toward -z (0.08, 0.12, -0.06) from the home posture shipped since
  // 2026-12-07 the turn about the vertical falls to the shoulder roll at its 60 deg/s, the whole motion is slowed, lags
  // its path and overshoots the goal by 15 mm (a pose goal's path honours the tool's speed limits, not the joints').
  goal.translation() = start + Eigen::Vector3d(0.08, 0.12, 0.06);
  goal.linear() = (Eigen::AngleAxisd(0.3, Eigen::Vector3d::UnitX()) * orientation(rig.last().tool_pose)).matrix();
  const Eigen::Vector3d u = (goal.translation() - start).normalized();
  double off_line = 0.0, beyond = 0.0;
  rig.on_state([&](const robot_state_t& s) {
    const Eigen::Vector3d d = position(s.tool_pose) - start;
    off_line = std::max(off_line, (d - d.dot(u) * u).norm());
    beyond = std::max(beyond, d.dot(u) - (goal.translation() - start).norm());
  });
  const GoalRun r = run_pose_goal(rig, goal, 5, 3.0);
  EXPECT_GE(r.reached_at, 0.0) << r.position_error << " m " << r.orientation_error << " rad";
  rig.run(0.5, every_20ms(rig, pose_goal_command(goal, 5)));
  EXPECT_LT((position(rig.last().tool_pose) - goal.translation()).norm(), 1e-3);
  EXPECT_LT(orientation(rig.last().tool_pose).angularDistance(Eigen::Quaterniond(goal.linear())), 5e-3);
  // Tracking lag only (about 1.4 mm); the straight joint-space path to the same
  // goal (solve_pose from home) leaves the line by 15 mm.
  EXPECT_LT(off_line, 3e-3) << "the tool leaves the straight line";
  EXPECT_LT(beyond, 3e-3) << "overshoot";
  EXPECT_EQ(counter(rig, "pose_goals_cartesian"), 1);
  EXPECT_EQ(counter(rig, "pose_goals_joint_space"), 0);
  EXPECT_EQ(rig.last().fault_flags, 0) << rig.last().fault_text;
}

TEST(RobotLinkNode, PoseGoalWithNoJointSolutionIsRefusedAndTheArmHolds) {
  const RobotLinkConfig c = default_config();
  // Far out toward the tree (inside the workspace box), the gripper turned
  // back toward the base: beyond what the arm can reach that way round.
  Eigen::Isometry3d goal = Eigen::Isometry3d::Identity();
  goal.translation() = Eigen::Vector3d(-0.3, 1.25, -0.3);
  goal.linear() =
      (Eigen::AngleAxisd(M_PI, Eigen::Vector3d::UnitX()) * kinematics::tool_pose(c.model, c.model.home).linear())
          .matrix();  // approach axis -y
  ASSERT_TRUE(c.workspace.contains(goal.translation()));
  ASSERT_FALSE(kinematics::solve_pose(c.model, goal, c.model.home)) << "the test needs a pose with no IK solution";

  Rig rig(default_config());
  rig.start();
  const robot_state_t before = rig.last();
  double fastest = 0.0;
  rig.on_state([&](const robot_state_t&) { fastest = std::max(fastest, rig.max_true_speed()); });
  const auto cmd = every_20ms(rig, pose_goal_command(goal, 9));
  const rt::Micros sent = rig.now();
  // The IK runs in slices (9000 iterations, every start running out, 150 a
  // period: 60 periods), then the goal is refused.
  ASSERT_TRUE(rig.run_until([&] { return (rig.last().fault_flags & kFlagRefused) != 0; }, 1.5, cmd))
      << rig.describe_last();
  const double planning = rt::to_seconds(rig.now() - sent);
  EXPECT_GT(planning, 0.55) << "spread over the control periods, not all at once";
  EXPECT_LT(planning, 0.65);
  rig.run(1.0, cmd);  // the controller keeps resending it
  const auto& s = rig.last();
  EXPECT_TRUE(s.fault_flags & kFlagRefused);
  EXPECT_NE(s.fault_text.find("pose goal not reachable"), std::string::npos) << s.fault_text;
  EXPECT_NE(s.fault_text.find("no joint solution"), std::string::npos) << s.fault_text;
  EXPECT_EQ(s.num_limit_events, before.num_limit_events + 1) << "one limit event, not one per resend";
  EXPECT_EQ(counter(rig, "pose_goals_unreachable"), 1) << "planned once";
  EXPECT_LT(fastest, 1e-9) << "the arm did not move";
  EXPECT_LT((position(s.tool_pose) - position(before.tool_pose)).norm(), 1e-6);
  EXPECT_LT((joints(s) - joints(before)).cwiseAbs().maxCoeff(), 1e-6);
  EXPECT_EQ(s.mode, +robot_state_t::MODE_IDLE) << rig.describe_last();
  // Another goal is taken as usual.
  Eigen::Isometry3d near = Eigen::Isometry3d::Identity();
  near.translation() = position(s.tool_pose) + Eigen::Vector3d(0.0, 0.05, 0.0);
  near.linear() = orientation(s.tool_pose).toRotationMatrix();
  EXPECT_GE(run_pose_goal(rig, near, 10, 3.0).reached_at, 0.0);
  EXPECT_EQ(rig.last().fault_flags & kFlagRefused, 0) << rig.last().fault_text;
}

TEST(RobotLinkNode, PoseGoalInJointSpaceStopsOnAStaleCommand) {
  const StuckCase& k = stuck_reorientation();
  ASSERT_EQ(k.plan.way, PoseGoalPlan::Way::kJointSpace);
  Rig rig(default_config());
  rig.start();
  auto cmd = pose_goal_command(k.goal, 3);
  cmd.validity_us = 100'000;
  // Until the joint-space motion is well under way.
  ASSERT_TRUE(rig.run_until([&] { return counter(rig, "pose_goals_joint_space") == 1 && rig.max_true_speed() > 0.3; },
                            2.0, every_20ms(rig, cmd)))
      << rig.describe_last();
  rig.inject(ch::kRobotCommand, cmd);  // the last one
  const std::size_t from = rig.states().size();
  rig.run(0.09);
  EXPECT_FALSE(rig.last().command_stale);
  rig.run(0.02);
  EXPECT_TRUE(rig.last().command_stale);
  EXPECT_TRUE(rig.last().fault_flags & kFlagCommandStale);
  ASSERT_TRUE(rig.run_until([&] { return rig.last().mode == +robot_state_t::MODE_IDLE; }, 2.0)) << rig.describe_last();
  EXPECT_LT(rig.max_true_speed(), 1e-9);
  const Eigen::VectorXd amax = rig.model().max_acceleration();
  for (std::size_t i = from; i < rig.states().size(); ++i)
    for (int j = 0; j < 7; ++j)
      EXPECT_LE(std::abs(rig.states()[i].joint_velocity_cmd[j] - rig.states()[i - 1].joint_velocity_cmd[j]),
                amax[j] * 0.01 * (1 + 1e-9));
  EXPECT_GT((joints(rig.last()) - k.plan.joints->goal()).cwiseAbs().maxCoeff(), 0.1) << "stopped on the way";
  const Eigen::VectorXd held = joints(rig.last());
  rig.run(0.5);
  EXPECT_LT((joints(rig.last()) - held).cwiseAbs().maxCoeff(), 1e-9) << "and stays stopped";
  EXPECT_NE(rig.last().mode, +robot_state_t::MODE_FAULT);
}

TEST(RobotLinkNode, PoseGoalInJointSpaceStopsOnEmergencyStop) {
  const StuckCase& k = stuck_reorientation();
  ASSERT_EQ(k.plan.way, PoseGoalPlan::Way::kJointSpace);
  Rig rig(default_config());
  rig.start();
  const auto cmd = every_20ms(rig, pose_goal_command(k.goal, 4));
  ASSERT_TRUE(rig.run_until([&] { return counter(rig, "pose_goals_joint_space") == 1 && rig.max_true_speed() > 0.3; },
                            2.0, cmd))
      << rig.describe_last();
  const std::size_t before = rig.states().size();
  rig.inject(ch::kEmergencyStop, estop(true, false));
  rig.run(0.011, cmd);
  ASSERT_GT(rig.states().size(), before);
  EXPECT_EQ(rig.states()[before].mode, +robot_state_t::MODE_ESTOP);
  EXPECT_EQ(rig.states()[before].joint_velocity_cmd, std::vector<double>(7, 0.0));
  rig.run(0.5, cmd);
  EXPECT_LT(rig.max_true_speed(), 1e-9);
  EXPECT_TRUE(all_drives_in(rig.last(), canopen::Cia402State::kQuickStopActive)) << rig.describe_last();
}

// Re-orientations from home as the servo controller's ORIENT asks for them,
// over a grid of aim points (the tree scenario's fruit region and a plane
// above and beside the tool), each on the rig the old way (Cartesian only)
// and the new. Everything the new way takes on is reached (goals the Cartesian
// way cannot complete it does in joint space where a solution exists: from the
// posture shipped before 2026-12-07, 3 of this grid's 8 stalls; from today's
// none of its 6 has one, and ReorientationTheCartesianPathCannotCompleteIsDoneInJointSpace
// finds its own case); a goal it refuses for want of an IK solution is
// never one the Cartesian way reaches. (One it refuses because the joint path
// leaves the workspace may be: the dry run and the arm part ways on long
// struggles against joint limits; such losses are counted and printed.)
TEST(RobotLinkNode, ReorientationsFromHomeOverAGrid) {
  const RobotLinkConfig c = default_config();
  const Eigen::Isometry3d home = kinematics::tool_pose(c.model, c.model.home);
  int cartesian_failed = 0, rescued = 0, refused = 0, joint_space = 0, lost = 0;
  int64_t id = 1;
  std::vector<Eigen::Vector3d> aims;
  for (double x : {-0.45, -0.3, -0.15, -0.05})  // the tree scenario's fruit region
    for (double y : {0.9, 1.05, 1.2})
      for (double z : {-0.7, -0.5, -0.3, -0.1}) aims.emplace_back(x, y, z);
  const std::size_t tree_aims = aims.size();
  for (double y : {0.8, 0.9, 1.0, 1.1, 1.2, 1.3})  // above and beside the tool
    for (double z : {-0.6, -0.5, -0.4, -0.3}) aims.emplace_back(-0.8, y, z);
  int lost_beside = 0;
  for (std::size_t a = 0; a < aims.size(); ++a) {
    const Eigen::Vector3d& aim = aims[a];
    const bool tree = a < tree_aims;
    const Eigen::Isometry3d goal = aim_goal(home, aim);
    RobotLinkConfig off = default_config();
    off.pose_goal_joint_fallback = false;
    Rig old_rig(std::move(off));
    old_rig.start();
    const GoalRun old_way = run_pose_goal(old_rig, goal, id, 10.0);
    Rig rig(default_config());
    rig.start();
    const Eigen::Vector3d at_start = position(rig.last().tool_pose);  // home as the encoders read it
    const GoalRun new_way = run_pose_goal(rig, goal, id, 10.0);
    ++id;
    const bool old_ok = old_way.reached_at >= 0, new_ok = new_way.reached_at >= 0;
    const bool was_refused = counter(rig, "pose_goals_unreachable") > 0;
    const bool in_joints = counter(rig, "pose_goals_joint_space") > 0;
    const std::string text = rig.last().fault_text;
    if (!old_ok || !new_ok || in_joints)
      std::printf("aim (%.2f, %.2f, %.2f): Cartesian way %s %.2f s; new way %s, %s %.2f s\n", aim.x(), aim.y(), aim.z(),
                  old_ok ? "reached" : "stalled", old_ok ? old_way.reached_at : -1.0,
                  was_refused ? "refused" : (in_joints ? "joint space" : "Cartesian"),
                  new_ok ? "reached" : "not reached", new_ok ? new_way.reached_at : -1.0);
    cartesian_failed += !old_ok;
    rescued += !old_ok && new_ok;
    refused += was_refused;
    joint_space += in_joints;
    (tree ? lost : lost_beside) += old_ok && !new_ok;
    // Beside the tool, a long joint-space swing (slowed to the tool's speed
    // limits) may move away from the goal for longer than the controller's
    // 2 s no-progress rule: given up there, never a fruit in the tree.
    // A goal with no joint solution whose straight path stops near enough runs "as near as it gets" (the
    // controller decides what short means): never one the Cartesian way reached, and the arm ends that near.
    const bool as_near_as_it_gets = !old_ok && !in_joints && !was_refused &&
                                    new_way.position_error <= c.dry_run.near_enough_position &&
                                    new_way.orientation_error <= c.dry_run.near_enough_orientation;
    EXPECT_TRUE(new_ok || was_refused || as_near_as_it_gets || (!tree && in_joints && new_way.stalled))
        << "aim (" << aim.transpose() << ") accepted but not reached";
    if (was_refused) {
      EXPECT_LT((position(rig.last().tool_pose) - at_start).norm(), 1e-6) << "a refused goal moves nothing";
      if (old_ok) {
        EXPECT_NE(text.find("leaves the workspace"), std::string::npos)
            << "aim (" << aim.transpose() << ") reachable the Cartesian way, refused: " << text;
      }
    }
  }
  std::printf(
      "%zu re-orientations from home: the Cartesian way stalls on %d, the new way completes %d of those; "
      "%d run in joint space, %d refused as unreachable, %d lost (reached before, not now) in the tree region, "
      "%d beside the tool\n",
      aims.size(), cartesian_failed, rescued, joint_space, refused, lost, lost_beside);
  EXPECT_EQ(lost, 0);
  EXPECT_LE(lost_beside, 3);
}

// Going home is a known joint solution: the joint-space way to the home
// posture, whatever joints the arm is at; any other goal gets none.
TEST(RobotLinkNode, HomePoseGoalHasTheHomePostureAsItsJointWay) {
  const RobotLinkConfig c = default_config();
  const Eigen::Isometry3d home = kinematics::tool_pose(c.model, c.model.home);
  Eigen::VectorXd q = c.model.home;
  q[0] += 0.05;
  q[3] -= 0.1;
  q[5] += 0.1;
  const auto path = home_path(c, q, home);
  ASSERT_TRUE(path);
  EXPECT_TRUE(path->position(path->duration()).isApprox(c.model.home, 1e-12));
  EXPECT_TRUE(path->position(0.0).isApprox(q, 1e-12));
  Eigen::Isometry3d elsewhere = home;
  elsewhere.translation().y() += 0.05;
  EXPECT_FALSE(home_path(c, q, elsewhere));
}

TEST(RobotLinkNode, ShutdownStopsAndDisablesTheDrives) {
  Rig rig(default_config());
  rig.start();
  rig.run(0.5, every_20ms(rig, twist_command(0.05, 0.05, 0.0)));
  ASSERT_GT(rig.max_true_speed(), 0.01);
  rig.node().begin_shutdown();
  ASSERT_TRUE(rig.run_until([&] { return rig.node().shutdown_complete(); }, 3.0)) << rig.describe_last();
  rig.run(0.05);
  EXPECT_LT(rig.max_true_speed(), 1e-9);
  for (std::size_t i = 0; i < rig.drives().size(); ++i) {
    EXPECT_EQ(rig.drives().drive(i).state(), canopen::Cia402State::kSwitchOnDisabled) << i;
    EXPECT_EQ(rig.drives().drive(i).nmt_state(), canopen::NmtState::kStopped) << i;
  }
}

TEST(RobotLinkNode, ShutdownWhileFaultedCompletesAndDisablesTheHealthyDrives) {
  Rig rig(default_config());
  rig.start();
  rig.run(0.3, every_20ms(rig, twist_command(0.05, 0.05, 0.0)));
  rig.drives().drive(2).inject_fault(0x2310);
  ASSERT_TRUE(rig.run_until([&] { return rig.last().mode == +robot_state_t::MODE_FAULT; }, 0.5));
  rig.node().begin_shutdown();
  ASSERT_TRUE(rig.run_until([&] { return rig.node().shutdown_complete(); }, 2.0)) << rig.describe_last();
  rig.run(0.05);
  EXPECT_LT(rig.max_true_speed(), 1e-9);
  for (std::size_t i = 0; i < rig.drives().size(); ++i) {
    const auto want = i == 2 ? canopen::Cia402State::kFault : canopen::Cia402State::kSwitchOnDisabled;
    EXPECT_EQ(rig.drives().drive(i).state(), want) << i;
    EXPECT_EQ(rig.drives().drive(i).nmt_state(), canopen::NmtState::kStopped) << i;
  }
}

}  // namespace
}  // namespace harvest::arm
