// harvest-servo-controller as a real process over real LCM. The scripted peer
// is the closed-loop harness's arm and world doubles (tests/unit/servo/
// sim_harness.hpp) running live in this test on an rt::LiveRunner: it
// publishes ROBOT_STATE, TARGETS (fixed and hand), FRUIT_HAND, IR_RANGE and
// GRIPPER_STATE and executes the ROBOT_COMMAND and GRIPPER_COMMAND it gets.
// Operator commands and emergency stops are sent with the harvest-operator
// tool, as a field engineer would.
#include <gtest/gtest.h>

#include <atomic>
#include <harvest/emergency_stop_t.hpp>
#include <harvest/gripper_command_t.hpp>
#include <harvest/harvest_status_t.hpp>
#include <harvest/robot_command_t.hpp>
#include <harvest/robot_state_t.hpp>
#include <lcm/lcm-cpp.hpp>
#include <mutex>
#include <optional>
#include <thread>

#include "runtime/channels.hpp"
#include "runtime/live_runner.hpp"
#include "runtime/log_io.hpp"
#include "servo/geometry.hpp"
#include "sim_harness.hpp"
#include "test_support.hpp"

namespace ht = harvest::testing;
namespace ch = harvest::channels;
using namespace harvest;
using namespace std::chrono_literals;

namespace {

// Every message on the bus in arrival order, received in a thread of its own.
class Recorder {
 public:
  struct Record {
    std::string channel;
    std::vector<uint8_t> data;
  };
  explicit Recorder(const std::string& url) : lcm_(url) {
    lcm_.subscribeFunction(".*", &Recorder::on_message, this);
    thread_ = std::thread([this] {
      while (!stop_) lcm_.handleTimeout(20);
    });
  }
  ~Recorder() {
    stop_ = true;
    thread_.join();
  }
  bool good() { return lcm_.good(); }
  std::vector<Record> records() {
    std::lock_guard<std::mutex> lock(mutex_);
    return records_;
  }
  std::size_t size() {
    std::lock_guard<std::mutex> lock(mutex_);
    return records_.size();
  }
  // Decoded messages on `channel` received at or after index `from`.
  template <class Msg>
  std::vector<Msg> on(const std::string& channel, std::size_t from = 0) {
    std::vector<Msg> out;
    const auto all = records();
    for (std::size_t i = from; i < all.size(); ++i)
      if (all[i].channel == channel)
        if (auto m = rt::decode<Msg>(all[i].data)) out.push_back(*m);
    return out;
  }
  template <class Msg>
  std::optional<Msg> last(const std::string& channel) {
    const auto all = on<Msg>(channel);
    if (all.empty()) return std::nullopt;
    return all.back();
  }

 private:
  static void on_message(const lcm::ReceiveBuffer* rb, const std::string& channel, Recorder* self) {
    const auto* p = static_cast<const uint8_t*>(rb->data);
    std::lock_guard<std::mutex> lock(self->mutex_);
    self->records_.push_back({channel, std::vector<uint8_t>(p, p + rb->data_size)});
  }
  lcm::LCM lcm_;
  std::mutex mutex_;
  std::vector<Record> records_;
  std::atomic<bool> stop_{false};
  std::thread thread_;
};

Eigen::Vector3d linear(const robot_command_t& c) { return {c.twist.linear[0], c.twist.linear[1], c.twist.linear[2]}; }

bool is_motion(const robot_command_t& c) {
  return c.type == robot_command_t::TYPE_POSE_GOAL || (c.type == robot_command_t::TYPE_TWIST && linear(c).norm() > 0.0);
}

class ServoProcess : public ::testing::Test {
 protected:
  void SetUp() override {
    url_ = ht::unique_lcm_url();
    recorder_ = std::make_unique<Recorder>(url_);
    ASSERT_TRUE(recorder_->good());
    spec_ = servo::testing::experiment_one();
    arm_ = std::make_unique<servo::testing::ArmDouble>(spec_);
    world_ = std::make_unique<servo::testing::WorldDouble>(spec_, *arm_);
    peer_ = std::make_unique<rt::LiveRunner>(rt::LiveOptions{url_, ""});
    peer_->add(*arm_);
    peer_->add(*world_);
    peer_thread_ = std::thread([this] { peer_->run(); });
    controller_.emplace(
        std::vector<std::string>{ht::bin("harvest-servo-controller"), "--config",
                                 ht::source_path("config/servo/controller.yaml"), "--lcm-url", url_, "--no-netcheck"},
        dir_ / "servo-controller.log");
    // Up and fed: an IDLE status derived from a robot state (its header
    // carries the newest robot state's time; 0 before the first one).
    ASSERT_TRUE(wait_status([](const harvest_status_t& s) { return s.state == "IDLE" && s.header.utime != 0; }, 10s))
        << controller_->output();
  }

  void TearDown() override {
    if (controller_) {
      const bool was_running = controller_->running();
      const int rc = controller_->stop(5s);
      if (was_running) {
        EXPECT_EQ(rc, 0) << controller_->output();
      }
    }
    if (peer_) {
      peer_->request_stop(0);
      peer_thread_.join();
    }
    if (HasFailure() && controller_) std::cerr << controller_->output();
  }

  // Runs harvest-operator to completion (it waits for the controller's
  // acknowledgement); true if it exited with `expected_rc` (0 acknowledged,
  // 4 refused). Each call is its own sender, as each invocation is live.
  bool operate(const std::string& verb, int expected_rc = 0) {
    const std::string source = "integration-test-" + std::to_string(++operations_);
    ht::ChildProcess op({ht::bin("harvest-operator"), verb, "--lcm-url", url_, "--source", source, "--timeout", "5"},
                        dir_ / ("operator-" + verb + "-" + std::to_string(operations_) + ".log"));
    const int rc = op.wait(10s);
    EXPECT_EQ(rc, expected_rc) << op.output();
    if (expected_rc == 4) EXPECT_NE(op.output().find(verb + ": REFUSED by the servo controller"), std::string::npos);
    if (expected_rc == 0) EXPECT_NE(op.output().find(verb + ": acknowledged by the servo controller"), std::string::npos);
    return rc == expected_rc;
  }
  int operations_ = 0;

  bool wait_status(const std::function<bool(const harvest_status_t&)>& pred, std::chrono::milliseconds timeout) {
    return ht::eventually(
        [&] {
          const auto s = recorder_->last<harvest_status_t>(ch::kHarvestStatus);
          return s && pred(*s);
        },
        timeout);
  }

  bool wait_motion(std::size_t from, std::chrono::milliseconds timeout) {
    return ht::eventually(
        [&] {
          for (const auto& c : recorder_->on<robot_command_t>(ch::kRobotCommand, from))
            if (is_motion(c)) return true;
          return false;
        },
        timeout);
  }

  // Index of the first HARVEST_STATUS at or after `from` that satisfies pred.
  std::optional<std::size_t> first_status(std::size_t from, const std::function<bool(const harvest_status_t&)>& pred) {
    const auto all = recorder_->records();
    for (std::size_t i = from; i < all.size(); ++i)
      if (all[i].channel == ch::kHarvestStatus)
        if (auto s = rt::decode<harvest_status_t>(all[i].data); s && pred(*s)) return i;
    return std::nullopt;
  }

  Eigen::Vector3d tool_now() {
    const auto s = recorder_->last<robot_state_t>(ch::kRobotState);
    if (!s) return Eigen::Vector3d::Zero();
    return servo::to_isometry(s->tool_pose).translation();
  }

  std::string url_;
  ht::TempDir dir_;
  std::unique_ptr<Recorder> recorder_;
  servo::testing::WorldSpec spec_;
  std::unique_ptr<servo::testing::ArmDouble> arm_;
  std::unique_ptr<servo::testing::WorldDouble> world_;
  std::unique_ptr<rt::LiveRunner> peer_;
  std::thread peer_thread_;
  std::optional<ht::ChildProcess> controller_;
};

TEST_F(ServoProcess, StartLeadsToMotionCommandsAndAPickWithinTheSpeedLimit) {
  EXPECT_TRUE(recorder_->on<robot_command_t>(ch::kRobotCommand).empty()) << "no motion before START";
  const std::size_t before = recorder_->size();
  ASSERT_TRUE(operate("start"));
  ASSERT_TRUE(wait_motion(before, 5s));
  ASSERT_TRUE(wait_status([](const harvest_status_t& s) { return s.picked == 1; }, 40s))
      << recorder_->last<harvest_status_t>(ch::kHarvestStatus)->summary;
  const auto status = *recorder_->last<harvest_status_t>(ch::kHarvestStatus);
  ASSERT_EQ(status.num_outcomes, 1);
  EXPECT_EQ(status.outcomes[0].fruit_id, 1);
  EXPECT_EQ(status.outcomes[0].outcome, +fruit_outcome_t::PICKED);
  const auto commands = recorder_->on<robot_command_t>(ch::kRobotCommand);
  double fastest = 0.0;
  int twists = 0, goals = 0;
  for (const auto& c : commands) {
    fastest = std::max(fastest, linear(c).norm());
    EXPECT_LE(linear(c).norm(), 0.381 + 1e-9);
    EXPECT_EQ(c.validity_us, 100'000);
    twists += c.type == robot_command_t::TYPE_TWIST;
    goals += c.type == robot_command_t::TYPE_POSE_GOAL;
  }
  EXPECT_GT(twists, 0);
  EXPECT_GT(goals, 0);
  // A one-line summary in the process's log on each change (complete once it has stopped).
  EXPECT_EQ(controller_->stop(5s), 0);
  // The fruit is let go as the retreat begins (release_while_retreating): DETACH, then RETREAT with it picked.
  EXPECT_NE(controller_->output().find("DETACH fruit 1 | picked 0"), std::string::npos) << controller_->output();
  EXPECT_NE(controller_->output().find("RETREAT | picked 1, lost 0"), std::string::npos) << controller_->output();
  std::printf("live: %zu commands (%d twist, %d pose goal), fastest %.4f m/s, cycle %.2f s\n", commands.size(), twists,
              goals, fastest, status.outcomes[0].cycle_time_s);
}

TEST_F(ServoProcess, EmergencyStopPublishesStopAndNothingElseUntilCleared) {
  ASSERT_TRUE(operate("start"));
  ASSERT_TRUE(wait_motion(0, 5s));
  // Let the approach get under way, then stop it.
  ASSERT_TRUE(wait_status([](const harvest_status_t& s) { return s.state == "APPROACH"; }, 15s));
  const std::size_t before = recorder_->size();
  ASSERT_TRUE(operate("estop"));
  ASSERT_TRUE(wait_status([](const harvest_status_t& s) { return s.estop; }, 5s));
  std::this_thread::sleep_for(300ms);
  const Eigen::Vector3d held = tool_now();
  ASSERT_TRUE(operate("start", 4));  // refused while latched, and harvest-operator says so
  ASSERT_TRUE(operate("home", 4));   // refused while latched
  std::this_thread::sleep_for(1s);
  EXPECT_LT((tool_now() - held).norm(), 1e-9) << "the arm moved while the e-stop was latched";
  const std::size_t latched_end = recorder_->size();

  // The STOP went out with the e-stop itself (before the status that reports it),
  // then only STOP, never a gripper command, until cleared.
  const auto engaged = first_status(before, [](const harvest_status_t& s) { return s.estop; });
  ASSERT_TRUE(engaged);
  const auto all = recorder_->records();
  std::optional<robot_command_t> just_before;
  for (std::size_t i = before; i < *engaged; ++i)
    if (all[i].channel == ch::kRobotCommand) just_before = rt::decode<robot_command_t>(all[i].data);
  ASSERT_TRUE(just_before);
  EXPECT_EQ(just_before->type, +robot_command_t::TYPE_STOP);
  int stops = 0;
  for (std::size_t i = *engaged; i < latched_end; ++i) {
    EXPECT_NE(all[i].channel, ch::kGripperCommand);
    if (all[i].channel != ch::kRobotCommand) continue;
    const auto c = *rt::decode<robot_command_t>(all[i].data);
    EXPECT_EQ(c.type, +robot_command_t::TYPE_STOP);
    ++stops;
  }
  EXPECT_GE(stops, 10) << "the latched controller keeps sending STOP at its tick rate";
  const auto latched = *recorder_->last<harvest_status_t>(ch::kHarvestStatus);
  EXPECT_EQ(latched.state, "ESTOP");
  EXPECT_NE(latched.summary.find("command refused: emergency stop latched"), std::string::npos) << latched.summary;
  ASSERT_EQ(latched.num_outcomes, 1);
  EXPECT_EQ(latched.outcomes[0].outcome, +fruit_outcome_t::ABORTED);
  EXPECT_EQ(latched.outcomes[0].detail, "emergency stop");

  // Cleared explicitly: IDLE, and a new START moves the arm again.
  ASSERT_TRUE(operate("estop-clear"));
  ASSERT_TRUE(wait_status([](const harvest_status_t& s) { return !s.estop && s.state == "IDLE"; }, 5s));
  const std::size_t cleared = recorder_->size();
  ASSERT_TRUE(operate("start"));
  EXPECT_TRUE(wait_motion(cleared, 5s));
}

TEST_F(ServoProcess, OperatorPauseResumeAbortAndHomeAreObeyed) {
  ASSERT_TRUE(operate("start"));
  ASSERT_TRUE(wait_status([](const harvest_status_t& s) { return s.state == "APPROACH"; }, 15s));
  const Eigen::Vector3d home = servo::testing::thesis_start_pose().translation();
  ASSERT_TRUE(ht::eventually([&] { return (tool_now() - home).norm() > 0.05; }, 10s)) << "the approach did not move";

  ASSERT_TRUE(operate("pause"));
  ASSERT_TRUE(wait_status([](const harvest_status_t& s) { return s.paused; }, 5s));
  const std::size_t paused = recorder_->size();
  std::this_thread::sleep_for(200ms);
  const Eigen::Vector3d held = tool_now();
  std::this_thread::sleep_for(800ms);
  EXPECT_LT((tool_now() - held).norm(), 1e-9) << "the arm moved while paused";
  const auto while_paused = recorder_->on<robot_command_t>(ch::kRobotCommand, paused);
  EXPECT_GE(while_paused.size(), 10u);
  for (const auto& c : while_paused) EXPECT_EQ(c.type, +robot_command_t::TYPE_STOP);

  const std::size_t resumed = recorder_->size();
  ASSERT_TRUE(operate("resume"));
  ASSERT_TRUE(wait_status([](const harvest_status_t& s) { return !s.paused; }, 5s));
  EXPECT_TRUE(wait_motion(resumed, 5s));

  ASSERT_TRUE(operate("abort"));
  ASSERT_TRUE(wait_status([](const harvest_status_t& s) { return s.state == "IDLE"; }, 5s));
  const auto aborted = *recorder_->last<harvest_status_t>(ch::kHarvestStatus);
  ASSERT_EQ(aborted.num_outcomes, 1);
  EXPECT_EQ(aborted.outcomes[0].outcome, +fruit_outcome_t::ABORTED);
  EXPECT_EQ(aborted.outcomes[0].detail, "operator abort");
  std::this_thread::sleep_for(300ms);
  EXPECT_EQ(recorder_->last<robot_command_t>(ch::kRobotCommand)->type, +robot_command_t::TYPE_STOP);
  EXPECT_GT((tool_now() - home).norm(), 0.05);

  ASSERT_TRUE(operate("home"));
  ASSERT_TRUE(wait_status([](const harvest_status_t& s) { return s.state == "HOMING"; }, 5s));
  ASSERT_TRUE(wait_status([](const harvest_status_t& s) { return s.state == "IDLE"; }, 20s));
  EXPECT_LT((tool_now() - home).norm(), 0.005);
}

// Nobody listening: harvest-operator says so and fails, instead of "sent".
TEST(Operator, FailsWhenNobodyAnswers) {
  ht::TempDir dir;
  ht::ChildProcess op({ht::bin("harvest-operator"), "start", "--lcm-url", ht::unique_lcm_url(), "--timeout", "0.5"},
                      dir / "operator.log");
  EXPECT_EQ(op.wait(10s), 3) << op.output();
  EXPECT_NE(op.output().find("start: nobody answered within 0.5 s (no HARVEST_STATUS from a servo controller)"),
            std::string::npos)
      << op.output();
  ht::ChildProcess fire({ht::bin("harvest-operator"), "estop", "--lcm-url", ht::unique_lcm_url(), "--no-wait"},
                        dir / "fire.log");
  EXPECT_EQ(fire.wait(10s), 0) << fire.output();  // --no-wait: sent is all it knows
}

}  // namespace
