// libFuzzer target: camera::decode_image (lib/camera/image_codec), raw and
// JPEG. The input's first 8 bytes are the message's encoding (mod 3 + a
// sometimes-unknown value), width, height (16 bits each, big-endian) and
// stride (8 bits x 4); the rest is the data, and size says its length. The
// pixel limit is 2^20 so no input can make a legitimate large allocation.
// Properties, besides "no crash, no sanitizer report, no allocation beyond
// libFuzzer's limit" (a JPEG header declaring more than the message would
// be decoded before the check): an accepted frame has exactly the message's
// width x height; a JPEG frame header, when found, is the size accepted.
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <string>

#include "camera/image_codec.hpp"

namespace camera = harvest::camera;

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, std::size_t size) {
  if (size < 8) return 0;
  harvest::image_t m{};
  m.encoding = static_cast<int8_t>(data[0] % 4 == 3 ? data[0] : data[0] % 4);
  m.width = (data[1] << 8) | data[2];
  m.height = (data[3] << 8) | data[4];
  m.stride = data[5] * 4 + (data[6] % 4);
  const bool size_lies = data[7] == 0xFF;
  m.data.assign(data + 8, data + size);
  m.size = static_cast<int32_t>(m.data.size()) + (size_lies ? 1 : 0);
  const camera::DecodedImage d = camera::decode_image(m, int64_t{1} << 20);
  if (!d.ok()) return 0;
  if (d.bgr.cols != m.width || d.bgr.rows != m.height) std::abort();
  if (m.encoding == harvest::image_t::ENCODING_JPEG) {
    std::string why;
    const auto header = camera::jpeg_frame_size(m.data.data(), m.data.size(), why);
    if (!header || header->width != m.width || header->height != m.height) std::abort();
  }
  return 0;
}
