// libFuzzer target: the python-can udp_multicast datagram decoder
// (lib/can/python_can_codec.hpp), which every virtual-CAN frame from another
// process on the group goes through. Properties, besides "no crash, no
// sanitizer report": a bad datagram is a CanError, nothing else; a frame it
// accepts is a valid classic CAN frame that encodes and decodes to itself.
#include <cstddef>
#include <cstdint>
#include <cstdlib>

#include "can/python_can_codec.hpp"

namespace can = harvest::can;

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, std::size_t size) {
  can::CanFrame f;
  try {
    f = can::decode_python_can(data, size);
  } catch (const can::CanError&) {
    return 0;
  }
  if (f.dlc > 8) std::abort();
  if (!f.extended && f.id > 0x7FF) std::abort();
  if (f.extended && f.id > 0x1FFFFFFF) std::abort();
  const auto bytes = can::encode_python_can(f, 1.5);
  const can::CanFrame again = can::decode_python_can(bytes.data(), bytes.size());
  if (!(again == f)) std::abort();
  return 0;
}
