// harvest-fruit-detector as a real process over real LCM: good frames give
// fruit; each kind of bad input (wrong encoding, truncated frame, zero size,
// corrupt or cut-off JPEG, wrong sensor size, a malformed LCM message) gives
// a status error naming the problem and the next good frame is detected.
#include <gtest/gtest.h>

#include <fstream>
#include <harvest/fruit_detections_t.hpp>
#include <harvest/image_t.hpp>
#include <harvest/process_status_t.hpp>
#include <opencv2/imgproc.hpp>

#include "bus.hpp"
#include "camera/image_codec.hpp"
#include "runtime/clock.hpp"
#include "test_support.hpp"

namespace ht = harvest::testing;
using namespace std::chrono_literals;

namespace harvest::vision {
namespace {

constexpr double kFx = 833.57, kFy = 767.02;  // config/cameras/fixed.yaml

cv::Mat3b frame_with_disc(int cx, int cy, int r, int width = 640, int height = 480) {
  cv::Mat3b img(height, width, cv::Vec3b(40, 120, 60));
  cv::circle(img, {cx, cy}, r, cv::Scalar(30, 140, 230), -1, cv::LINE_8);
  return img;
}

image_t image(const cv::Mat3b& bgr, bool jpeg, int64_t seq) {
  image_t m{};
  m.header.utime = rt::wall_time_now();
  m.header.seq = seq;
  m.header.frame_id = "camera_fixed";
  m.header.source_seq = -1;
  camera::encode_image(bgr, jpeg, 90, m);
  m.sensor_width = bgr.cols;
  m.sensor_height = bgr.rows;
  return m;
}

int64_t counter(const process_status_t& s, const std::string& name) {
  for (std::size_t i = 0; i < s.counter_names.size(); ++i)
    if (s.counter_names[i] == name) return s.counter_values[i];
  return 0;
}

class DetectorProcess : public ::testing::Test {
 protected:
  void SetUp() override {
    std::ofstream(dir / "detector.yaml") << "camera: fixed\ncalibration: "
                                         << ht::source_path("config/cameras/fixed.yaml")
                                         << "\ndetector: {mode: thesis}\n";
    detector = std::make_unique<ht::ChildProcess>(
        std::vector<std::string>{ht::bin("harvest-fruit-detector"), "--config", (dir / "detector.yaml").string(),
                                 "--lcm-url", url, "--no-netcheck"},
        dir / "detector.txt");
  }
  // The detections made from the image with header.seq == seq.
  std::optional<fruit_detections_t> result_for(int64_t seq) {
    std::optional<fruit_detections_t> found;
    ht::eventually(
        [&] {
          for (const auto& d : bus.on<fruit_detections_t>("FRUIT_FIXED"))
            if (d.header.source_seq == seq) found = d;
          return found.has_value();
        },
        5s);
    return found;
  }
  // Sends a frame with one fruit at (cx, cy) and checks it is found there.
  void expect_good_frame(int64_t seq, int cx, int cy, int r) {
    const cv::Mat3b img = frame_with_disc(cx, cy, r);
    const bool jpeg = seq % 2 == 0;
    bus.publish("CAMERA_FIXED", image(img, jpeg, seq));
    // Thesis mode: diameter from the area of the orange pixels.
    cv::Mat1b orange;
    cv::inRange(img, cv::Scalar(30, 140, 230), cv::Scalar(30, 140, 230), orange);
    const double diameter = 2 * std::sqrt(cv::countNonZero(orange) / CV_PI);
    const auto d = result_for(seq);
    ASSERT_TRUE(d) << "no detections for good frame " << seq << "\n" << detector->output();
    EXPECT_EQ(d->status, +fruit_detections_t::STATUS_OK) << d->status_text;
    ASSERT_EQ(d->num_fruits, 1) << "frame " << seq;
    const fruit_t& f = d->fruits[0];
    EXPECT_NEAR(f.u_px, cx, jpeg ? 1.0 : 0.5) << "frame " << seq;
    EXPECT_NEAR(f.v_px, cy, jpeg ? 1.0 : 0.5) << "frame " << seq;
    EXPECT_NEAR(f.diameter_px, diameter, (jpeg ? 0.05 : 0.01) * diameter) << "frame " << seq;
    EXPECT_NEAR(f.depth_m, 0.5 * (kFx + kFy) * 0.0725 / f.diameter_px, 1e-4);
    EXPECT_TRUE(f.selected);
    EXPECT_EQ(d->selected_index, 0);
    EXPECT_EQ(d->image_width, 640);
  }
  // Sends a bad frame and returns the status text of its detections.
  std::string bad_frame_text(const image_t& m) {
    bus.publish("CAMERA_FIXED", m);
    const auto d = result_for(m.header.seq);
    if (!d) return "<no detections published>";
    EXPECT_EQ(d->status, +fruit_detections_t::STATUS_BAD_IMAGE);
    EXPECT_EQ(d->num_fruits, 0);
    EXPECT_EQ(d->selected_index, -1);
    return d->status_text;
  }

  ht::TempDir dir;
  std::string url = ht::unique_lcm_url();
  test::Bus bus{url};
  std::unique_ptr<ht::ChildProcess> detector;
};

TEST_F(DetectorProcess, BadInputGivesAStatusErrorAndTheNextFrameIsDetected) {
  // Wait until the process is subscribed: resend the first frame until answered.
  int64_t seq = 1;
  ASSERT_TRUE(ht::eventually(
      [&] {
        bus.publish("CAMERA_FIXED", image(frame_with_disc(200, 240, 40), false, seq));
        std::this_thread::sleep_for(100ms);
        return bus.count("FRUIT_FIXED") > 0;
      },
      10s))
      << detector->output();
  seq = 100;
  expect_good_frame(seq++, 300, 200, 35);

  // Wrong encoding: the heartbeat reports the error until a good frame comes.
  image_t wrong = image(frame_with_disc(300, 200, 35), false, seq++);
  wrong.encoding = 7;
  EXPECT_NE(bad_frame_text(wrong).find("unknown encoding 7"), std::string::npos);
  EXPECT_TRUE(ht::eventually(
      [&] {
        for (const auto& s : bus.on<process_status_t>("PROCESS_STATUS"))
          if (s.state == process_status_t::STATE_ERROR && s.message.find("unknown encoding 7") != std::string::npos)
            return true;
        return false;
      },
      5s));
  expect_good_frame(seq++, 100, 400, 25);

  image_t truncated = image(frame_with_disc(300, 200, 35), false, seq++);
  truncated.data.resize(truncated.data.size() / 2);
  truncated.size = static_cast<int32_t>(truncated.data.size());
  EXPECT_NE(bad_frame_text(truncated).find("truncated 640x480 frame"), std::string::npos);
  expect_good_frame(seq++, 500, 100, 30);

  image_t zero = image(frame_with_disc(300, 200, 35), false, seq++);
  zero.width = zero.height = 0;
  zero.data.clear();
  zero.size = 0;
  EXPECT_NE(bad_frame_text(zero).find("bad image size 0x0"), std::string::npos);
  expect_good_frame(seq++, 320, 240, 50);

  image_t corrupt = image(frame_with_disc(300, 200, 35), true, seq++);
  for (std::size_t i = 20; i + 2 < corrupt.data.size(); ++i) corrupt.data[i] = static_cast<uint8_t>(i * 37);
  EXPECT_NE(bad_frame_text(corrupt).find("JPEG"), std::string::npos);
  expect_good_frame(seq++, 250, 260, 45);

  image_t cut = image(frame_with_disc(300, 200, 35), true, seq++);
  cut.data.resize(cut.data.size() / 2);
  cut.size = static_cast<int32_t>(cut.data.size());
  EXPECT_NE(bad_frame_text(cut).find("truncated JPEG"), std::string::npos);
  expect_good_frame(seq++, 420, 330, 20);

  const image_t small = image(frame_with_disc(100, 100, 20, 320, 240), false, seq++);
  EXPECT_NE(bad_frame_text(small).find("does not match the 640x480 calibration"), std::string::npos);
  expect_good_frame(seq++, 150, 150, 30);

  // A malformed LCM message (cut short) is dropped and counted, nothing published for it.
  const std::size_t before = bus.count("FRUIT_FIXED");
  auto bytes = rt::encode(image(frame_with_disc(300, 200, 35), false, seq++));
  bytes.resize(bytes.size() / 3);
  bus.publish_raw("CAMERA_FIXED", bytes);
  expect_good_frame(seq++, 330, 230, 30);
  EXPECT_EQ(bus.count("FRUIT_FIXED"), before + 1);

  // Six bad images and one malformed message counted; the process lives on.
  EXPECT_TRUE(ht::eventually(
      [&] {
        const auto s = bus.on<process_status_t>("PROCESS_STATUS");
        return !s.empty() && counter(s.back(), "bad_images") == 6 && s.back().decode_errors == 1;
      },
      5s))
      << detector->output();
  EXPECT_TRUE(detector->running());
  EXPECT_EQ(detector->stop(), 0) << detector->output();
}

// Mode learned: the model is loaded when the configuration is read, so a bad
// file stops --check-config (and a start) with exit 2 naming it.
TEST(DetectorProcessConfig, LearnedModeRefusesABadModelFileAtStart) {
  ht::TempDir dir;
  std::ofstream(dir / "bad.onnx") << "not a network";
  const auto check = [&](const std::string& model) {
    std::ofstream(dir / "detector.yaml") << "camera: fixed\ncalibration: "
                                         << ht::source_path("config/cameras/fixed.yaml")
                                         << "\ndetector: {mode: learned, model: " << model << "}\n";
    ht::ChildProcess p({ht::bin("harvest-fruit-detector"), "--config", (dir / "detector.yaml").string(),
                        "--check-config", "--lcm-url", ht::unique_lcm_url(), "--no-netcheck"},
                       dir / "out.txt");
    const int rc = p.wait(20s);
    return std::make_pair(rc, p.output());
  };
  auto [bad, bad_out] = check((dir / "bad.onnx").string());
  EXPECT_EQ(bad, 2) << bad_out;
  EXPECT_NE(bad_out.find((dir / "bad.onnx").string()), std::string::npos) << bad_out;
  EXPECT_NE(bad_out.find("detector.model"), std::string::npos) << bad_out;
  auto [missing, missing_out] = check((dir / "none.onnx").string());
  EXPECT_EQ(missing, 2) << missing_out;
  EXPECT_NE(missing_out.find("no such file"), std::string::npos) << missing_out;
  auto [good, good_out] = check(ht::source_path("config/vision/models/fruit_net.onnx"));
  EXPECT_EQ(good, 0) << good_out;
  EXPECT_NE(good_out.find("mode: learned"), std::string::npos) << good_out;
}

}  // namespace
}  // namespace harvest::vision
