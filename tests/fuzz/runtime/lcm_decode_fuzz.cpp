// libFuzzer target: every harvest LCM type through rt::decode_checked, the
// path every subscription and log tool decodes by (lib/runtime/wire_check.hpp).
//
// The first byte picks the type; the fingerprint of that type is put in
// front of the rest, so mutations explore the message body instead of
// failing on the fingerprint. Besides "no crash, no sanitizer report, no
// allocation beyond libFuzzer's limits" (a count the check let through
// would allocate), on every input:
//  * what the check passes the lcm-gen decoder decodes without throwing or
//    refusing (decode_checked says "decoder ..." only for a gap in the check);
//  * a decoded message re-encodes to exactly the bytes it was decoded from.
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <vector>

#include "runtime/log_io.hpp"
#include "runtime/wire_check.hpp"

namespace rt = harvest::rt;

namespace {

int type_count() {
  int n = 0;
  rt::for_each_wire_type([&]<class T>(const char*) { ++n; });
  return n;
}

void check(bool ok) {
  if (!ok) std::abort();
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, std::size_t size) {
  static const int kTypes = type_count();
  if (size < 1) return 0;
  const int pick = data[0] % kTypes;
  int index = 0;
  rt::for_each_wire_type([&]<class T>(const char*) {
    if (index++ != pick) return;
    std::vector<uint8_t> bytes(8 + size - 1);
    const uint64_t hash = static_cast<uint64_t>(T::getHash());
    for (int i = 0; i < 8; ++i) bytes[static_cast<std::size_t>(i)] = static_cast<uint8_t>(hash >> (56 - 8 * i));
    std::copy(data + 1, data + size, bytes.begin() + 8);
    T m;
    const std::string why = rt::decode_checked(bytes.data(), bytes.size(), m);
    check(why.rfind("decoder", 0) != 0);  // the check let through what the decoder cannot take
    if (!why.empty()) return;
    const auto again = rt::encode(m);
    check(again.size() <= bytes.size());
    check(std::equal(again.begin(), again.end(), bytes.begin()));
  });
  return 0;
}
