// harvest-log latency on a hand-built log whose every figure is worked out below.
#include "logtools/latency.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <nlohmann/json.hpp>

#include "harvest/fruit_detections_t.hpp"
#include "harvest/image_t.hpp"
#include "harvest/operator_command_t.hpp"
#include "harvest/robot_command_t.hpp"
#include "harvest/targets_t.hpp"
#include "runtime/log_io.hpp"

namespace lt = harvest::logtools;
namespace rt = harvest::rt;

namespace {

template <class M>
void stamp(M& m, const char* frame, int64_t utime, int64_t seq, int64_t source_seq, int64_t publish) {
  m.header.frame_id = frame;
  m.header.utime = utime;
  m.header.seq = seq;
  m.header.source_seq = source_seq;
  m.header.publish_utime = publish;
}

// Two cameras sensing at the same instants with the same seq (as the simulator's do), a detector per camera,
// a reconstructor on both. Frame k is sensed at t_k = 1 s + k * 33 ms; the hand camera publishes 1 ms after
// sensing, the fixed one 2 ms after; detections come 4 ms (hand) and 3 ms (fixed) after their frame's
// publication; targets 1 ms after the hand detections. The logger receives everything 100 us after publication.
std::vector<rt::LogRecord> chain_log(int frames) {
  std::vector<rt::LogRecord> log;
  for (int k = 0; k < frames; ++k) {
    const int64_t t = 1'000'000 + k * 33'000;
    harvest::image_t hand{}, fixed{};
    stamp(hand, "camera_hand", t, k, -1, t + 1'000);
    stamp(fixed, "camera_fixed", t, k, -1, t + 2'000);
    harvest::fruit_detections_t fh{}, ff{};
    stamp(fh, "camera_hand", t, k, k, t + 5'000);
    stamp(ff, "camera_fixed", t, k, k, t + 5'000);
    harvest::targets_t targets{};
    stamp(targets, "base", t, k, k, t + 6'000);
    log.push_back({t + 1'100, "CAMERA_HAND", rt::encode(hand)});
    log.push_back({t + 2'100, "CAMERA_FIXED", rt::encode(fixed)});
    log.push_back({t + 5'100, "FRUIT_HAND", rt::encode(fh)});
    log.push_back({t + 5'100, "FRUIT_FIXED", rt::encode(ff)});
    log.push_back({t + 6'100, "TARGETS", rt::encode(targets)});
  }
  return log;
}

}  // namespace

TEST(Latency, NearestRankPercentiles) {
  std::vector<int64_t> v;
  for (int i = 1; i <= 200; ++i) v.push_back(i * 1000);  // 1..200 ms
  const auto d = lt::distribution(v);
  EXPECT_EQ(d.count, 200);
  EXPECT_DOUBLE_EQ(d.p50_ms, 100.0);
  EXPECT_DOUBLE_EQ(d.p99_ms, 198.0);
  EXPECT_DOUBLE_EQ(d.max_ms, 200.0);
  EXPECT_DOUBLE_EQ(d.min_ms, 1.0);
  EXPECT_EQ(lt::distribution({}).count, 0);
}

TEST(Latency, AgesTransportAndHopsTracedThroughTwoCamerasSharingStamps) {
  const auto r = lt::latency(chain_log(10));
  ASSERT_EQ(r.channels.count("CAMERA_FIXED"), 1u);
  EXPECT_DOUBLE_EQ(r.channels.at("CAMERA_HAND").age.p50_ms, 1.0);
  EXPECT_DOUBLE_EQ(r.channels.at("CAMERA_FIXED").age.max_ms, 2.0);
  EXPECT_DOUBLE_EQ(r.channels.at("TARGETS").age.p99_ms, 6.0);
  EXPECT_DOUBLE_EQ(r.channels.at("FRUIT_FIXED").transport.p50_ms, 0.1);
  // Each detector's input is its own camera (same frame_id), though both cameras share utime and seq.
  ASSERT_EQ(r.hops.count("CAMERA_HAND -> FRUIT_HAND"), 1u);
  EXPECT_DOUBLE_EQ(r.hops.at("CAMERA_HAND -> FRUIT_HAND").p50_ms, 4.0);
  EXPECT_DOUBLE_EQ(r.hops.at("CAMERA_FIXED -> FRUIT_FIXED").p50_ms, 3.0);
  EXPECT_EQ(r.hops.count("CAMERA_FIXED -> FRUIT_HAND"), 0u);
  EXPECT_EQ(r.hops.count("CAMERA_HAND -> FRUIT_FIXED"), 0u);
  // TARGETS: the latest published input (both detections at +5 ms; either is right), 1 ms.
  int64_t targets_hops = 0;
  for (const auto& [name, d] : r.hops)
    if (name.find("-> TARGETS") != std::string::npos) {
      targets_hops += d.count;
      EXPECT_DOUBLE_EQ(d.max_ms, 1.0) << name;
    }
  EXPECT_EQ(targets_hops, 10);
  EXPECT_EQ(r.untraced, 0);
}

TEST(Latency, MissingInputsUnstampedAndMalformedAreCountedNotFatal) {
  auto log = chain_log(3);
  // Hand images recorded at a reduced rate: frames 1 and 2 missing. Their detections are not charged to the
  // fixed camera's frames of the same instant (same utime and seq).
  log.erase(std::remove_if(log.begin(), log.end(),
                           [](const auto& e) { return e.channel == "CAMERA_HAND" && e.timestamp > 1'010'000; }),
            log.end());
  harvest::operator_command_t op{};
  op.header.utime = 1'500'000;  // a tool's message with no publish_utime
  log.push_back({1'500'000, "OPERATOR_COMMAND", rt::encode(op)});
  auto bad = rt::encode(op);
  bad.resize(bad.size() / 2);  // truncated: known fingerprint, does not decode
  log.push_back({1'600'000, "OPERATOR_COMMAND", bad});
  log.push_back({1'700'000, "OTHER_TOOL", {1, 2, 3}});  // not a harvest message: ignored
  const auto r = lt::latency(log);
  EXPECT_EQ(r.untraced, 2);  // FRUIT_HAND without its camera frame
  EXPECT_EQ(r.hops.at("CAMERA_HAND -> FRUIT_HAND").count, 1);
  EXPECT_EQ(r.hops.count("CAMERA_FIXED -> FRUIT_HAND"), 0u);
  EXPECT_EQ(r.unstamped, 1);
  EXPECT_EQ(r.malformed, 1);
  EXPECT_EQ(r.channels.count("OPERATOR_COMMAND"), 0u);
  const auto text = lt::format_latency("x.lcmlog", r);
  EXPECT_NE(text.find("2 derived messages whose input is not in the log: FRUIT_HAND 2"), std::string::npos) << text;
  EXPECT_NE(text.find("CAMERA_FIXED -> FRUIT_FIXED"), std::string::npos) << text;
}

namespace {

// A controller that ticks every 20 ms and names the newest TARGETS in each command, fed by a hand camera every
// 25 ms and one fixed-camera frame. All times in ms after 1 s:
//   hand frame k sensed at 25k, published +1, its detections at +4, its targets at +5; frame 4's detections
//   are missing; fixed frames sensed at -20 (before any command) and 40, published +1, detections +4,
//   targets +5;
//   TARGETS seq 0..6 = fixed 0 (-15), hand 0 (5), hand 1 (30), fixed 1 (45), hand 2 (55), hand 3 (80),
//   hand 5 (130); ticks due at 7, 27, ..., 147, every other command published 0.4 ms late (7, 27.4, 47, 67.4,
//   87, 107.4, 127, 147.4), naming seq 1, 1, 3, 4, 5, 5, 5, 6 (the newest targets published before them).
// The logger receives camera frames and targets 100 us after publication, detections 200 us, commands 50 us.
std::vector<rt::LogRecord> command_log() {
  std::vector<rt::LogRecord> log;
  auto ms = [](double v) { return static_cast<int64_t>(1'000'000 + v * 1000); };
  struct Targets {
    int64_t utime, seq, publish;
  };
  std::vector<Targets> targets;
  auto frame = [&](const char* cam, const char* det_ch, const char* frame_id, double sensed, int64_t seq,
                   int64_t det_seq, bool detected) {
    harvest::image_t img{};
    stamp(img, frame_id, ms(sensed), seq, -1, ms(sensed + 1));
    log.push_back({ms(sensed + 1.1), cam, rt::encode(img)});
    if (!detected) return;
    harvest::fruit_detections_t d{};
    stamp(d, frame_id, ms(sensed), det_seq, seq, ms(sensed + 4));
    log.push_back({ms(sensed + 4.2), det_ch, rt::encode(d)});
    harvest::targets_t t{};
    stamp(t, "base", ms(sensed), static_cast<int64_t>(targets.size()), det_seq, ms(sensed + 5));
    targets.push_back({ms(sensed), t.header.seq, ms(sensed + 5)});
    log.push_back({ms(sensed + 5.1), "TARGETS", rt::encode(t)});
  };
  frame("CAMERA_FIXED", "FRUIT_FIXED", "camera_fixed", -20, 0, 0, true);
  frame("CAMERA_HAND", "FRUIT_HAND", "camera_hand", 0, 0, 0, true);
  frame("CAMERA_HAND", "FRUIT_HAND", "camera_hand", 25, 1, 1, true);
  frame("CAMERA_FIXED", "FRUIT_FIXED", "camera_fixed", 40, 1, 1, true);
  frame("CAMERA_HAND", "FRUIT_HAND", "camera_hand", 50, 2, 2, true);
  frame("CAMERA_HAND", "FRUIT_HAND", "camera_hand", 75, 3, 3, true);
  frame("CAMERA_HAND", "FRUIT_HAND", "camera_hand", 100, 4, 4, false);
  frame("CAMERA_HAND", "FRUIT_HAND", "camera_hand", 125, 5, 4, true);
  for (int j = 0; j < 8; ++j) {
    const int64_t tick = ms(7 + 20 * j + (j % 2) * 0.4);
    const Targets* newest = nullptr;
    for (const auto& t : targets)
      if (t.publish < tick) newest = &t;
    harvest::robot_command_t c{};
    stamp(c, "base", newest->utime, j, newest->seq, tick);
    log.push_back({tick + 50, "ROBOT_COMMAND", rt::encode(c)});
  }
  std::stable_sort(log.begin(), log.end(), [](const auto& a, const auto& b) { return a.timestamp < b.timestamp; });
  return log;
}

}  // namespace

TEST(Latency, EveryFrameIsFollowedToTheFirstCommandThatUsedIt) {
  const auto r = lt::latency(command_log());
  EXPECT_DOUBLE_EQ(r.hops.at("TARGETS -> ROBOT_COMMAND").p50_ms, 12.4);  // 2, 22.4, 2, 12.4, 7, 27.4, 47, 17.4
  EXPECT_DOUBLE_EQ(r.hop_processing.at("CAMERA_HAND -> FRUIT_HAND").p50_ms, 2.9);
  ASSERT_EQ(r.chains.count("CAMERA_HAND"), 1u);
  const auto& hand = r.chains.at("CAMERA_HAND");
  EXPECT_EQ(hand.path, "CAMERA_HAND > FRUIT_HAND > TARGETS > ROBOT_COMMAND");
  // Frames 0..5 lie in the window; frame 4 has no detections.
  EXPECT_EQ(hand.frames, 6);
  EXPECT_EQ(hand.commanded, 5);
  ASSERT_EQ(hand.lost.size(), 1u);
  EXPECT_EQ(hand.lost.at("no FRUIT_HAND"), 1);
  // Frame 1's targets (seq 2) were never named: the command at 47 ms (naming seq 3) is the first that used them.
  // End to end 7, 22, 17.4, 12, 22.4 ms.
  EXPECT_EQ(hand.end_to_end.count, 5);
  EXPECT_DOUBLE_EQ(hand.end_to_end.p50_ms, 17.4);
  EXPECT_DOUBLE_EQ(hand.end_to_end.max_ms, 22.4);
  // Camera 1 + detector 2.9 + reconstructor 0.8; transport 0.1 + 0.2 + 0.1.
  EXPECT_DOUBLE_EQ(hand.upstream.max_ms, 4.7);
  EXPECT_DOUBLE_EQ(hand.transport.p50_ms, 0.4);
  EXPECT_DOUBLE_EQ(hand.processing.max_ms, 22.0);
  ASSERT_EQ(hand.stages.size(), 7u);
  EXPECT_EQ(hand.stages[0].first, "sensed -> CAMERA_HAND published");
  EXPECT_DOUBLE_EQ(hand.stages[0].second.p50_ms, 1.0);
  EXPECT_EQ(hand.stages[3].first, "FRUIT_HAND transport");
  EXPECT_DOUBLE_EQ(hand.stages[3].second.p50_ms, 0.2);
  EXPECT_EQ(hand.stages[6].first, "ROBOT_COMMAND node: received -> published");
  EXPECT_DOUBLE_EQ(hand.stages[6].second.max_ms, 17.3);  // 1.9, 16.9, 12.3, 6.9, 17.3
  EXPECT_EQ(hand.own.count, 0);                          // the timer's period not given
  EXPECT_EQ(r.command_tick.count, 0);
  EXPECT_DOUBLE_EQ(hand.command_transport.max_ms, 0.05);
  // The second fixed frame's targets (seq 3) are named by the command at 47 ms: 7 ms after sensing. The first
  // was superseded before the first command (at 7 ms, naming hand frame 0): not in the window.
  const auto& fixed = r.chains.at("CAMERA_FIXED");
  EXPECT_EQ(fixed.frames, 1);
  EXPECT_EQ(fixed.commanded, 1);
  EXPECT_DOUBLE_EQ(fixed.end_to_end.max_ms, 7.0);
  const auto json = nlohmann::json::parse(lt::latency_json("x.lcmlog", r));
  EXPECT_EQ(json["chains"]["CAMERA_HAND"]["commanded"], 5);
  EXPECT_EQ(json["chains"]["CAMERA_HAND"]["lost"]["no FRUIT_HAND"], 1);
  EXPECT_DOUBLE_EQ(json["chains"]["CAMERA_HAND"]["end_to_end"]["p50_ms"].get<double>(), 17.4);
  const auto text = lt::format_latency("x.lcmlog", r);
  EXPECT_NE(text.find("5 of 6 frames in the window used, 1 no FRUIT_HAND"), std::string::npos) << text;
}

// The controller's 20 ms timer: its stage splits into the wait for the tick and the tick's work.
TEST(Latency, TheCommandTimersPeriodSplitsOffTheWaitForTheTick) {
  lt::LatencyOptions o;
  o.command_period_us = 20'000;
  const auto r = lt::latency(command_log(), o);
  // Every command 0 or 0.4 ms after its tick was due (phase 7 ms).
  EXPECT_EQ(r.command_tick.count, 8);
  EXPECT_DOUBLE_EQ(r.command_tick.p50_ms, 0.0);
  EXPECT_DOUBLE_EQ(r.command_tick.max_ms, 0.4);
  const auto& hand = r.chains.at("CAMERA_HAND");
  ASSERT_EQ(hand.stages.size(), 8u);
  // Targets received at 5.1, 30.1, 55.1, 80.1, 130.1; ticks due at 7, 47, 67, 87, 147, published 0, 0, 0.4, 0, 0.4
  // ms after.
  EXPECT_EQ(hand.stages[6].first, "ROBOT_COMMAND node: received -> timer due");
  EXPECT_DOUBLE_EQ(hand.stages[6].second.max_ms, 16.9);
  EXPECT_EQ(hand.stages[7].first, "ROBOT_COMMAND node: timer due -> published");
  EXPECT_DOUBLE_EQ(hand.stages[7].second.max_ms, 0.4);
  EXPECT_DOUBLE_EQ(hand.stages[7].second.p50_ms, 0.0);
  // Up to the targets 4.7 ms, then the tick's work.
  EXPECT_EQ(hand.own.count, 5);
  EXPECT_DOUBLE_EQ(hand.own.p50_ms, 4.7);
  EXPECT_DOUBLE_EQ(hand.own.max_ms, 5.1);
  EXPECT_NE(lt::format_latency("x", r).find("without the wait for the timer"), std::string::npos);
}

// A timer rounded to milliseconds: on-time ticks spread over 0..1 ms after their due time, crowded at 0.6-0.87
// ms. The phase is where the spread begins, not the crowd: no command comes out a period late.
TEST(Latency, TheTimersPhaseIsWhereItsOnTimeTicksBegin) {
  std::vector<rt::LogRecord> log;
  harvest::targets_t t{};
  stamp(t, "base", 1'000'000, 0, 0, 1'000'000);
  log.push_back({1'000'100, "TARGETS", rt::encode(t)});
  for (int k = 0; k < 50; ++k) {
    const int64_t late = k < 10 ? k * 60 : 600 + (k % 10) * 30;  // 0..540 us, then 600..870 us
    harvest::robot_command_t c{};
    const int64_t publish = 1'007'000 + k * 20'000 + late;
    stamp(c, "base", 1'000'000, k, 0, publish);
    log.push_back({publish + 50, "ROBOT_COMMAND", rt::encode(c)});
  }
  lt::LatencyOptions o;
  o.command_period_us = 20'000;
  const auto r = lt::latency(log, o);
  EXPECT_EQ(r.command_tick.count, 50);
  EXPECT_DOUBLE_EQ(r.command_tick.min_ms, 0.0);
  EXPECT_DOUBLE_EQ(r.command_tick.max_ms, 0.87);
}

TEST(Latency, CommandsStampedWithTheRobotStateMakeNoChains) {
  auto log = command_log();
  for (auto& e : log)
    if (e.channel == "ROBOT_COMMAND") {
      auto c = *rt::decode<harvest::robot_command_t>(e.data);
      c.header.utime = 5;  // an input not in the log
      e.data = rt::encode(c);
    }
  const auto r = lt::latency(log);
  EXPECT_TRUE(r.chains.empty());
  EXPECT_EQ(r.untraced_by_channel.at("ROBOT_COMMAND"), 8);
}
