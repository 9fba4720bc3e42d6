#include <gtest/gtest.h>

#include <fstream>
#include <harvest/config_snapshot_t.hpp>
#include <harvest/gripper_state_t.hpp>
#include <harvest/process_status_t.hpp>

#include "runtime/heartbeat.hpp"
#include "runtime/log_io.hpp"
#include "runtime/replay_runner.hpp"
#include "test_nodes.hpp"
#include "test_support.hpp"

using namespace harvest;
namespace ht = harvest::testing;
using harvest::testing::ScaleNode;
using harvest::testing::TempDir;

namespace {

constexpr rt::Micros kT0 = 1'700'000'000'000'000;

// An input log: IR readings at 30 Hz for 2 s, with unrelated traffic mixed in.
std::vector<rt::LogRecord> make_input(int n = 60) {
  std::vector<rt::LogRecord> in;
  for (int i = 0; i < n; ++i) {
    const rt::Micros t = kT0 + i * 33'333;
    in.push_back({t, "IN", rt::encode(ht::make_ir(t - 2000, i, 0.01f * i))});
    if (i % 7 == 0) in.push_back({t + 5, "OTHER", std::vector<uint8_t>{1, 2, 3}});
  }
  return in;
}

rt::ReplayResult replay(const std::string& in, const std::string& out, std::vector<rt::Node*> nodes,
                        rt::Micros tail = 0) {
  rt::ReplayOptions opt;
  opt.input_log = in;
  opt.output_log = out;
  opt.tail = tail;
  rt::ReplayRunner runner(opt);
  for (auto* n : nodes) runner.add(*n);
  return runner.run();
}

std::vector<rt::LogRecord> on_channel(const std::vector<rt::LogRecord>& all, const std::string& ch) {
  std::vector<rt::LogRecord> out;
  for (const auto& r : all)
    if (r.channel == ch) out.push_back(r);
  return out;
}

}  // namespace

TEST(Replay, SameLogTwiceGivesByteIdenticalOutput) {
  TempDir dir;
  rt::write_log(dir / "in.log", make_input());
  ScaleNode a("IN", "OUT", 2.0), b("IN", "OUT", 2.0);
  replay(dir / "in.log", dir / "out1.log", {&a});
  replay(dir / "in.log", dir / "out2.log", {&b});
  const auto o1 = rt::read_log(dir / "out1.log");
  const auto o2 = rt::read_log(dir / "out2.log");
  ASSERT_FALSE(o1.empty());
  EXPECT_EQ(rt::first_difference(o1, o2), std::nullopt);
}

TEST(Replay, ANodeThatReadsTheWallClockIsCaught) {
  TempDir dir;
  rt::write_log(dir / "in.log", make_input());
  ht::WallClockNode a("IN", "OUT", 2.0), b("IN", "OUT", 2.0);
  replay(dir / "in.log", dir / "out1.log", {&a});
  // Make sure the wall clock moves between the two replays.
  struct timespec ts {
    0, 2'000'000
  };
  nanosleep(&ts, nullptr);
  replay(dir / "in.log", dir / "out2.log", {&b});
  const auto diff = rt::first_difference(rt::read_log(dir / "out1.log"), rt::read_log(dir / "out2.log"));
  ASSERT_TRUE(diff.has_value());
  EXPECT_NE(diff->find("OUT"), std::string::npos) << *diff;
}

TEST(Replay, DerivedMessagesCarryTheirInputsTimeAndSeq) {
  TempDir dir;
  rt::write_log(dir / "in.log", make_input());
  ScaleNode a("IN", "OUT", 2.0, false);
  const auto res = replay(dir / "in.log", dir / "out.log", {&a});
  EXPECT_EQ(res.events_delivered, 60);
  const auto out = on_channel(rt::read_log(dir / "out.log"), "OUT");
  ASSERT_EQ(out.size(), 60u);
  for (std::size_t i = 0; i < out.size(); ++i) {
    auto m = rt::decode<ir_range_t>(out[i].data);
    ASSERT_TRUE(m);
    const rt::Micros t = kT0 + static_cast<rt::Micros>(i) * 33'333;
    EXPECT_EQ(m->header.utime, t - 2000);         // sensing time of the input
    EXPECT_EQ(m->header.source_seq, int64_t(i));  // the input that caused it
    EXPECT_EQ(m->header.seq, int64_t(i));         // own per-channel sequence
    EXPECT_EQ(m->header.publish_utime, t);        // log time of the input
    EXPECT_EQ(out[i].timestamp, t);
    EXPECT_FLOAT_EQ(m->range_m, 0.02f * i);
  }
}

TEST(Replay, TimersFireAtLogTime) {
  TempDir dir;
  rt::write_log(dir / "in.log", make_input());
  ScaleNode a("IN", "OUT", 1.0);
  const auto res = replay(dir / "in.log", dir / "out.log", {&a});
  const auto ticks = on_channel(rt::read_log(dir / "out.log"), "TICK");
  // 59 * 33.333 ms of log = 1.967 s: ticks at t0 + 100 ms ... t0 + 1900 ms.
  ASSERT_EQ(ticks.size(), 19u);
  for (std::size_t k = 0; k < ticks.size(); ++k) {
    const rt::Micros due = kT0 + static_cast<rt::Micros>(k + 1) * 100'000;
    EXPECT_EQ(ticks[k].timestamp, due);
    EXPECT_EQ(rt::decode<ir_range_t>(ticks[k].data)->header.utime, due);
  }
  EXPECT_EQ(res.timers_fired, 19);
  // Ticks are interleaved with the inputs in time order.
  const auto all = rt::read_log(dir / "out.log");
  for (std::size_t i = 1; i < all.size(); ++i) EXPECT_LE(all[i - 1].timestamp, all[i].timestamp);
}

// make_input() plus 10 recorded OUT messages (value 9) 3 s in, as a log of a
// set whose first node published OUT would hold them.
void write_input_with_recorded_out(const std::filesystem::path& file) {
  auto in = make_input();
  for (int i = 0; i < 10; ++i) in.push_back({kT0 + 3'000'000 + i, "OUT", rt::encode(ht::make_ir(0, 999, 9.f))});
  std::sort(in.begin(), in.end(), [](auto& a, auto& b) { return a.timestamp < b.timestamp; });
  rt::write_log(file, in);
}

// Isolated (each node against the recording): the second node gets the
// recorded OUT at its recorded times, not the first node's regenerated one,
// and what the first publishes still goes to the output log.
TEST(Replay, IsolatedNodesReceiveTheRecordingNotEachOther) {
  TempDir dir;
  write_input_with_recorded_out(dir / "in.log");
  ScaleNode first("IN", "OUT", 2.0, false), second("OUT", "OUT2", 3.0, false);
  rt::ReplayOptions opt;
  opt.input_log = dir / "in.log";
  opt.output_log = dir / "out.log";
  opt.isolated = true;
  rt::ReplayRunner runner(opt);
  runner.add(first);
  runner.add(second);
  const auto res = runner.run();
  EXPECT_EQ(res.events_skipped, 0);
  EXPECT_EQ(first.received, 60);
  EXPECT_EQ(second.received, 10);  // the recorded OUT only
  const auto out = rt::read_log(dir / "out.log");
  EXPECT_EQ(on_channel(out, "OUT").size(), 60u);
  const auto out2 = on_channel(out, "OUT2");
  ASSERT_EQ(out2.size(), 10u);
  EXPECT_FLOAT_EQ(rt::decode<ir_range_t>(out2[0].data)->range_m, 27.f);
  EXPECT_EQ(out2[0].timestamp, kT0 + 3'000'000);
}

// A recording's process that started late (harvest-replay attaches it at its
// CONFIG snapshot's time): its replayed twin receives only what came after
// that moment and runs its timers from then, as it did live; a node added
// with a start before the log's first event is attached at that event.
TEST(Replay, ANodeAddedFromItsStartSeesWhatCameAfterAndTicksFromThen) {
  TempDir dir;
  rt::write_log(dir / "in.log", make_input());
  ScaleNode early("IN", "OUT", 2.0, false), late("IN", "OUT2", 3.0), before("IN", "OUT3", 1.0, false);
  rt::ReplayOptions opt;
  opt.input_log = dir / "in.log";
  opt.output_log = dir / "out.log";
  opt.isolated = true;
  rt::ReplayRunner runner(opt);
  const rt::Micros start = kT0 + 1'000'010;  // frame 30 is at kT0 + 999,990
  runner.add_from(late, start);
  runner.add(early);
  runner.add_from(before, kT0 - 5'000'000);
  const auto res = runner.run();
  EXPECT_EQ(early.received, 60);
  EXPECT_EQ(before.received, 60);
  EXPECT_EQ(late.received, 29);  // frames 31..59
  const auto out = rt::read_log(dir / "out.log");
  const auto out2 = on_channel(out, "OUT2");
  ASSERT_EQ(out2.size(), 29u);
  EXPECT_EQ(out2.front().timestamp, kT0 + 31 * 33'333);
  // Ticks every 100 ms from its start, to the last event (kT0 + 1,966,647).
  const auto ticks = on_channel(out, "TICK");
  ASSERT_EQ(ticks.size(), 9u);
  for (std::size_t k = 0; k < ticks.size(); ++k)
    EXPECT_EQ(rt::decode<ir_range_t>(ticks[k].data)->header.utime, start + static_cast<rt::Micros>(k + 1) * 100'000);
  EXPECT_EQ(res.timers_fired, 9);
}

TEST(Replay, TailKeepsTimersGoing) {
  TempDir dir;
  rt::write_log(dir / "in.log", make_input(2));
  ScaleNode a("IN", "OUT", 1.0);
  replay(dir / "in.log", dir / "out.log", {&a}, 1 * rt::kSecond);
  EXPECT_EQ(on_channel(rt::read_log(dir / "out.log"), "TICK").size(), 10u);
}

TEST(Replay, NodesChainAndRecordedOutputsAreRegenerated) {
  TempDir dir;
  // The log also holds what a previous version of the first node published
  // on OUT: it must not reach the second node, which gets the regenerated OUT.
  write_input_with_recorded_out(dir / "in.log");
  ScaleNode first("IN", "OUT", 2.0, false), second("OUT", "OUT2", 3.0, false);
  const auto res = replay(dir / "in.log", dir / "out.log", {&first, &second});
  EXPECT_EQ(res.events_skipped, 10);
  EXPECT_EQ(second.received, 60);
  const auto out2 = on_channel(rt::read_log(dir / "out.log"), "OUT2");
  ASSERT_EQ(out2.size(), 60u);
  EXPECT_FLOAT_EQ(rt::decode<ir_range_t>(out2[10].data)->range_m, 0.01f * 10 * 6);
  // Chained output has the same timestamp as the input that started the chain.
  EXPECT_EQ(out2[10].timestamp, kT0 + 10 * 33'333);
}

TEST(Replay, MalformedMessagesAreCountedNotFatal) {
  TempDir dir;
  auto in = make_input(10);
  auto good = rt::encode(ht::make_ir(kT0, 5, 1.f));
  std::vector<uint8_t> truncated(good.begin(), good.begin() + static_cast<long>(good.size() / 2));
  gripper_state_t other{};
  in.push_back({kT0 + 400'000, "IN", truncated});                              // truncated bytes
  in.push_back({kT0 + 400'001, "IN", rt::encode(other)});                      // wrong fingerprint
  in.push_back({kT0 + 400'002, "IN", {}});                                     // empty
  in.push_back({kT0 + 400'003, "IN", rt::encode(ht::make_ir(kT0, 77, 1.f))});  // still processed after
  rt::write_log(dir / "in.log", in);
  ScaleNode a("IN", "OUT", 1.0, false);
  replay(dir / "in.log", dir / "out.log", {&a});
  EXPECT_EQ(a.stats().decode_errors, 3);
  EXPECT_EQ(a.received, 11);
  EXPECT_EQ(on_channel(rt::read_log(dir / "out.log"), "OUT").size(), 11u);
}

namespace {

// The bytes of an IR_RANGE whose header.frame_id length is 0: the generated
// decoder throws std::length_error on it (issue 16's one-datagram kill).
std::vector<uint8_t> zero_frame_id(const ir_range_t& m) {
  auto b = rt::encode(m);
  // fingerprint 8, utime 8, seq 8, then frame_id's int32 length and its bytes
  const std::size_t at = 24;
  const std::size_t len = m.header.frame_id.size() + 1;
  b[at] = b[at + 1] = b[at + 2] = b[at + 3] = 0;
  b.erase(b.begin() + at + 4, b.begin() + static_cast<long>(at + 4 + len));
  return b;
}

// Throws out of its handler for one reading, as a node with a bug would.
class ThrowingNode : public ScaleNode {
 public:
  using ScaleNode::ScaleNode;

 protected:
  int32_t stamp(int32_t raw) override {
    if (raw == 13) throw std::runtime_error("bug on reading 13");
    return raw;
  }
};

}  // namespace

TEST(Replay, MalformedMessagesAreCountedPerChannelAndNeverDecoded) {
  TempDir dir;
  auto in = make_input(10);
  in.push_back({kT0 + 400'000, "IN", zero_frame_id(ht::make_ir(kT0, 5, 1.f))});
  in.push_back({kT0 + 400'001, "IN", rt::encode(ht::make_ir(kT0, 77, 1.f))});
  rt::write_log(dir / "in.log", in);
  ScaleNode a("IN", "OUT", 1.0, false);
  replay(dir / "in.log", dir / "out.log", {&a});
  EXPECT_EQ(a.stats().decode_errors, 1);
  EXPECT_EQ(a.stats().counters.at("malformed.IN"), 1);
  EXPECT_EQ(a.received, 11);
}

TEST(Replay, HandlerExceptionIsCaughtCountedAndTheNodeGoesOn) {
  TempDir dir;
  rt::write_log(dir / "in.log", make_input(30));
  ThrowingNode a("IN", "OUT", 1.0, false);
  rt::HeartbeatNode hb(rt::ProcessIdentity{"scale", "scale-1", "host", 42, "", "{}", "scale", "v1"}, {&a});
  replay(dir / "in.log", dir / "out.log", {&hb, &a}, 2 * rt::kSecond);
  EXPECT_EQ(a.stats().handler_errors, 1);
  EXPECT_EQ(a.stats().counters.at("handler_errors.IN"), 1);
  // The 29 other readings were answered; the one that threw was not.
  EXPECT_EQ(on_channel(rt::read_log(dir / "out.log"), "OUT").size(), 29u);
  const auto status = on_channel(rt::read_log(dir / "out.log"), "PROCESS_STATUS");
  const auto last = rt::decode<process_status_t>(status.back().data);
  ASSERT_TRUE(last);
  EXPECT_EQ(last->state, +process_status_t::STATE_DEGRADED);
  EXPECT_NE(last->message.find("1 messages failed in a handler"), std::string::npos) << last->message;
  const auto names = last->counter_names;
  EXPECT_NE(std::find(names.begin(), names.end(), "handler_errors.IN"), names.end());
}

TEST(Replay, HeartbeatReportsConfigOnceAndStatusAtOneHertz) {
  TempDir dir;
  rt::write_log(dir / "in.log", make_input());
  ScaleNode a("IN", "OUT", 1.0, false);
  rt::HeartbeatNode hb(rt::ProcessIdentity{"scale", "scale-1", "host", 42, "cfg.yaml", "gain: 1\n", "scale", "v1"},
                       {&a});
  // Feed one malformed message so the heartbeat has something to report.
  auto in = make_input();
  in.push_back({kT0 + 500'000, "IN", {1, 2, 3}});
  std::sort(in.begin(), in.end(), [](auto& x, auto& y) { return x.timestamp < y.timestamp; });
  rt::write_log(dir / "in.log", in);
  replay(dir / "in.log", dir / "out.log", {&hb, &a});
  const auto all = rt::read_log(dir / "out.log");
  const auto cfg = on_channel(all, "CONFIG");
  ASSERT_EQ(cfg.size(), 1u);
  EXPECT_EQ(rt::decode<config_snapshot_t>(cfg[0].data)->yaml, "gain: 1\n");
  const auto status = on_channel(all, "PROCESS_STATUS");
  ASSERT_EQ(status.size(), 2u);  // at start and at t0 + 1 s
  auto last = rt::decode<process_status_t>(status.back().data);
  EXPECT_EQ(status.back().timestamp, kT0 + rt::kSecond);
  EXPECT_EQ(last->instance, "scale-1");
  EXPECT_EQ(last->messages_received, 31);  // inputs up to t0 + 1 s
  EXPECT_EQ(last->decode_errors, 1);
  EXPECT_EQ(last->state, +process_status_t::STATE_DEGRADED);
  EXPECT_NE(last->message.find("1 malformed"), std::string::npos) << last->message;
  EXPECT_EQ(rt::decode<process_status_t>(status.front().data)->state, +process_status_t::STATE_OK);
}

TEST(Replay, MissingLogIsAClearError) {
  ScaleNode a("IN", "OUT", 1.0);
  try {
    replay("/nonexistent/in.log", "", {&a});
    FAIL() << "expected an error";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("/nonexistent/in.log"), std::string::npos);
  }
}

// The reader every replay uses maps the file and hands out views into it. It
// reads what lcm's writer wrote, skips to the next sync word over damage (as
// lcm's reader does) and ends at an event the logger did not finish.
TEST(LogReader, ReadsWhatLcmWroteSkipsDamageAndEndsAtATruncatedEvent) {
  ht::TempDir dir;
  const std::vector<rt::LogRecord> records = {
      {100, "A", {1, 2, 3}}, {200, "CHANNEL_B", {}}, {300, "A", std::vector<uint8_t>(70'000, 9)}};
  const std::string path = (dir / "log.lcm").string();
  rt::write_log(path, records);
  std::string bytes;
  {
    std::ifstream f(path, std::ios::binary);
    bytes.assign(std::istreambuf_iterator<char>(f), {});
  }
  auto read_all = [](const std::string& p) {
    std::vector<rt::LogRecord> got;
    rt::LogReader r(p);
    for (const rt::LogView* e = r.next(); e != nullptr; e = r.next())
      got.push_back({e->timestamp, std::string(e->channel), std::vector<uint8_t>(e->data, e->data + e->size)});
    return got;
  };
  EXPECT_EQ(read_all(path), records);
  EXPECT_EQ(rt::read_log(path), records);
  const std::string later = (dir / "later.lcm").string();
  EXPECT_EQ(rt::copy_log_from(path, later, 200), 1u);
  EXPECT_EQ(rt::read_log(later), std::vector<rt::LogRecord>(records.begin() + 1, records.end()));

  const std::string damaged = (dir / "damaged.lcm").string();
  std::ofstream(damaged, std::ios::binary) << std::string("\x01\xED\xA1junk", 7) << bytes.substr(0, bytes.size() - 10);
  EXPECT_EQ(read_all(damaged), std::vector<rt::LogRecord>(records.begin(), records.begin() + 2));

  const std::string empty = (dir / "empty.lcm").string();
  std::ofstream(empty).close();
  EXPECT_TRUE(read_all(empty).empty());
  EXPECT_THROW(rt::LogReader((dir / "absent.lcm").string()), std::runtime_error);
}
