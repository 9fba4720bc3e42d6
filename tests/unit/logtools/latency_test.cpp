// harvest-log latency on a hand-built log whose every figure is worked out below.
#include "logtools/latency.hpp"

#include <gtest/gtest.h>

#include <algorithm>

#include "harvest/fruit_detections_t.hpp"
#include "harvest/image_t.hpp"
#include "harvest/operator_command_t.hpp"
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
