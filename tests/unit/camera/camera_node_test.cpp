// The camera driver node on a scripted frame source, driven by the replay
// runner's clock: an unplugged device is reopened with doubling back-off and
// the frames go on with consecutive sequence numbers; a bad frame is skipped.
// The shipped driver configurations load.
#include "camera/camera_node.hpp"

#include <gtest/gtest.h>

#include <deque>

#include "harvest/image_t.hpp"
#include "runtime/log_io.hpp"
#include "runtime/replay_runner.hpp"
#include "test_support.hpp"

namespace ht = harvest::testing;

namespace harvest::camera {
namespace {

struct Script {
  std::deque<bool> opens;        // result of each open(); true = success
  std::deque<ReadStatus> reads;  // result of each read()
  int open_calls = 0, close_calls = 0;
};

class ScriptedSource : public FrameSource {
 public:
  explicit ScriptedSource(Script* s) : s_(s) {}
  void open() override {
    ++s_->open_calls;
    const bool ok = s_->opens.empty() ? true : s_->opens.front();
    if (!s_->opens.empty()) s_->opens.pop_front();
    if (!ok) throw std::runtime_error("cannot open camera device /dev/video7 (missing, busy or no permission)");
  }
  void close() override { ++s_->close_calls; }
  ReadResult read() override {
    ReadStatus st = ReadStatus::kFrame;
    if (!s_->reads.empty()) {
      st = s_->reads.front();
      s_->reads.pop_front();
    }
    if (st == ReadStatus::kFrame) return {st, cv::Mat3b(48, 64, cv::Vec3b(1, 2, 3)), {}};
    return {st, {}, st == ReadStatus::kLost ? "camera device /dev/video7: no frame (unplugged?)" : "bad frame x.png"};
  }
  std::string describe() const override { return "camera device /dev/video7"; }

 private:
  Script* s_;
};

constexpr rt::Micros kT0 = 1'000'000'000;

// Runs the node from kT0 for `seconds` of log time; returns the image times (relative to kT0) and seqs.
std::vector<std::pair<rt::Micros, int64_t>> run(CameraNode& node, double seconds, const ht::TempDir& dir) {
  rt::write_log((dir / "in.log").string(), {{kT0, "UNRELATED", {1, 2, 3}}});
  rt::ReplayOptions o;
  o.input_log = (dir / "in.log").string();
  o.output_log = (dir / "out.log").string();
  o.tail = static_cast<rt::Micros>(seconds * 1e6);
  rt::ReplayRunner runner(o);
  runner.add(node);
  runner.run();
  std::vector<std::pair<rt::Micros, int64_t>> out;
  for (const auto& r : rt::read_log((dir / "out.log").string()))
    if (r.channel == "CAMERA_FIXED") {
      const auto m = rt::decode<image_t>(r.data);
      EXPECT_TRUE(m);
      out.emplace_back(m->header.utime - kT0, m->header.seq);
    }
  return out;
}

CameraConfig device_config() {
  CameraConfig c;
  c.camera = "fixed";
  c.channel = "CAMERA_FIXED";
  c.source = "device";
  c.frame_rate_hz = 10;
  c.retry_initial_s = 0.5;
  c.retry_max_s = 2.0;
  return c;
}

TEST(CameraNode, UnpluggedDeviceIsReopenedWithDoublingBackOff) {
  Script s;
  s.opens = {true, false, false, true};
  s.reads = {ReadStatus::kFrame, ReadStatus::kFrame, ReadStatus::kFrame, ReadStatus::kLost};
  CameraNode node(device_config(), std::make_unique<ScriptedSource>(&s));
  ht::TempDir dir;
  const auto frames = run(node, 4.25, dir);
  // Ticks every 100 ms: frames at 0.1..0.3 s, lost at 0.4 s; reopen tried at
  // 0.9 s (0.5 s later, fails), 1.9 s (1 s, fails), 3.9 s (2 s, the cap, works).
  ASSERT_EQ(frames.size(), 6u);
  EXPECT_EQ(frames[0].first, 100'000);
  EXPECT_EQ(frames[2].first, 300'000);
  EXPECT_EQ(frames[3].first, 4'000'000);
  EXPECT_EQ(frames[5].first, 4'200'000);
  for (std::size_t i = 1; i < frames.size(); ++i) EXPECT_EQ(frames[i].second, frames[i - 1].second + 1);
  EXPECT_EQ(s.open_calls, 4);
  EXPECT_EQ(s.close_calls, 1);
  EXPECT_EQ(node.stats().counters.at("device_lost"), 1);
  EXPECT_EQ(node.stats().counters.at("open_failures"), 2);
  EXPECT_EQ(node.health(), rt::Health::kOk);
}

TEST(CameraNode, MissingDeviceStaysInErrorAndKeepsRetrying) {
  Script s;
  s.opens = std::deque<bool>(100, false);
  CameraNode node(device_config(), std::make_unique<ScriptedSource>(&s));
  ht::TempDir dir;
  EXPECT_TRUE(run(node, 10.05, dir).empty());
  // Attempts at 0, 0.5, 1.5, 3.5, 5.5, 7.5, 9.5 s.
  EXPECT_EQ(s.open_calls, 7);
  EXPECT_EQ(node.health(), rt::Health::kError);
  EXPECT_NE(node.health_message().find("/dev/video7"), std::string::npos) << node.health_message();
  EXPECT_NE(node.health_message().find("retrying in 2.00 s"), std::string::npos) << node.health_message();
}

TEST(CameraNode, BadFrameIsSkippedAndCounted) {
  Script s;
  s.reads = {ReadStatus::kFrame, ReadStatus::kBadFrame, ReadStatus::kFrame};
  CameraConfig c = device_config();
  c.source = "folder";
  CameraNode node(c, std::make_unique<ScriptedSource>(&s));
  ht::TempDir dir;
  const auto frames = run(node, 0.35, dir);
  ASSERT_EQ(frames.size(), 2u);  // ticks 0.1 (frame), 0.2 (bad), 0.3 (frame)
  EXPECT_EQ(frames[1].first, 300'000);
  EXPECT_EQ(frames[1].second, frames[0].second + 1);
  EXPECT_EQ(node.stats().counters.at("bad_frames"), 1);
  EXPECT_EQ(node.health(), rt::Health::kOk);
}

TEST(CameraConfig, ShippedFilesLoadWithoutUnknownKeys) {
  for (const char* cam : {"fixed", "hand"}) {
    auto doc = config::Document::load_file(std::string("config/vision/camera-") + cam + ".yaml");
    const CameraConfig c = CameraConfig::from_yaml(doc.root());
    EXPECT_NO_THROW(doc.check_unused());
    EXPECT_EQ(c.camera, cam);
    EXPECT_EQ(c.channel, std::string("CAMERA_") + (std::string(cam) == "fixed" ? "FIXED" : "HAND"));
    EXPECT_EQ(c.source, "device");
  }
}

}  // namespace
}  // namespace harvest::camera
