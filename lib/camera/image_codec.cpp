#include "camera/image_codec.hpp"

#include <cstring>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <stdexcept>

namespace harvest::camera {

namespace {
constexpr int kMaxSide = 16384;
}

DecodedImage decode_image(const image_t& msg) {
  DecodedImage out;
  const std::string size_text = std::to_string(msg.width) + "x" + std::to_string(msg.height);
  if (msg.width <= 0 || msg.height <= 0 || msg.width > kMaxSide || msg.height > kMaxSide) {
    out.error = "bad image size " + size_text;
    return out;
  }
  if (msg.size != static_cast<int32_t>(msg.data.size())) {
    out.error =
        "size field " + std::to_string(msg.size) + " does not match " + std::to_string(msg.data.size()) + " data bytes";
    return out;
  }
  if (msg.encoding == image_t::ENCODING_BGR8 || msg.encoding == image_t::ENCODING_MONO8) {
    const int channels = msg.encoding == image_t::ENCODING_BGR8 ? 3 : 1;
    const int64_t row = static_cast<int64_t>(msg.width) * channels;
    if (msg.stride < row) {
      out.error = "stride " + std::to_string(msg.stride) + " shorter than a row of " + std::to_string(row) + " bytes";
      return out;
    }
    const int64_t needed = static_cast<int64_t>(msg.stride) * (msg.height - 1) + row;
    if (static_cast<int64_t>(msg.data.size()) < needed) {
      out.error = "truncated " + size_text + " frame: " + std::to_string(msg.data.size()) + " of " +
                  std::to_string(needed) + " bytes";
      return out;
    }
    const cv::Mat view(msg.height, msg.width, channels == 3 ? CV_8UC3 : CV_8UC1, const_cast<uint8_t*>(msg.data.data()),
                       static_cast<std::size_t>(msg.stride));
    if (channels == 3)
      view.copyTo(out.bgr);
    else
      cv::cvtColor(view, out.bgr, cv::COLOR_GRAY2BGR);
    return out;
  }
  if (msg.encoding == image_t::ENCODING_JPEG) {
    if (msg.data.empty()) {
      out.error = "empty JPEG stream";
      return out;
    }
    // A JFIF stream starts with SOI (FF D8) and ends with EOI (FF D9); some
    // cameras pad after EOI with zeros. libjpeg "decodes" a cut-off stream by
    // filling the missing rows with grey, so check the end marker first.
    const auto& d = msg.data;
    if (d.size() < 4 || d[0] != 0xFF || d[1] != 0xD8) {
      out.error = "not a JPEG stream (no start-of-image marker, " + std::to_string(d.size()) + " bytes)";
      return out;
    }
    std::size_t end = d.size();
    while (end > 2 && d[end - 1] == 0) --end;
    if (d[end - 2] != 0xFF || d[end - 1] != 0xD9) {
      out.error = "truncated JPEG (no end-of-image marker, " + std::to_string(d.size()) + " bytes)";
      return out;
    }
    cv::Mat decoded;
    try {
      decoded = cv::imdecode(msg.data, cv::IMREAD_COLOR);
    } catch (const cv::Exception&) {
      decoded.release();
    }
    if (decoded.empty()) {
      out.error = "corrupt JPEG (" + std::to_string(msg.data.size()) + " bytes)";
      return out;
    }
    if (decoded.cols != msg.width || decoded.rows != msg.height) {
      out.error = "JPEG decodes to " + std::to_string(decoded.cols) + "x" + std::to_string(decoded.rows) +
                  ", header says " + size_text;
      return out;
    }
    out.bgr = decoded;
    return out;
  }
  out.error = "unknown encoding " + std::to_string(msg.encoding);
  return out;
}

void encode_image(const cv::Mat& bgr, bool jpeg, int jpeg_quality, image_t& msg) {
  msg.width = bgr.cols;
  msg.height = bgr.rows;
  if (jpeg) {
    std::vector<uint8_t> buf;
    if (!cv::imencode(".jpg", bgr, buf, {cv::IMWRITE_JPEG_QUALITY, jpeg_quality}))
      throw std::runtime_error("JPEG encoding failed");
    msg.encoding = image_t::ENCODING_JPEG;
    msg.stride = 0;
    msg.data = std::move(buf);
  } else {
    msg.encoding = bgr.channels() == 1 ? image_t::ENCODING_MONO8 : image_t::ENCODING_BGR8;
    const std::size_t row = static_cast<std::size_t>(bgr.cols) * bgr.elemSize();
    msg.stride = static_cast<int32_t>(row);
    msg.data.resize(row * static_cast<std::size_t>(bgr.rows));
    for (int y = 0; y < bgr.rows; ++y)
      std::memcpy(msg.data.data() + row * static_cast<std::size_t>(y), bgr.ptr(y), row);
  }
  msg.size = static_cast<int32_t>(msg.data.size());
}

cv::Rect2d image_roi(const image_t& msg) {
  if (msg.roi_px[2] > 0 && msg.roi_px[3] > 0) return {msg.roi_px[0], msg.roi_px[1], msg.roi_px[2], msg.roi_px[3]};
  return {0, 0, static_cast<double>(msg.width), static_cast<double>(msg.height)};
}

}  // namespace harvest::camera
