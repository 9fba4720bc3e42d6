#include "camera/image_codec.hpp"

// jpeglib.h needs FILE and size_t declared first.
#include <jpeglib.h>

#include <csetjmp>
#include <cstdio>
#include <cstring>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <stdexcept>

namespace harvest::camera {

namespace {
constexpr int kMaxSide = 16384;

struct JpegErrors {
  jpeg_error_mgr mgr;
  std::jmp_buf jump;
};

// Decodes a 1- or 3-component JPEG straight into BGR rows with libjpeg-turbo
// (JCS_EXT_BGR: the colour conversion writes the bytes in OpenCV's order).
// cv::imdecode makes the same pixels (same library, same defaults: ISLOW
// DCT, fancy upsampling) but decodes to RGB and swaps every pixel after,
// which was a fifth of its time on 320 x 240 frames. False: corrupt, or
// another component count (left to cv::imdecode). Only plain locals here:
// an error longjmps out of libjpeg.
bool decode_jpeg_bgr(const uint8_t* data, std::size_t size, int width, int height, uint8_t* bgr, std::size_t stride,
                     bool& other_components) {
  jpeg_decompress_struct cinfo{};
  JpegErrors errors{};
  cinfo.err = jpeg_std_error(&errors.mgr);
  errors.mgr.error_exit = [](j_common_ptr c) { std::longjmp(reinterpret_cast<JpegErrors*>(c->err)->jump, 1); };
  errors.mgr.output_message = [](j_common_ptr) {};  // warnings (corrupt data) are not printed
  if (setjmp(errors.jump) != 0) {
    jpeg_destroy_decompress(&cinfo);
    return false;
  }
  jpeg_create_decompress(&cinfo);
  jpeg_mem_src(&cinfo, data, static_cast<unsigned long>(size));
  jpeg_read_header(&cinfo, TRUE);
  if ((cinfo.num_components != 1 && cinfo.num_components != 3) || static_cast<int>(cinfo.image_width) != width ||
      static_cast<int>(cinfo.image_height) != height) {
    other_components = true;
    jpeg_destroy_decompress(&cinfo);
    return false;
  }
  cinfo.out_color_space = JCS_EXT_BGR;
  jpeg_start_decompress(&cinfo);
  while (cinfo.output_scanline < cinfo.output_height) {
    JSAMPROW row = bgr + static_cast<std::size_t>(cinfo.output_scanline) * stride;
    jpeg_read_scanlines(&cinfo, &row, 1);
  }
  jpeg_finish_decompress(&cinfo);
  jpeg_destroy_decompress(&cinfo);
  return true;
}
}  // namespace

std::optional<JpegFrameSize> jpeg_frame_size(const uint8_t* d, std::size_t n, std::string& why) {
  if (n < 4 || d[0] != 0xFF || d[1] != 0xD8) {
    why = "no start-of-image marker";
    return std::nullopt;
  }
  std::size_t pos = 2;
  while (pos < n) {
    if (d[pos] != 0xFF) {
      why = "no marker at byte " + std::to_string(pos);
      return std::nullopt;
    }
    while (pos < n && d[pos] == 0xFF) ++pos;  // fill bytes
    if (pos >= n) break;
    const uint8_t marker = d[pos++];
    if (marker == 0x01 || (marker >= 0xD0 && marker <= 0xD7)) continue;  // no length field
    if (marker == 0xD9 || marker == 0xDA) {
      why = marker == 0xDA ? "scan before any frame header" : "end of image before any frame header";
      return std::nullopt;
    }
    if (pos + 2 > n) break;
    const std::size_t length = (static_cast<std::size_t>(d[pos]) << 8) | d[pos + 1];
    if (length < 2 || pos + length > n) {
      why = "marker segment of " + std::to_string(length) + " bytes at byte " + std::to_string(pos) +
            " runs past the end";
      return std::nullopt;
    }
    // SOF0..SOF15 except DHT (C4), JPG (C8) and DAC (CC): precision, height, width.
    if (marker >= 0xC0 && marker <= 0xCF && marker != 0xC4 && marker != 0xC8 && marker != 0xCC) {
      if (length < 7) {
        why = "frame header of " + std::to_string(length) + " bytes";
        return std::nullopt;
      }
      JpegFrameSize s;
      s.height = (d[pos + 3] << 8) | d[pos + 4];
      s.width = (d[pos + 5] << 8) | d[pos + 6];
      return s;
    }
    pos += length;
  }
  why = "stream ends before a frame header";
  return std::nullopt;
}

DecodedImage decode_image(const image_t& msg, int64_t max_pixels) {
  DecodedImage out;
  const std::string size_text = std::to_string(msg.width) + "x" + std::to_string(msg.height);
  if (msg.width <= 0 || msg.height <= 0 || msg.width > kMaxSide || msg.height > kMaxSide) {
    out.error = "bad image size " + size_text;
    return out;
  }
  if (static_cast<int64_t>(msg.width) * msg.height > max_pixels) {
    out.error = "image size " + size_text + " is more than " + std::to_string(max_pixels) + " pixels";
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
    // The header's dimensions decide what imdecode allocates: check them
    // before it runs (a decompression bomb declares more than it says here).
    std::string why;
    const auto header = jpeg_frame_size(d.data(), d.size(), why);
    if (!header) {
      out.error = "corrupt JPEG (" + why + ", " + std::to_string(d.size()) + " bytes)";
      return out;
    }
    if (header->width != msg.width || header->height != msg.height) {
      out.error = "JPEG header says " + std::to_string(header->width) + "x" + std::to_string(header->height) +
                  ", message says " + size_text;
      return out;
    }
    cv::Mat decoded(msg.height, msg.width, CV_8UC3);
    bool other_components = false;
    if (!decode_jpeg_bgr(d.data(), d.size(), msg.width, msg.height, decoded.data, decoded.step, other_components)) {
      decoded.release();
      if (other_components) {  // CMYK and the like: OpenCV's conversions
        try {
          decoded = cv::imdecode(msg.data, cv::IMREAD_COLOR);
        } catch (const cv::Exception&) {
          decoded.release();
        }
      }
    }
    if (decoded.empty()) {
      out.error = "corrupt JPEG (" + std::to_string(msg.data.size()) + " bytes)";
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
