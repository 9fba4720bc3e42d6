// harvest-camera as a real process over real LCM: a folder of images and a
// video file are published with capture time and sequence numbers, with
// digital zoom, output resolution and JPEG; a missing device is retried with
// back-off; a bad file is an error that names it.
#include <gtest/gtest.h>

#include <fstream>
#include <harvest/image_t.hpp>
#include <harvest/process_status_t.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <opencv2/videoio.hpp>

#include "bus.hpp"
#include "camera/image_codec.hpp"
#include "runtime/clock.hpp"
#include "test_support.hpp"

namespace ht = harvest::testing;
using namespace std::chrono_literals;

namespace harvest::vision {
namespace {

const cv::Scalar kLeaf(40, 120, 60), kOrange(30, 140, 230);

// A 320x240 leaf-green frame with one orange disc.
cv::Mat3b frame_with_disc(double cx, double cy, double r) {
  cv::Mat3b img(240, 320, cv::Vec3b(40, 120, 60));
  cv::circle(img, cv::Point(static_cast<int>(std::lround(cx * 16)), static_cast<int>(std::lround(cy * 16))),
             static_cast<int>(std::lround(r * 16)), kOrange, -1, cv::LINE_8, 4);
  return img;
}

// Centroid and equivalent diameter of the orange pixels (tolerant colour test: JPEG).
struct Blob {
  double x = 0, y = 0, diameter = 0;
};
Blob orange_blob(const cv::Mat3b& img) {
  cv::Mat1b mask;
  cv::inRange(img, cv::Scalar(0, 90, 170), cv::Scalar(90, 190, 255), mask);
  const cv::Moments m = cv::moments(mask, true);
  if (m.m00 == 0) return {};
  return {m.m10 / m.m00, m.m01 / m.m00, 2 * std::sqrt(m.m00 / CV_PI)};
}

class CameraProcess : public ::testing::Test {
 protected:
  ht::TempDir dir;
  std::string url = ht::unique_lcm_url();
  std::string write(const std::string& name, const std::string& text) {
    std::ofstream(dir / name) << text;
    return (dir / name).string();
  }
  std::vector<std::string> args(const std::string& config) {
    return {ht::bin("harvest-camera"), "--config", config, "--lcm-url", url, "--no-netcheck"};
  }
};

TEST_F(CameraProcess, FolderWithZoomAndJpegInNameOrderSkippingABadFile) {
  std::filesystem::create_directory(dir / "frames");
  // Written out of order; published in name order. Disc centres in sensor pixels.
  const std::vector<double> xs = {100, 130, 160, 190, 220};
  for (int i = 4; i >= 0; --i)
    ASSERT_TRUE(cv::imwrite((dir / "frames" / ("f0" + std::to_string(i) + ".png")).string(),
                            frame_with_disc(xs[static_cast<std::size_t>(i)], 120, 15)));
  std::ofstream(dir / "frames" / "f02b.png") << "this is not a PNG";
  std::ofstream(dir / "frames" / "notes.txt") << "not an image, not listed";

  const auto config = write("camera.yaml",
                            "camera: hand\nsource: folder\npath: frames\nframe_rate_hz: 25\n"
                            "encoding: jpeg\njpeg_quality: 95\nzoom_roi_px: [80, 60, 160, 120]\n"
                            "output_width: 320\noutput_height: 240\n");
  test::Bus bus(url);
  ASSERT_TRUE(bus.good());
  const int64_t started = rt::wall_time_now();
  ht::ChildProcess camera(args(config), dir / "camera.txt");
  ASSERT_EQ(camera.wait(20s), 0) << camera.output();  // stops by itself at the end of the folder
  const int64_t ended = rt::wall_time_now();
  ASSERT_TRUE(ht::eventually([&] { return bus.count("CAMERA_HAND") >= 5; }, 2s));

  const auto frames = bus.on<image_t>("CAMERA_HAND");
  ASSERT_EQ(frames.size(), 5u) << camera.output();
  for (std::size_t i = 0; i < frames.size(); ++i) {
    const image_t& f = frames[i];
    EXPECT_EQ(f.header.frame_id, "camera_hand");
    if (i > 0) {
      EXPECT_EQ(f.header.seq, frames[i - 1].header.seq + 1);
      EXPECT_GT(f.header.utime, frames[i - 1].header.utime);
    }
    EXPECT_GE(f.header.utime, started);
    EXPECT_LE(f.header.utime, ended);
    EXPECT_GE(f.header.publish_utime, f.header.utime);
    EXPECT_EQ(f.encoding, +image_t::ENCODING_JPEG);
    EXPECT_EQ(f.sensor_width, 320);
    EXPECT_EQ(f.sensor_height, 240);
    EXPECT_EQ(f.roi_px[0], 80);
    EXPECT_EQ(f.roi_px[1], 60);
    EXPECT_EQ(f.roi_px[2], 160);
    EXPECT_EQ(f.roi_px[3], 120);
    const camera::DecodedImage d = camera::decode_image(f);
    ASSERT_TRUE(d.ok()) << d.error;
    ASSERT_EQ(d.bgr.cols, 320);
    ASSERT_EQ(d.bgr.rows, 240);
    // The zoom doubles the disc and moves it: x_out = 2 (x + 0.5 - 80) - 0.5.
    const Blob b = orange_blob(d.bgr);
    EXPECT_NEAR(b.x, 2 * (xs[i] + 0.5 - 80) - 0.5, 1.0) << "frame " << i;
    EXPECT_NEAR(b.y, 2 * (120 + 0.5 - 60) - 0.5, 1.0) << "frame " << i;
    EXPECT_NEAR(b.diameter, 60, 2.0) << "frame " << i;
  }
  // The unreadable file is named, counted, and the next frame still follows.
  EXPECT_NE(camera.output().find("cannot read image " + (dir / "frames" / "f02b.png").string()), std::string::npos)
      << camera.output();
  const auto status = bus.on<process_status_t>("PROCESS_STATUS");
  ASSERT_FALSE(status.empty());
  const process_status_t& last = status.back();
  int64_t bad = -1;
  for (int i = 0; i < last.num_counters; ++i)
    if (last.counter_names[static_cast<std::size_t>(i)] == "bad_frames")
      bad = last.counter_values[static_cast<std::size_t>(i)];
  EXPECT_EQ(bad, 1);
  EXPECT_EQ(last.messages_published, 5);  // the camera node's frames (the heartbeat counts its nodes only)
}

TEST_F(CameraProcess, VideoFileAtOutputResolution) {
  const auto video = (dir / "clip.avi").string();
  constexpr int kFrames = 8;
  {
    cv::VideoWriter writer(video, cv::VideoWriter::fourcc('M', 'J', 'P', 'G'), 10, cv::Size(320, 240));
    ASSERT_TRUE(writer.isOpened()) << "OpenCV cannot write MJPG AVI";
    for (int i = 0; i < kFrames; ++i) writer.write(frame_with_disc(60 + 25 * i, 100, 20));
  }
  const auto config = write("camera.yaml", "camera: fixed\nsource: video\npath: " + video +
                                               "\nframe_rate_hz: 40\nencoding: bgr8\n"
                                               "output_width: 160\noutput_height: 120\n");
  test::Bus bus(url);
  ht::ChildProcess camera(args(config), dir / "camera.txt");
  ASSERT_EQ(camera.wait(20s), 0) << camera.output();
  ASSERT_TRUE(ht::eventually([&] { return bus.count("CAMERA_FIXED") >= kFrames; }, 2s));
  const auto frames = bus.on<image_t>("CAMERA_FIXED");
  ASSERT_EQ(frames.size(), static_cast<std::size_t>(kFrames)) << camera.output();
  for (int i = 0; i < kFrames; ++i) {
    const image_t& f = frames[static_cast<std::size_t>(i)];
    if (i > 0) {
      EXPECT_EQ(f.header.seq, frames[static_cast<std::size_t>(i) - 1].header.seq + 1);
      EXPECT_GT(f.header.utime, frames[static_cast<std::size_t>(i) - 1].header.utime);
    }
    EXPECT_EQ(f.encoding, +image_t::ENCODING_BGR8);
    EXPECT_EQ(f.width, 160);
    EXPECT_EQ(f.height, 120);
    EXPECT_EQ(f.stride, 160 * 3);
    EXPECT_EQ(f.sensor_width, 320);
    EXPECT_EQ(f.roi_px[2], 320);  // no zoom: the whole sensor
    const camera::DecodedImage d = camera::decode_image(f);
    ASSERT_TRUE(d.ok()) << d.error;
    const Blob b = orange_blob(d.bgr);
    EXPECT_NEAR(b.x, (60 + 25 * i + 0.5) / 2 - 0.5, 1.0) << "frame " << i;
    EXPECT_NEAR(b.y, (100 + 0.5) / 2 - 0.5, 1.0) << "frame " << i;
    EXPECT_NEAR(b.diameter, 20, 1.5) << "frame " << i;
  }
}

TEST_F(CameraProcess, BadOrMissingFileIsAnErrorNamingIt) {
  const auto garbage = write("broken.avi", std::string(4096, 'x'));
  for (const std::string& path : {garbage, (dir / "missing.avi").string()}) {
    const auto config = write("camera.yaml", "source: video\npath: " + path + "\n");
    ht::ChildProcess camera(args(config), dir / "camera.txt");
    EXPECT_EQ(camera.wait(20s), 1) << camera.output();
    EXPECT_NE(camera.output().find(path), std::string::npos) << camera.output();
  }
  const auto config = write("camera.yaml", "source: folder\npath: " + (dir / "nowhere").string() + "\n");
  ht::ChildProcess camera(args(config), dir / "camera.txt");
  EXPECT_EQ(camera.wait(20s), 1) << camera.output();
  EXPECT_NE(camera.output().find("image folder " + (dir / "nowhere").string()), std::string::npos) << camera.output();
}

TEST_F(CameraProcess, MissingDeviceIsRetriedWithBackOffWithoutCrashing) {
  const std::string device = "/dev/video-missing-" + std::to_string(getpid());
  const auto config =
      write("camera.yaml", "source: device\ndevice: {path: " + device + "}\nretry_initial_s: 0.1\nretry_max_s: 0.4\n");
  test::Bus bus(url);
  ht::ChildProcess camera(args(config), dir / "camera.txt");
  // Each failure is logged with the next wait, doubling up to the cap.
  ASSERT_TRUE(ht::eventually([&] { return camera.output().find("retrying in 0.40 s") != std::string::npos; }, 15s))
      << camera.output();
  const std::string out = camera.output();
  const auto a = out.find("retrying in 0.10 s"), b = out.find("retrying in 0.20 s"), c = out.find("retrying in 0.40 s");
  ASSERT_NE(a, std::string::npos) << out;
  ASSERT_NE(b, std::string::npos) << out;
  EXPECT_LT(a, b);
  EXPECT_LT(b, c);
  EXPECT_EQ(out.find("retrying in 0.80 s"), std::string::npos) << out;
  EXPECT_NE(out.find(device), std::string::npos);
  // The heartbeat says what is wrong, and the process is still alive.
  ASSERT_TRUE(ht::eventually(
      [&] {
        for (const auto& s : bus.on<process_status_t>("PROCESS_STATUS"))
          if (s.state == process_status_t::STATE_ERROR && s.message.find(device) != std::string::npos) return true;
        return false;
      },
      5s));
  EXPECT_TRUE(camera.running());
  EXPECT_EQ(bus.count("CAMERA_FIXED"), 0u);
  EXPECT_EQ(camera.stop(), 0) << camera.output();  // SIGTERM: a clean exit
}

}  // namespace
}  // namespace harvest::vision
