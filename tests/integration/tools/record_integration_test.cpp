// harvest-record against real LCM traffic: camera frames kept at a reduced
// rate, everything else whole, numbered parts split by size, the size/rate
// reports and the disk warning printed while it records, a clean stop on
// SIGINT.
#include <gtest/gtest.h>
#include <signal.h>

#include <lcm/lcm-cpp.hpp>
#include <map>
#include <thread>

#include "runtime/log_io.hpp"
#include "test_support.hpp"

namespace harvest {
namespace {

using namespace std::chrono_literals;

TEST(Record, KeepsImagesAtTheirRateSplitsBySizeAndReportsWhileRecording) {
  testing::TempDir dir;
  const std::string url = testing::unique_lcm_url();
  testing::ChildProcess rec({testing::bin("harvest-record"), "--lcm-url=" + url, "-i", "--split-mb=0.05",
                             "--max-rate=CAMERA_.*=5", "--status-s=1",
                             // More than any disk has free: the warning must show.
                             "--warn-free-mb=100000000", (dir / "run.lcm").string()},
                            dir / "record.out");
  ASSERT_TRUE(testing::eventually([&] { return rec.output().find("recording to") != std::string::npos; }, 10s))
      << rec.output();
  lcm::LCM lcm(url);
  ASSERT_TRUE(lcm.good());
  const std::vector<uint8_t> frame(5000, 1), state(200, 2);
  // 3 s: cameras at 30 Hz, robot state at 90 Hz.
  const auto t0 = std::chrono::steady_clock::now();
  int sent_frames = 0, sent_states = 0;
  for (int tick = 0; tick < 270; ++tick) {
    std::this_thread::sleep_until(t0 + tick * 11111us);
    if (tick % 3 == 0) {
      lcm.publish("CAMERA_FIXED", frame.data(), static_cast<unsigned>(frame.size()));
      ++sent_frames;
    }
    lcm.publish("ROBOT_STATE", state.data(), static_cast<unsigned>(state.size()));
    ++sent_states;
  }
  std::this_thread::sleep_for(1200ms);  // one more report
  EXPECT_EQ(rec.stop(10s, SIGINT), 0) << rec.output();
  const std::string out = rec.output();

  std::map<std::string, int> count;
  int parts = 0;
  for (;; ++parts) {
    char suffix[16];
    std::snprintf(suffix, sizeof suffix, ".%02d", parts);
    const std::filesystem::path part = dir.path().string() + "/run.lcm" + suffix;
    if (!std::filesystem::exists(part)) break;
    EXPECT_LE(std::filesystem::file_size(part), 0.05 * 1024 * 1024 + 6000) << part;
    for (const auto& r : rt::read_log(part.string())) ++count[r.channel];
  }
  EXPECT_GE(parts, 2) << out;
  // 5 a second of the camera's 30 (3 s), every robot state (UDP on a loaded machine may drop a few).
  EXPECT_GE(count["CAMERA_FIXED"], 12) << out;
  EXPECT_LE(count["CAMERA_FIXED"], 17) << out;
  EXPECT_GE(count["ROBOT_STATE"], sent_states * 9 / 10) << out;
  EXPECT_NE(out.find("channels CAMERA_.* kept at most 5 per second"), std::string::npos) << out;
  EXPECT_NE(out.find("recording: "), std::string::npos) << out;
  EXPECT_NE(out.find(" MB/s, "), std::string::npos) << out;
  EXPECT_NE(out.find("messages left out by rate limits"), std::string::npos) << out;
  EXPECT_NE(out.find("warning: only "), std::string::npos) << out;
  EXPECT_NE(out.find("recorded "), std::string::npos) << out;
  (void)sent_frames;
}

TEST(Record, RefusesBadOptionsAndAnUnwritableFolder) {
  testing::TempDir dir;
  testing::ChildProcess bad({testing::bin("harvest-record"), "--max-rate=CAMERA_.*=fast", (dir / "x.lcm").string()},
                            dir / "bad.out");
  EXPECT_EQ(bad.wait(10s), 2);
  EXPECT_NE(bad.output().find("the rate must be a number"), std::string::npos) << bad.output();
  testing::ChildProcess nowhere({testing::bin("harvest-record"), "--lcm-url=" + testing::unique_lcm_url(), "-i",
                                 (dir / "no" / "such" / "x.lcm").string()},
                                dir / "nowhere.out");
  EXPECT_EQ(nowhere.wait(10s), 1);
  EXPECT_NE(nowhere.output().find("error: cannot write"), std::string::npos) << nowhere.output();
}

}  // namespace
}  // namespace harvest
