// image_t <-> OpenCV images, with every field checked: a malformed frame
// gives a clear error text, never a crash or an out-of-bounds read.
#pragma once

#include <cstddef>
#include <cstdint>
#include <opencv2/core.hpp>
#include <optional>
#include <string>

#include "harvest/image_t.hpp"

namespace harvest::camera {

struct DecodedImage {
  cv::Mat3b bgr;      // MONO8 frames are expanded to BGR
  std::string error;  // empty when bgr is valid
  bool ok() const { return error.empty(); }
};

// Frames larger than this are refused before any pixel is allocated (a
// JPEG of a few kB can declare 16384 x 16384: 805 MB decoded).
inline constexpr int64_t kDefaultMaxPixels = int64_t{1} << 25;  // 33.5 MP, 100 MB as BGR

// max_pixels: the most pixels a frame may have (a detector passes its
// sensor's). A JPEG's dimensions are read from its frame header (SOFn) and
// must equal width x height before it is decoded.
DecodedImage decode_image(const image_t& msg, int64_t max_pixels = kDefaultMaxPixels);

struct JpegFrameSize {
  int width = 0;
  int height = 0;
};
// The dimensions a JPEG stream's frame header declares, found by walking its
// marker segments (bounds-checked); nullopt with `why` set if there is no
// well-formed frame header before the scan.
std::optional<JpegFrameSize> jpeg_frame_size(const uint8_t* data, std::size_t size, std::string& why);

// Fills encoding, width, height, stride, size and data (header and ROI are
// the caller's). jpeg_quality 1..100. Throws std::runtime_error if JPEG
// encoding fails.
void encode_image(const cv::Mat& bgr, bool jpeg, int jpeg_quality, image_t& msg);

// Sensor region an image shows (roi_px), defaulting to the whole image when
// the sender left it empty.
cv::Rect2d image_roi(const image_t& msg);

}  // namespace harvest::camera
