// libFuzzer target: the end-effector line-protocol parser (docs/end-effector-protocol.md).
//
// Properties checked on every input, besides "no crash, no sanitizer report":
//  * feeding the input in one piece or split at an input-chosen point gives
//    the same frames and the same counters (the parser is incremental);
//  * every delivered frame re-encodes to a line the parser accepts as the
//    same frame (what we accept, we can also say), within kMaxLine;
//  * garbage bytes never exceed the input length.
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <span>
#include <string>
#include <vector>

#include "endeffector/parser.hpp"
#include "endeffector/protocol.hpp"

namespace ee = harvest::endeffector;

namespace {

void check(bool ok) {
  if (!ok) std::abort();
}

bool same_counters(const ee::ParserCounters& a, const ee::ParserCounters& b) {
  return a.frames == b.frames && a.bad_checksum == b.bad_checksum && a.truncated == b.truncated &&
         a.garbage_bytes == b.garbage_bytes && a.oversize == b.oversize && a.unknown_version == b.unknown_version &&
         a.unknown_type == b.unknown_type && a.bad_fields == b.bad_fields;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, std::size_t size) {
  const std::span<const uint8_t> all(data, size);

  ee::Parser whole;
  std::vector<std::string> lines_whole;
  whole.feed(all, [&](const ee::Frame& f) { lines_whole.push_back(ee::encode(f)); });

  ee::Parser split;
  std::vector<std::string> lines_split;
  const std::size_t cut = size ? data[0] % (size + 1) : 0;
  const auto sink = [&](const ee::Frame& f) { lines_split.push_back(ee::encode(f)); };
  split.feed(all.first(cut), sink);
  split.feed(all.subspan(cut), sink);

  check(lines_whole == lines_split);
  check(same_counters(whole.counters(), split.counters()));
  check(whole.counters().frames == static_cast<int64_t>(lines_whole.size()));
  check(whole.counters().garbage_bytes <= static_cast<int64_t>(size));

  for (const std::string& line : lines_whole) {
    // The canonical encoding is never longer than the accepted line (no leading zeros, no '\r').
    check(line.size() <= ee::kMaxLine);
    ee::Parser again;
    const auto frames = again.feed(line);
    check(frames.size() == 1);
    check(ee::encode(frames[0]) == line);
    check(again.counters().errors() == 0);
  }

  whole.reset();  // must be safe in any state
  return 0;
}
