// image_t <-> OpenCV images, with every field checked: a malformed frame
// gives a clear error text, never a crash or an out-of-bounds read.
#pragma once

#include <opencv2/core.hpp>
#include <string>

#include "harvest/image_t.hpp"

namespace harvest::camera {

struct DecodedImage {
  cv::Mat3b bgr;      // MONO8 frames are expanded to BGR
  std::string error;  // empty when bgr is valid
  bool ok() const { return error.empty(); }
};

DecodedImage decode_image(const image_t& msg);

// Fills encoding, width, height, stride, size and data (header and ROI are
// the caller's). jpeg_quality 1..100. Throws std::runtime_error if JPEG
// encoding fails.
void encode_image(const cv::Mat& bgr, bool jpeg, int jpeg_quality, image_t& msg);

// Sensor region an image shows (roi_px), defaulting to the whole image when
// the sender left it empty.
cv::Rect2d image_roi(const image_t& msg);

}  // namespace harvest::camera
