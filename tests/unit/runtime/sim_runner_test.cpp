// rt::SimRunner, the in-memory runner of the unit tests, delivers in exactly
// ReplayRunner's order: the same events through the same nodes give the same
// published messages, at the same times, in the same order.
#include "runtime/sim_runner.hpp"

#include <gtest/gtest.h>

#include "runtime/log_io.hpp"
#include "runtime/replay_runner.hpp"
#include "test_nodes.hpp"
#include "test_support.hpp"

using namespace harvest;
namespace ht = harvest::testing;

namespace {

constexpr rt::Micros kT0 = 1'700'000'000'000'000;

// IR readings at 30 Hz with unrelated traffic, a burst at one instant, and a
// reading exactly on a 100 ms tick (timer and message at the same time).
std::vector<rt::LogRecord> make_input() {
  std::vector<rt::LogRecord> in;
  for (int i = 0; i < 45; ++i) {
    const rt::Micros t = kT0 + i * 33'333;
    in.push_back({t, "IN", rt::encode(ht::make_ir(t - 2000, i, 0.01f * i))});
    if (i % 7 == 0) in.push_back({t + 5, "OTHER", std::vector<uint8_t>{1, 2, 3}});
  }
  in.push_back({kT0 + 1'500'000, "IN", rt::encode(ht::make_ir(kT0, 100, 1.0f))});
  in.push_back({kT0 + 1'500'000, "IN", rt::encode(ht::make_ir(kT0, 101, 1.1f))});
  std::stable_sort(in.begin(), in.end(), [](const auto& a, const auto& b) { return a.timestamp < b.timestamp; });
  return in;
}

// Two chained nodes: IN -> MID (and TICK every 100 ms) -> OUT (and its own TICK2).
struct Graph {
  ht::ScaleNode first{"IN", "MID", 2.0};
  ht::ScaleNode second{"MID", "OUT", 0.5, false};
  std::vector<rt::Node*> nodes() { return {&first, &second}; }
};

std::vector<rt::LogRecord> published_only(const std::vector<rt::LogRecord>& all) {
  std::vector<rt::LogRecord> out;
  for (const auto& r : all)
    if (r.channel != "IN" && r.channel != "OTHER") out.push_back(r);
  return out;
}

std::vector<rt::LogRecord> through_replay(const std::vector<rt::LogRecord>& input, rt::Micros tail) {
  ht::TempDir dir;
  rt::write_log(dir / "in.log", input);
  rt::ReplayOptions opt;
  opt.input_log = dir / "in.log";
  opt.output_log = dir / "out.log";
  opt.tail = tail;
  rt::ReplayRunner runner(opt);
  Graph g;
  for (auto* n : g.nodes()) runner.add(*n);
  runner.run();
  return rt::read_log(dir / "out.log");
}

std::vector<rt::LogRecord> through_sim(const std::vector<rt::LogRecord>& input, rt::Micros tail) {
  rt::SimRunner sim(input.front().timestamp);
  Graph g;
  for (auto* n : g.nodes()) sim.add(*n);
  sim.start();
  for (const auto& r : input) {
    sim.run_until(r.timestamp);
    sim.inject_raw(r.channel, r.data);
  }
  sim.run_until(input.back().timestamp + tail);
  return published_only(sim.log());
}

TEST(SimRunner, DeliversInExactlyReplayRunnersOrder) {
  const auto input = make_input();
  const auto replayed = through_replay(input, 250 * rt::kMilli);
  const auto simulated = through_sim(input, 250 * rt::kMilli);
  ASSERT_GT(replayed.size(), 100u);
  int mid = 0, out = 0, tick = 0;
  for (const auto& r : replayed) (r.channel == "MID" ? mid : r.channel == "OUT" ? out : tick)++;
  EXPECT_EQ(mid, 47);
  EXPECT_EQ(out, 47);
  EXPECT_EQ(tick, 17);  // 0 .. 1.6 s plus the tail, every 100 ms
  EXPECT_EQ(rt::first_difference(replayed, simulated), std::nullopt);
}

// The comparison can fail: a runner that delivered a timer's messages only
// after the next input would differ from replay.
TEST(SimRunner, AChangedOrderIsSeen) {
  const auto input = make_input();
  auto simulated = through_sim(input, 0);
  std::swap(simulated[3], simulated[4]);
  EXPECT_NE(rt::first_difference(through_replay(input, 0), simulated), std::nullopt);
}

TEST(SimRunner, KeepsInjectedAndPublishedMessagesInBusOrder) {
  rt::SimRunner sim(kT0);
  ht::ScaleNode node("IN", "OUT", 3.0, false);
  sim.add(node);
  sim.start();
  sim.inject("IN", ht::make_ir(kT0, 1, 0.5f));
  sim.inject_raw("IN", {0xde, 0xad});  // garbage: dropped by the runtime, kept on the bus record
  sim.run_until(kT0 + 10);
  sim.inject("IN", ht::make_ir(kT0 + 10, 2, 0.25f));
  ASSERT_EQ(sim.log().size(), 5u);
  EXPECT_EQ(sim.log()[0].channel, "IN");
  EXPECT_EQ(sim.log()[1].channel, "OUT");
  EXPECT_EQ(sim.log()[2].channel, "IN");
  EXPECT_EQ(sim.log()[4].timestamp, kT0 + 10);
  const auto outs = sim.messages<harvest::ir_range_t>("OUT");
  ASSERT_EQ(outs.size(), 2u);
  EXPECT_FLOAT_EQ(outs[1].second.range_m, 0.75f);
  EXPECT_EQ(sim.messages<harvest::ir_range_t>("IN").size(), 2u) << "the garbage is not a message";
  EXPECT_EQ(node.received, 2);
}

// A node reading a device: its descriptor is offered on poll() at the current
// time, each callback's messages delivered before the next; a node that
// stops watching (its device closed) is not offered it again.
class DeviceNode final : public rt::Node {
 public:
  DeviceNode() : rt::Node("device") {}
  int reads = 0;
  bool close_after_read = false;

 protected:
  void on_attach() override {
    advertise("DEVICE");
    ctx().watch_fd(7, [this] {
      ++reads;
      auto m = ht::make_ir(now(), reads, 0.1f * reads);
      publish("DEVICE", m);
      if (close_after_read) ctx().unwatch_fd(7);
    });
  }
};

TEST(SimRunner, WatchedDescriptorsAreOfferedOnPollAndNotAfterUnwatch) {
  rt::SimRunner sim(kT0);
  DeviceNode device;
  ht::ScaleNode reader("DEVICE", "OUT", 2.0, false);
  sim.add(device);
  sim.add(reader);
  sim.start();
  EXPECT_TRUE(sim.watching());
  EXPECT_EQ(device.reads, 0) << "nothing offered before a poll";
  sim.run_until(kT0 + 1000);
  sim.poll();
  ASSERT_EQ(device.reads, 1);
  const auto outs = sim.messages<harvest::ir_range_t>("OUT");
  ASSERT_EQ(outs.size(), 1u) << "the device's message reached the reader within the poll";
  EXPECT_EQ(outs[0].first, kT0 + 1000);
  device.close_after_read = true;
  sim.poll();
  sim.poll();
  EXPECT_EQ(device.reads, 2);
  EXPECT_FALSE(sim.watching());
}

}  // namespace
