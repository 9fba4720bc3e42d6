#include "logtools/frames.hpp"

#include <gtest/gtest.h>

#include <filesystem>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <sstream>

#include "harvest/fruit_detections_t.hpp"
#include "harvest/image_t.hpp"
#include "runtime/log_io.hpp"
#include "test_support.hpp"

namespace lt = harvest::logtools;
namespace rt = harvest::rt;
namespace ht = harvest::testing;

TEST(Frames, DetectionsAreDrawnOnTheirOwnImage) {
  // Two grey JPEG frames; the second has a selected fruit at (100, 60), d = 40 px.
  std::vector<rt::LogRecord> log;
  for (int k = 0; k < 2; ++k) {
    harvest::image_t img{};
    img.header.utime = 1000 + k;
    img.encoding = harvest::image_t::ENCODING_JPEG;
    img.width = img.sensor_width = 160;
    img.height = img.sensor_height = 120;
    cv::Mat grey(120, 160, CV_8UC3, cv::Scalar(128, 128, 128));
    cv::imencode(".jpg", grey, img.data);
    img.size = static_cast<int32_t>(img.data.size());
    log.push_back({img.header.utime, "CAMERA_FIXED", rt::encode(img)});
  }
  harvest::fruit_detections_t d{};
  d.header.utime = 1001;
  d.num_fruits = 1;
  d.fruits.resize(1);
  d.fruits[0].u_px = 100;
  d.fruits[0].v_px = 60;
  d.fruits[0].diameter_px = 40;
  d.fruits[0].selected = true;
  log.push_back({1002, "FRUIT_FIXED", rt::encode(d)});

  ht::TempDir dir;
  lt::FramesOptions o{"CAMERA_FIXED", "FRUIT_FIXED", (dir / "frames").string(), 1, 10};
  std::ostringstream err;
  const auto written = lt::write_frames(log, o, err);
  ASSERT_EQ(written.size(), 2u) << err.str();
  const cv::Mat3b plain = cv::imread(written[0]), marked = cv::imread(written[1]);
  ASSERT_FALSE(marked.empty());
  // The circle's rightmost point (u + r, v) is red on the second frame only.
  const cv::Vec3b on = marked(60, 120), off = plain(60, 120);
  EXPECT_GT(on[2], 200) << on;
  EXPECT_LT(on[0], 80) << on;
  EXPECT_NEAR(off[2], 128, 20);
  o.image_channel = "NOPE";
  EXPECT_THROW(lt::write_frames(log, o, err), std::runtime_error);
}

// A half-size frame of a 160x120 sensor region comes out at the region's size, with nothing drawn on it.
TEST(Frames, SensorSizeFramesAreTheImageAloneAtTheSizeOfTheRegionTheyShow) {
  harvest::image_t img{};
  img.header.utime = 1000;
  img.encoding = harvest::image_t::ENCODING_BGR8;
  img.width = 80;
  img.height = 60;
  img.stride = 240;
  img.sensor_width = 160;
  img.sensor_height = 120;
  img.roi_px[2] = 160;
  img.roi_px[3] = 120;
  img.data.assign(240 * 60, 128);
  img.size = static_cast<int32_t>(img.data.size());
  ht::TempDir dir;
  lt::FramesOptions o{"CAMERA_HAND", "", (dir / "frames").string(), 1, 10};
  o.sensor_size = true;
  o.format = "bmp";
  std::ostringstream err;
  const auto written = lt::write_frames({{1000, "CAMERA_HAND", rt::encode(img)}}, o, err);
  ASSERT_EQ(written.size(), 1u) << err.str();
  EXPECT_EQ(std::filesystem::path(written[0]).extension(), ".bmp");
  const cv::Mat3b out = cv::imread(written[0]);
  EXPECT_EQ(out.cols, 160);
  EXPECT_EQ(out.rows, 120);
  // No label: the whole image stays the grey it was.
  double lo = 0, hi = 0;
  cv::minMaxLoc(out.reshape(1), &lo, &hi);
  EXPECT_EQ(lo, 128);
  EXPECT_EQ(hi, 128);
}
