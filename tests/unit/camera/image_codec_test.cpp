// image_t <-> cv::Mat: round trips of every encoding, and every malformed
// frame is an error with a clear text, never a crash or an over-read.
#include "camera/image_codec.hpp"

#include <gtest/gtest.h>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

namespace harvest::camera {
namespace {

cv::Mat3b test_image(int w = 64, int h = 48) {
  cv::Mat3b img(h, w);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) img(y, x) = cv::Vec3b(static_cast<uint8_t>(x * 4), static_cast<uint8_t>(y * 5), 90);
  return img;
}

TEST(ImageCodec, RawRoundTripIsExact) {
  const cv::Mat3b img = test_image();
  image_t m{};
  encode_image(img, false, 90, m);
  EXPECT_EQ(m.encoding, +image_t::ENCODING_BGR8);
  EXPECT_EQ(m.stride, 64 * 3);
  EXPECT_EQ(m.size, 64 * 48 * 3);
  const DecodedImage d = decode_image(m);
  ASSERT_TRUE(d.ok()) << d.error;
  EXPECT_EQ(cv::norm(d.bgr, img, cv::NORM_INF), 0);
}

TEST(ImageCodec, PaddedStrideAndMono) {
  const cv::Mat3b img = test_image();
  image_t m{};
  encode_image(img, false, 90, m);
  // Re-pack with 8 padding bytes per row.
  const int row = 64 * 3, stride = row + 8;
  std::vector<uint8_t> padded(static_cast<std::size_t>(stride) * 48, 0xAB);
  for (int y = 0; y < 48; ++y)
    std::copy_n(m.data.begin() + y * row, row, padded.begin() + static_cast<std::ptrdiff_t>(y) * stride);
  m.stride = stride;
  m.data = padded;
  m.size = static_cast<int32_t>(padded.size());
  DecodedImage d = decode_image(m);
  ASSERT_TRUE(d.ok()) << d.error;
  EXPECT_EQ(cv::norm(d.bgr, img, cv::NORM_INF), 0);

  cv::Mat1b grey;
  cv::cvtColor(img, grey, cv::COLOR_BGR2GRAY);
  encode_image(grey, false, 90, m);
  EXPECT_EQ(m.encoding, +image_t::ENCODING_MONO8);
  d = decode_image(m);
  ASSERT_TRUE(d.ok()) << d.error;
  cv::Mat3b expected;
  cv::cvtColor(grey, expected, cv::COLOR_GRAY2BGR);
  EXPECT_EQ(cv::norm(d.bgr, expected, cv::NORM_INF), 0);
}

TEST(ImageCodec, JpegRoundTripIsClose) {
  const cv::Mat3b img = test_image(160, 120);
  image_t m{};
  encode_image(img, true, 95, m);
  EXPECT_EQ(m.encoding, +image_t::ENCODING_JPEG);
  EXPECT_EQ(m.width, 160);
  EXPECT_EQ(m.height, 120);
  EXPECT_LT(m.size, 160 * 120 * 3);
  const DecodedImage d = decode_image(m);
  ASSERT_TRUE(d.ok()) << d.error;
  EXPECT_LT(cv::norm(d.bgr, img, cv::NORM_L1) / (160 * 120 * 3), 3.0);  // mean abs error per channel
  // Zero padding after the end-of-image marker (some cameras) is accepted.
  m.data.resize(m.data.size() + 16, 0);
  m.size = static_cast<int32_t>(m.data.size());
  EXPECT_TRUE(decode_image(m).ok()) << decode_image(m).error;
}

// decode_image reads JPEG with libjpeg-turbo itself, straight into BGR; the
// pixels must be exactly cv::imdecode's (the detectors' outputs, and every
// recorded detection a replay compares with, depend on them): colour,
// baseline, optimised and progressive, several qualities, odd sizes, and grey.
TEST(ImageCodec, JpegPixelsAreExactlyOpenCvs) {
  cv::RNG rng(17);
  for (const int variant : {0, int{cv::IMWRITE_JPEG_OPTIMIZE}, int{cv::IMWRITE_JPEG_PROGRESSIVE}})
    for (const int quality : {50, 90, 98})
      for (const cv::Size size : {cv::Size(320, 240), cv::Size(75, 33)}) {
        cv::Mat3b img = test_image(size.width, size.height);
        cv::Mat noise(img.size(), img.type());
        rng.fill(noise, cv::RNG::NORMAL, 0, 25);
        img += noise;
        cv::circle(img, {size.width / 2, size.height / 2}, size.height / 3, cv::Scalar(30, 120, 240), -1);
        for (const bool grey : {false, true}) {
          cv::Mat src = img;
          if (grey) cv::cvtColor(img, src, cv::COLOR_BGR2GRAY);
          image_t m{};
          m.encoding = image_t::ENCODING_JPEG;
          m.width = size.width;
          m.height = size.height;
          std::vector<int> params = {cv::IMWRITE_JPEG_QUALITY, quality};
          if (variant != 0) params.insert(params.end(), {variant, 1});
          cv::imencode(".jpg", src, m.data, params);
          m.size = static_cast<int32_t>(m.data.size());
          const DecodedImage d = decode_image(m);
          ASSERT_TRUE(d.ok()) << d.error;
          const cv::Mat reference = cv::imdecode(m.data, cv::IMREAD_COLOR);
          ASSERT_EQ(d.bgr.size(), reference.size());
          EXPECT_EQ(cv::norm(d.bgr, reference, cv::NORM_INF), 0)
              << "variant " << variant << " quality " << quality << " " << size << (grey ? " grey" : "");
        }
      }
}

std::string error_of(image_t m) { return decode_image(m).error; }

TEST(ImageCodec, MalformedFramesAreErrorsNamingTheProblem) {
  image_t raw{};
  encode_image(test_image(), false, 90, raw);
  image_t jpeg{};
  encode_image(test_image(), true, 90, jpeg);

  image_t m = raw;
  m.width = 0;
  EXPECT_NE(error_of(m).find("bad image size 0x48"), std::string::npos);
  m = raw;
  m.height = -5;
  EXPECT_NE(error_of(m).find("bad image size"), std::string::npos);
  m = raw;
  m.width = 100000;
  EXPECT_NE(error_of(m).find("bad image size"), std::string::npos);
  m = raw;
  m.encoding = 9;
  EXPECT_NE(error_of(m).find("unknown encoding 9"), std::string::npos);
  m = raw;
  m.size += 1;
  EXPECT_NE(error_of(m).find("does not match"), std::string::npos);
  m = raw;
  m.data.resize(m.data.size() - 1);
  m.size = static_cast<int32_t>(m.data.size());
  EXPECT_NE(error_of(m).find("truncated 64x48 frame"), std::string::npos);
  m = raw;
  m.stride = 10;
  EXPECT_NE(error_of(m).find("stride 10 shorter"), std::string::npos);
  m = raw;
  m.encoding = image_t::ENCODING_MONO8;  // 1 byte/px: data is larger than needed, which is fine
  EXPECT_TRUE(decode_image(m).ok());

  m = jpeg;
  m.data.clear();
  m.size = 0;
  EXPECT_FALSE(error_of(m).empty());
  m = jpeg;
  m.data[0] = 0;
  EXPECT_NE(error_of(m).find("not a JPEG stream"), std::string::npos);
  m = jpeg;
  m.data.resize(m.data.size() * 2 / 3);
  m.size = static_cast<int32_t>(m.data.size());
  EXPECT_NE(error_of(m).find("truncated JPEG"), std::string::npos);
  m = jpeg;
  for (std::size_t i = 2; i + 2 < m.data.size(); ++i) m.data[i] = static_cast<uint8_t>(i * 53);
  EXPECT_NE(error_of(m).find("JPEG"), std::string::npos);
  m = jpeg;
  m.width = 32;  // the message disagrees with the stream's frame header
  EXPECT_EQ(error_of(m), "JPEG header says 64x48, message says 32x48");
}

// The offset of the first SOF0 marker segment's length field in a JPEG.
std::size_t sof0(const std::vector<uint8_t>& d) {
  for (std::size_t i = 2; i + 1 < d.size(); ++i)
    if (d[i] == 0xFF && d[i + 1] == 0xC0) return i + 2;
  ADD_FAILURE() << "no SOF0";
  return 0;
}

TEST(ImageCodec, JpegDimensionsAreCheckedFromTheHeaderBeforeDecoding) {
  image_t jpeg{};
  encode_image(test_image(), true, 90, jpeg);
  std::string why;
  const auto size = jpeg_frame_size(jpeg.data.data(), jpeg.data.size(), why);
  ASSERT_TRUE(size) << why;
  EXPECT_EQ(size->width, 64);
  EXPECT_EQ(size->height, 48);

  // A decompression bomb: a 1 kB stream whose header declares 16000 x 16000
  // (768 MB decoded) is refused before imdecode allocates anything.
  image_t bomb = jpeg;
  const std::size_t at = sof0(bomb.data);
  bomb.data[at + 3] = bomb.data[at + 5] = 16000 >> 8;
  bomb.data[at + 4] = bomb.data[at + 6] = 16000 & 0xFF;
  EXPECT_EQ(error_of(bomb), "JPEG header says 16000x16000, message says 64x48");
  bomb.width = bomb.height = 16000;  // the message agreeing does not help: too many pixels
  EXPECT_EQ(error_of(bomb), "image size 16000x16000 is more than 33554432 pixels");
  // A detector passes its sensor's size as the limit.
  EXPECT_EQ(decode_image(jpeg, 64 * 47).error, "image size 64x48 is more than 3008 pixels");
  EXPECT_TRUE(decode_image(jpeg, 64 * 48).ok());

  // Frame headers that are not there or do not fit.
  image_t m = jpeg;
  m.data[at] = 0xFF;  // SOF0's length now runs past the end
  EXPECT_NE(error_of(m).find("runs past the end"), std::string::npos) << error_of(m);
  m = jpeg;
  m.data[at - 1] = 0xDA;  // a scan where the frame header was
  EXPECT_NE(error_of(m).find("scan before any frame header"), std::string::npos) << error_of(m);
  m = jpeg;
  m.data[at - 2] = 0x00;  // no marker where one must be
  EXPECT_NE(error_of(m).find("no marker at byte"), std::string::npos) << error_of(m);
  const uint8_t only_soi[] = {0xFF, 0xD8, 0xFF, 0xE0};
  EXPECT_FALSE(jpeg_frame_size(only_soi, sizeof only_soi, why));
}

TEST(ImageCodec, RoiDefaultsToTheWholeImage) {
  image_t m{};
  encode_image(test_image(), false, 90, m);
  EXPECT_EQ(image_roi(m), cv::Rect2d(0, 0, 64, 48));
  m.roi_px[0] = 8;
  m.roi_px[1] = 6;
  m.roi_px[2] = 32;
  m.roi_px[3] = 24;
  EXPECT_EQ(image_roi(m), cv::Rect2d(8, 6, 32, 24));
}

}  // namespace
}  // namespace harvest::camera
