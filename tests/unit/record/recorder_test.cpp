#include "record/recorder.hpp"

#include <gtest/gtest.h>

#include <vector>

#include "runtime/log_io.hpp"
#include "test_support.hpp"

namespace harvest::record {
namespace {

constexpr double kMB = 1024.0 * 1024.0;

std::vector<rt::LogRecord> read_parts(const std::filesystem::path& file, int parts) {
  std::vector<rt::LogRecord> all;
  for (int i = 0; i < parts; ++i) {
    char suffix[16];
    std::snprintf(suffix, sizeof suffix, ".%02d", i);
    auto more = rt::read_log(file.string() + suffix);
    all.insert(all.end(), more.begin(), more.end());
  }
  return all;
}

// Cameras at 30 Hz kept at 5 Hz: 5 a second on average, the first frame kept,
// every other channel whole.
TEST(Recorder, KeepsRateLimitedChannelsAtTheirRateAndEverythingElse) {
  testing::TempDir dir;
  RecorderOptions o;
  o.file = dir / "run.lcm";
  o.increment = true;
  o.rate_limits.push_back(parse_rate_limit("CAMERA_.*=5"));
  Recorder r(o);
  const std::vector<uint8_t> frame(1000, 7), state(100, 1);
  int kept_fixed = 0, kept_hand = 0, kept_state = 0;
  const int64_t t0 = 1'700'000'000'000'000;
  for (int i = 0; i < 300; ++i) {  // 10 s
    const int64_t t = t0 + i * 33'333;
    kept_fixed += r.on_message("CAMERA_FIXED", t, frame.data(), frame.size());
    kept_hand += r.on_message("CAMERA_HAND", t + 1000, frame.data(), frame.size());
    kept_state += r.on_message("ROBOT_STATE", t, state.data(), state.size());
  }
  EXPECT_NEAR(kept_fixed, 50, 1);
  EXPECT_NEAR(kept_hand, 50, 1);  // each channel has its own slots
  EXPECT_EQ(kept_state, 300);
  EXPECT_EQ(r.stats().rate_dropped, 600 - kept_fixed - kept_hand);
  EXPECT_EQ(r.stats().messages, kept_fixed + kept_hand + kept_state);
  r.flush();
  const auto log = read_parts(o.file, 1);
  ASSERT_EQ(static_cast<int>(log.size()), r.stats().messages);
  EXPECT_EQ(log.front().channel, "CAMERA_FIXED");  // the first frame is kept
  EXPECT_EQ(log.front().timestamp, t0);
  // Bytes counted as they are on disk.
  EXPECT_EQ(r.stats().bytes, static_cast<int64_t>(std::filesystem::file_size(r.stats().current)));
}

TEST(Recorder, SplitsIntoNumberedPartsBySizeAndLosesNothing) {
  testing::TempDir dir;
  RecorderOptions o;
  o.file = dir / "run.lcm";
  o.increment = true;
  o.split_mb = 0.01;  // 10485 bytes
  Recorder r(o);
  const std::vector<uint8_t> payload(1000, 3);
  for (int i = 0; i < 100; ++i) r.on_message("IMG", 1000 + i, payload.data(), payload.size());
  r.flush();
  EXPECT_EQ(r.stats().parts, 10);  // 10 events of 1031 bytes fit in a part of 10485 bytes
  EXPECT_EQ(r.stats().current, dir / "run.lcm.09");
  for (int i = 0; i < r.stats().parts; ++i) {
    char suffix[16];
    std::snprintf(suffix, sizeof suffix, ".%02d", i);
    EXPECT_LE(std::filesystem::file_size(o.file.string() + suffix), 0.01 * kMB) << suffix;
  }
  const auto log = read_parts(o.file, r.stats().parts);
  ASSERT_EQ(log.size(), 100u);
  for (int i = 0; i < 100; ++i) EXPECT_EQ(log[i].timestamp, 1000 + i);

  // A second recording beside it never overwrites: it takes the next free number.
  Recorder again(o);
  EXPECT_EQ(again.stats().current, dir / "run.lcm.10");
}

TEST(Recorder, SelectsOrInvertsChannelsAndRefusesWhatWouldLoseData) {
  testing::TempDir dir;
  RecorderOptions o;
  o.file = dir / "all-but-images.lcm";
  o.channels = "CAMERA_.*";
  o.invert_channels = true;
  Recorder r(o);
  const uint8_t b = 0;
  EXPECT_FALSE(r.on_message("CAMERA_FIXED", 1, &b, 1));
  EXPECT_TRUE(r.on_message("ROBOT_STATE", 2, &b, 1));
  EXPECT_EQ(r.stats().messages, 1);
  EXPECT_EQ(r.stats().rate_dropped, 0);

  try {
    Recorder again(o);  // without -i an existing file is kept
    ADD_FAILURE() << "overwrote " << o.file;
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("exists; not overwriting it"), std::string::npos) << e.what();
  }
  o.file = dir / "split.lcm";
  o.split_mb = 1;
  EXPECT_THROW(Recorder{o}, std::runtime_error);  // parts need numbers
  o.increment = true;
  o.channels = "([";
  EXPECT_THROW(Recorder{o}, std::runtime_error);
}

TEST(Recorder, RateLimitsAreParsedOrRefusedClearly) {
  const RateLimit r = parse_rate_limit("CAMERA_.*=2.5");
  EXPECT_EQ(r.pattern, "CAMERA_.*");
  EXPECT_DOUBLE_EQ(r.max_hz, 2.5);
  for (const char* bad : {"CAMERA_.*", "=5", "CAMERA_.*=", "CAMERA_.*=0", "CAMERA_.*=-1", "CAMERA_.*=5x", "([=5"}) {
    SCOPED_TRACE(bad);
    EXPECT_THROW(parse_rate_limit(bad), std::invalid_argument);
  }
}

// The status line and the disk warnings: short of space, or filling within
// warn_fill_minutes at the current rate; a standing warning is repeated once a
// minute, not every second.
TEST(RecordingMeter, ReportsSizeRateAndWarnsBeforeTheDiskFills) {
  RecordingMeter m(MeterOptions{1000, 10, 60}, "/data/logs");
  RecorderStats s;
  s.parts = 1;
  s.current = "/data/logs/run0-x.lcm.00";
  MeterReport r = m.update(0, s, 100.0 * 1024 * kMB);
  EXPECT_EQ(r.status, "recording: 0.0 MB in 1 file (run0-x.lcm.00), 0.00 MB/s, 100.0 GB free");
  EXPECT_FALSE(r.warning);

  s.bytes = static_cast<int64_t>(20 * kMB);  // 10 MB/s
  r = m.update(2, s, 100.0 * 1024 * kMB);
  EXPECT_EQ(r.status, "recording: 20.0 MB in 1 file (run0-x.lcm.00), 10.00 MB/s, 100.0 GB free (2.8 h at this rate)");
  EXPECT_FALSE(r.warning);

  s.bytes = static_cast<int64_t>(30 * kMB);
  r = m.update(3, s, 5.0 * 1024 * kMB);  // 512 s left at 10 MB/s
  ASSERT_TRUE(r.warning);
  EXPECT_EQ(*r.warning,
            "warning: the disk holding /data/logs fills in about 9 min at 10.00 MB/s (5.0 GB free): free space, lower "
            "recording.image_rate_hz, or stop the run");
  s.bytes = static_cast<int64_t>(40 * kMB);
  EXPECT_FALSE(m.update(4, s, 5.0 * 1024 * kMB).warning);  // said a second ago
  s.bytes = static_cast<int64_t>(40 * kMB);
  s.parts = 2;
  s.rate_dropped = 7;
  r = m.update(64, s, 500 * kMB);
  ASSERT_TRUE(r.warning);
  EXPECT_EQ(*r.warning,
            "warning: only 500.0 MB free on the disk holding /data/logs (warning below 1000.0 MB): free "
            "space, or the recording stops when it is full");
  EXPECT_NE(r.status.find("in 2 files"), std::string::npos) << r.status;
  EXPECT_NE(r.status.find("7 messages left out by rate limits"), std::string::npos) << r.status;
  EXPECT_GT(free_bytes("/"), 0);
  EXPECT_EQ(free_bytes("/no/such/folder"), -1);
}

}  // namespace
}  // namespace harvest::record
