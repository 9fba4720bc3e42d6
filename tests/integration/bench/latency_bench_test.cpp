// tools/latency_bench.py for a few seconds (`tools/harvest bench latency`): the
// real processes over LCM, every ROBOT_COMMAND traced back through TARGETS and
// the detections to a camera frame, every hop non-negative. Correctness only:
// no timing is asserted (the figures: docs/performance.md).
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>

#include "runtime/json.hpp"
#include "test_support.hpp"

namespace ht = harvest::testing;
using namespace std::chrono_literals;

TEST(LatencyBench, EveryCommandIsTracedBackToACameraFrame) {
  ht::TempDir dir;
  const std::filesystem::path build = std::filesystem::path(ht::bin("")).parent_path().parent_path();
  ht::ChildProcess bench({"/usr/bin/python3", ht::source_path("tools/latency_bench.py"), "--seconds", "4", "--out",
                          (dir / "run").string(), "--build-dir", build.string()},
                         dir / "bench.txt");
  const int rc = bench.wait(150s);
  if (rc == -1) bench.stop();  // by its PID; it stops the processes it started by theirs
  ASSERT_EQ(rc, 0) << bench.output();
  std::ifstream in(dir / "run" / "latency.json");
  ASSERT_TRUE(in) << bench.output();
  const auto j = harvest::rt::Json::parse(in);

  // Every command names a TARGETS message that is in the log.
  const int64_t commands = j["transport"]["ROBOT_COMMAND"]["count"];
  EXPECT_GT(commands, 50) << bench.output();
  EXPECT_EQ(j["hops"]["TARGETS -> ROBOT_COMMAND"]["count"], commands) << bench.output();
  // ... every TARGETS a detection, every detection a frame.
  for (const char* ch : {"ROBOT_COMMAND", "TARGETS", "FRUIT_FIXED", "FRUIT_HAND"})
    EXPECT_FALSE(j["untraced_by_channel"].contains(ch)) << ch << "\n" << bench.output();
  for (const auto& [name, d] : j["hops"].items()) EXPECT_GE(d["min_ms"].get<double>(), 0.0) << name;
  // Both cameras' frames reach commands, and the stages of each add up to non-negative times.
  for (const char* cam : {"CAMERA_FIXED", "CAMERA_HAND"}) {
    ASSERT_TRUE(j["chains"].contains(cam)) << cam << "\n" << bench.output();
    const auto& c = j["chains"][cam];
    EXPECT_GT(c["commanded"].get<int64_t>(), 30) << cam;
    EXPECT_EQ(c["end_to_end"]["count"], c["commanded"]) << cam;
    EXPECT_GE(c["end_to_end"]["min_ms"].get<double>(), 0.0) << cam;
    EXPECT_GE(c["transport"]["min_ms"].get<double>(), 0.0) << cam;
    EXPECT_TRUE(c.contains("own_processing")) << cam;
  }
  // The controller obeyed START (on a loaded machine the simulated arm may fault soon after: its STOPs are
  // traced the same way).
  const auto& states = j["bench"]["controller_states"];
  EXPECT_NE(std::find(states.begin(), states.end(), "SELECT"), states.end()) << states.dump();
}
