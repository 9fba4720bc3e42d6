// explain_unmatched: each reason the logs can give for a regenerated message
// without a partner, and none where they cannot.
#include "logtools/explain.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <harvest/fruit_detections_t.hpp>
#include <harvest/image_t.hpp>
#include <harvest/targets_t.hpp>
#include <stdexcept>

#include "runtime/log_io.hpp"

namespace lt = harvest::logtools;
namespace rt = harvest::rt;

namespace {

rt::LogRecord frame(int64_t utime, int64_t log_time) {
  harvest::image_t m{};
  m.header.utime = utime;
  m.header.frame_id = "fixed";
  return {log_time, "CAMERA_FIXED", rt::encode(m)};
}

rt::LogRecord fruit(const std::string& channel, int64_t utime, int64_t log_time) {
  harvest::fruit_detections_t d{};
  d.header.utime = utime;
  d.header.frame_id = "fixed";
  d.camera = "fixed";
  return {log_time, channel, rt::encode(d)};
}

rt::LogRecord targets(int64_t utime, int64_t log_time) {
  harvest::targets_t t{};
  t.header.utime = utime;
  t.header.frame_id = "base";
  return {log_time, "TARGETS", rt::encode(t)};
}

const std::string& why_replayed(const lt::CompareReport& r, const std::string& channel, std::size_t k) {
  for (const auto& c : r.channels)
    if (c.channel == channel) return c.only_replayed_why.at(k);
  throw std::runtime_error("no channel " + channel);
}

}  // namespace

// Frames at 100..600 (log time +10); the live detector answered 200, 300
// and 500 (not 400: dropped live) and stopped after 500; the replay answered
// every frame from the replay's start at 150. A detection of frame 50 was
// recorded (before the replay's start), and one of frame 700 whose frame is
// not in the recording.
TEST(Explain, EachUnmatchedDetectionGetsItsReason) {
  std::vector<rt::LogRecord> recording;
  recording.push_back(frame(50, 60));
  for (int64_t u = 100; u <= 600; u += 100) recording.push_back(frame(u, u + 10));
  const std::vector<rt::LogRecord> recorded = {fruit("FRUIT_FIXED", 50, 160), fruit("FRUIT_FIXED", 200, 230),
                                               fruit("FRUIT_FIXED", 300, 330), fruit("FRUIT_FIXED", 500, 530),
                                               fruit("FRUIT_FIXED", 700, 731)};
  for (const auto& r : recorded) recording.push_back(r);
  std::stable_sort(recording.begin(), recording.end(),
                   [](const auto& a, const auto& b) { return a.timestamp < b.timestamp; });
  std::vector<rt::LogRecord> replayed;
  for (int64_t u = 200; u <= 600; u += 100) replayed.push_back(fruit("FRUIT_FIXED", u, u + 10));

  lt::CompareOptions o;
  auto report = lt::compare_logs(recorded, replayed, {"FRUIT_FIXED"}, o);
  lt::explain_unmatched(report, recording, {"FRUIT_FIXED"}, 150);
  const auto& c = report.channels.at(0);
  ASSERT_EQ(c.only_recorded.size(), 2u);  // 50 and 700
  EXPECT_NE(c.only_recorded_why[0].find("before the replay's start"), std::string::npos) << c.only_recorded_why[0];
  EXPECT_NE(c.only_recorded_why[1].find("not in the recording"), std::string::npos) << c.only_recorded_why[1];
  ASSERT_EQ(c.only_replayed.size(), 2u);  // 400 and 600
  EXPECT_NE(why_replayed(report, "FRUIT_FIXED", 0).find("dropped the frame"), std::string::npos);
  // 600's replay (log time 610) is before the live node's last message (700's, at 731): also a live drop.
  EXPECT_NE(why_replayed(report, "FRUIT_FIXED", 1).find("dropped the frame"), std::string::npos);
  EXPECT_TRUE(c.explained());
  EXPECT_NE(lt::format_report(report, o).find("EXPLAINED FRUIT_FIXED"), std::string::npos);
}

TEST(Explain, AfterTheLiveNodesLastMessageAndBeforeItsFirst) {
  std::vector<rt::LogRecord> recording = {frame(100, 110), frame(200, 210), frame(300, 310)};
  const std::vector<rt::LogRecord> recorded = {fruit("FRUIT_FIXED", 200, 230)};
  const std::vector<rt::LogRecord> replayed = {fruit("FRUIT_FIXED", 100, 110), fruit("FRUIT_FIXED", 200, 210),
                                               fruit("FRUIT_FIXED", 300, 310)};
  auto report = lt::compare_logs(recorded, replayed, {"FRUIT_FIXED"}, {});
  lt::explain_unmatched(report, recording, {"FRUIT_FIXED"}, 0);
  EXPECT_NE(why_replayed(report, "FRUIT_FIXED", 0).find("before the live node's first"), std::string::npos);
  EXPECT_NE(why_replayed(report, "FRUIT_FIXED", 1).find("after the live node's last"), std::string::npos);
}

// A message the live node did not publish in the middle of its run, on a
// channel that does not answer every frame (targets follow the controller's
// and the detections' timing): the logs cannot tell why, the channel is a DIFF.
TEST(Explain, WhatTheLogsCannotTellStaysUnexplained) {
  std::vector<rt::LogRecord> recording = {frame(100, 110), frame(200, 210), frame(300, 310)};
  const std::vector<rt::LogRecord> recorded = {targets(100, 120), targets(300, 320)};
  const std::vector<rt::LogRecord> replayed = {targets(100, 120), targets(200, 220), targets(300, 320)};
  lt::CompareOptions o;
  auto report = lt::compare_logs(recorded, replayed, {"TARGETS"}, o);
  lt::explain_unmatched(report, recording, {"TARGETS"}, 0);
  EXPECT_EQ(why_replayed(report, "TARGETS", 0), "");
  EXPECT_FALSE(report.channels[0].explained());
  const std::string text = lt::format_report(report, o);
  EXPECT_NE(text.find("DIFF TARGETS"), std::string::npos) << text;
  EXPECT_NE(text.find("NOT EXPLAINED"), std::string::npos) << text;
}
