// The same node live over LCM and replayed from the recorded inputs must
// publish the same messages; a real process honours its command line,
// configuration errors, heartbeat and SIGTERM.
#include <gtest/gtest.h>

#include <atomic>
#include <fstream>
#include <harvest/config_snapshot_t.hpp>
#include <harvest/process_status_t.hpp>
#include <lcm/lcm-cpp.hpp>
#include <mutex>
#include <thread>

#include "../../unit/runtime/test_nodes.hpp"
#include "runtime/live_runner.hpp"
#include "runtime/log_io.hpp"
#include "runtime/replay_runner.hpp"
#include "test_support.hpp"

using namespace harvest;
namespace ht = harvest::testing;
using namespace std::chrono_literals;

namespace {

// Records every message on the bus, like lcm-logger, in its own thread.
class Recorder {
 public:
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
  std::vector<rt::LogRecord> on(const std::string& channel) {
    std::lock_guard<std::mutex> lock(mutex_);
    std::vector<rt::LogRecord> out;
    for (const auto& r : records_)
      if (r.channel == channel) out.push_back(r);
    return out;
  }

 private:
  static void on_message(const lcm::ReceiveBuffer* rb, const std::string& channel, Recorder* self) {
    const auto* p = static_cast<const uint8_t*>(rb->data);
    std::lock_guard<std::mutex> lock(self->mutex_);
    self->records_.push_back({rb->recv_utime, channel, std::vector<uint8_t>(p, p + rb->data_size)});
  }
  lcm::LCM lcm_;
  std::mutex mutex_;
  std::vector<rt::LogRecord> records_;
  std::atomic<bool> stop_{false};
  std::thread thread_;
};

// publish_utime is when a message left its publisher: the one field that
// legitimately differs between live and replay.
std::vector<uint8_t> without_publish_time(const std::vector<uint8_t>& bytes) {
  auto m = rt::decode<ir_range_t>(bytes);
  EXPECT_TRUE(m);
  m->header.publish_utime = 0;
  return rt::encode(*m);
}

}  // namespace

TEST(LiveAndReplay, SameNodeSameMessages) {
  const std::string url = ht::unique_lcm_url();
  Recorder recorder(url);
  ht::ScaleNode live_node("IN", "OUT", 1.5, false);
  rt::LiveRunner runner(rt::LiveOptions{url, ""});
  runner.add(live_node);
  std::thread live([&] { runner.run(); });

  lcm::LCM pub(url);
  ASSERT_TRUE(pub.good());
  // Give the runner time to subscribe before the first input.
  std::this_thread::sleep_for(200ms);
  constexpr int kN = 40;
  for (int i = 0; i < kN; ++i) {
    auto m = ht::make_ir(rt::wall_time_now(), i, 0.01f * i);
    pub.publish("IN", &m);
    std::this_thread::sleep_for(3ms);
  }
  EXPECT_TRUE(ht::eventually([&] { return recorder.on("OUT").size() == kN; }, 5s));
  runner.request_stop(0);
  live.join();

  ht::TempDir dir;
  rt::write_log(dir / "in.log", recorder.on("IN"));
  ht::ScaleNode replay_node("IN", "OUT", 1.5, false);
  rt::ReplayOptions options;
  options.input_log = dir / "in.log";
  options.output_log = dir / "out.log";
  rt::ReplayRunner replay(options);
  replay.add(replay_node);
  replay.run();

  const auto live_out = recorder.on("OUT");
  const auto replay_out = rt::read_log(dir / "out.log");
  ASSERT_EQ(live_out.size(), size_t(kN));
  ASSERT_EQ(replay_out.size(), size_t(kN));
  for (int i = 0; i < kN; ++i)
    EXPECT_EQ(without_publish_time(live_out[i].data), without_publish_time(replay_out[i].data)) << "message " << i;
}

class ProcessTest : public ::testing::Test {
 protected:
  ht::TempDir dir;
  std::string write(const std::string& name, const std::string& text) {
    std::ofstream(dir / name) << text;
    return (dir / name).string();
  }
  int run_to_end(const std::vector<std::string>& args, std::string* output) {
    ht::ChildProcess p(args, dir / "out.txt");
    const int rc = p.wait(20s);
    *output = p.output();
    return rc;
  }
};

TEST_F(ProcessTest, BadConfigurationExitsBeforeStartingAndNamesTheKey) {
  std::string out;
  const auto bad = write("bad.yaml", "gain: abc\n");
  EXPECT_EQ(run_to_end({ht::test_bin("harvest-test-scale"), "--config", bad, "--no-netcheck"}, &out), 2);
  EXPECT_NE(out.find("bad.yaml: gain: expected a number"), std::string::npos) << out;

  const auto typo = write("typo.yaml", "gain: 1\ngian: 2\n");
  EXPECT_EQ(run_to_end({ht::test_bin("harvest-test-scale"), "--config", typo}, &out), 2);
  EXPECT_NE(out.find("unknown key: gian"), std::string::npos) << out;

  const auto range = write("range.yaml", "gain: 1000\n");
  EXPECT_EQ(run_to_end({ht::test_bin("harvest-test-scale"), "--config", range}, &out), 2);
  EXPECT_NE(out.find("gain: expected a number in"), std::string::npos) << out;

  EXPECT_EQ(run_to_end({ht::test_bin("harvest-test-scale"), "--config", (dir / "missing.yaml").string()}, &out), 2);
  EXPECT_NE(out.find("missing.yaml: configuration file not found"), std::string::npos) << out;

  EXPECT_EQ(run_to_end({ht::test_bin("harvest-test-scale"), "--bogus-flag"}, &out), 2);
}

TEST_F(ProcessTest, CheckConfigPrintsTheEffectiveConfiguration) {
  std::string out;
  const auto cfg = write("ok.yaml", "gain: 2\n");
  EXPECT_EQ(
      run_to_end({ht::test_bin("harvest-test-scale"), "--config", cfg, "--set", "output=SCALED", "--check-config"},
                 &out),
      0);
  EXPECT_NE(out.find("gain: 2"), std::string::npos) << out;
  EXPECT_NE(out.find("output: SCALED"), std::string::npos) << out;
  EXPECT_NE(out.find("input: IN"), std::string::npos) << out;  // default, made explicit
}

TEST_F(ProcessTest, LiveProcessHeartbeatsProcessesAndStopsOnSigterm) {
  const std::string url = ht::unique_lcm_url();
  Recorder recorder(url);
  const auto cfg = write("ok.yaml", "gain: 3\n");
  ht::ChildProcess p({ht::test_bin("harvest-test-scale"), "--config", cfg, "--lcm-url", url, "--prefix", "ARM2_",
                      "--instance", "scale-a"},
                     dir / "proc.txt");
  ASSERT_TRUE(ht::eventually([&] { return !recorder.on("ARM2_PROCESS_STATUS").empty(); }, 10s)) << p.output();
  const auto cfgmsg = recorder.on("ARM2_CONFIG");
  ASSERT_EQ(cfgmsg.size(), 1u);
  auto snapshot = rt::decode<config_snapshot_t>(cfgmsg[0].data);
  EXPECT_EQ(snapshot->instance, "scale-a");
  EXPECT_NE(snapshot->yaml.find("gain: 3"), std::string::npos);

  lcm::LCM pub(url);
  auto m = ht::make_ir(rt::wall_time_now(), 1, 0.5f);
  // Sent again every 0.5 s until answered: on a loaded machine a first
  // datagram can go out before the process's subscription is in place.
  int polls = 0;
  ASSERT_TRUE(ht::eventually(
      [&] {
        if (polls++ % 50 == 0) pub.publish("ARM2_IN", &m);
        return !recorder.on("ARM2_OUT").empty();
      },
      10s))
      << p.output();
  EXPECT_FLOAT_EQ(rt::decode<ir_range_t>(recorder.on("ARM2_OUT")[0].data)->range_m, 1.5f);
  std::this_thread::sleep_for(600ms);  // an answer to a repeat still on its way
  const std::size_t answered = recorder.on("ARM2_OUT").size();
  // Unprefixed channels are someone else's arm.
  pub.publish("IN", &m);

  // Malformed messages on a subscribed channel: counted, reported, no crash.
  const uint8_t garbage[] = {1, 2, 3, 4, 5};
  pub.publish("ARM2_IN", garbage, sizeof garbage);
  auto truncated = rt::encode(m);
  pub.publish("ARM2_IN", truncated.data(), static_cast<unsigned>(truncated.size() - 3));
  pub.publish("ARM2_IN", &m);  // and the next good one is still processed
  ASSERT_TRUE(ht::eventually([&] { return recorder.on("ARM2_OUT").size() == answered + 1; }, 5s)) << p.output();
  ASSERT_TRUE(ht::eventually(
      [&] {
        auto s = rt::decode<process_status_t>(recorder.on("ARM2_PROCESS_STATUS").back().data);
        return s->decode_errors == 2;
      },
      5s));
  const auto status = rt::decode<process_status_t>(recorder.on("ARM2_PROCESS_STATUS").back().data);
  EXPECT_EQ(status->state, +process_status_t::STATE_DEGRADED);
  EXPECT_NE(status->message.find("2 malformed messages dropped"), std::string::npos) << status->message;
  EXPECT_EQ(status->pid, p.pid());
  EXPECT_EQ(status->process, "harvest-test-scale");
  EXPECT_TRUE(p.running());
  EXPECT_EQ(p.stop(5s), 0) << p.output();
  EXPECT_EQ(recorder.on("ARM2_OUT").size(), answered + 1);
  EXPECT_NE(p.output().find("dropped malformed message on IN"), std::string::npos) << p.output();
}
