#include "endeffector/parser.hpp"

#include <charconv>
#include <optional>

namespace harvest::endeffector {

namespace {

std::vector<std::string_view> split(std::string_view s) {
  std::vector<std::string_view> out;
  std::size_t start = 0;
  while (true) {
    const std::size_t comma = s.find(',', start);
    out.push_back(s.substr(start, comma == std::string_view::npos ? std::string_view::npos : comma - start));
    if (comma == std::string_view::npos) return out;
    start = comma + 1;
  }
}

// Strict decimal integer in [lo, hi]: the whole token, no sign for unsigned ranges, no spaces.
template <class T>
std::optional<T> to_int(std::string_view s, int64_t lo, int64_t hi) {
  int64_t v = 0;
  if (s.empty()) return std::nullopt;
  const auto [end, ec] = std::from_chars(s.data(), s.data() + s.size(), v);
  if (ec != std::errc() || end != s.data() + s.size() || v < lo || v > hi) return std::nullopt;
  return static_cast<T>(v);
}

std::optional<uint16_t> hex4(std::string_view s) {
  if (s.size() != 4) return std::nullopt;
  uint16_t v = 0;
  for (const char c : s) {
    int d;
    if (c >= '0' && c <= '9') d = c - '0';
    else if (c >= 'A' && c <= 'F') d = c - 'A' + 10;
    else return std::nullopt;
    v = static_cast<uint16_t>(v * 16 + d);
  }
  return v;
}

bool text_ok(std::string_view s) { return s.size() <= kMaxFaultText && sanitize_text(s) == s; }

constexpr int64_t kMaxForceMn = 1'000'000;  // 1 kN: far beyond any gripper, catches corrupted values
constexpr int64_t kMaxRaw = 65535;          // 16-bit ADC

// Fields after the type tag -> message; nullopt if they do not fit the type.
// `known` reports whether the tag itself is known.
std::optional<Message> decode_fields(std::string_view tag, const std::vector<std::string_view>& f, bool& known) {
  known = true;
  const std::size_t n = f.size();
  if (tag == "PING") {
    if (n != 1) return std::nullopt;
    if (auto t = to_int<uint32_t>(f[0], 0, UINT32_MAX)) return Ping{*t};
  } else if (tag == "OPEN") {
    if (n == 0) return Open{};
  } else if (tag == "STOP") {
    if (n == 0) return Stop{};
  } else if (tag == "CLOSE") {
    if (n != 1) return std::nullopt;
    if (auto force = to_int<int32_t>(f[0], 0, kMaxForceMn)) return Close{*force};
  } else if (tag == "MOVE") {
    if (n != 2) return std::nullopt;
    auto pos = to_int<int32_t>(f[0], 0, 1000);
    auto force = to_int<int32_t>(f[1], 0, kMaxForceMn);
    if (pos && force) return Move{*pos, *force};
  } else if (tag == "IR") {
    if (n != 1) return std::nullopt;
    if (auto raw = to_int<int32_t>(f[0], 0, kMaxRaw)) return IrSample{*raw};
  } else if (tag == "GRIP") {
    if (n != 3) return std::nullopt;
    auto state = to_int<int>(f[0], 0, kGripStateMax);
    auto pos = to_int<int32_t>(f[1], 0, 1000);
    auto force = to_int<int32_t>(f[2], 0, kMaxForceMn);
    if (state && pos && force) return Grip{static_cast<GripState>(*state), *pos, *force};
  } else if (tag == "FAULT") {
    if (n != 2 || !text_ok(f[1])) return std::nullopt;
    if (auto code = to_int<int32_t>(f[0], 0, INT32_MAX)) return Fault{*code, std::string(f[1])};
  } else if (tag == "PONG") {
    if (n != 3 || !text_ok(f[2])) return std::nullopt;
    auto token = to_int<uint32_t>(f[0], 0, UINT32_MAX);
    auto version = to_int<int32_t>(f[1], 0, 255);
    if (token && version) return Pong{*token, *version, std::string(f[2])};
  } else if (tag == "ACK") {
    if (n != 2) return std::nullopt;
    auto seq = to_int<uint16_t>(f[0], 0, 65535);
    auto status = to_int<int32_t>(f[1], INT32_MIN, INT32_MAX);
    if (seq && status) return Ack{*seq, *status};
  } else {
    known = false;
  }
  return std::nullopt;
}

}  // namespace

void Parser::reject(int64_t& counter, std::string why) {
  ++counter;
  last_error_ = std::move(why);
}

void Parser::reset() {
  if (state_ == State::kInFrame) reject(counters_.truncated, "stream interrupted mid-frame");
  state_ = State::kHunting;
  line_.clear();
}

void Parser::feed(std::span<const uint8_t> bytes, const Sink& sink) {
  for (const uint8_t b : bytes) {
    const char c = static_cast<char>(b);
    switch (state_) {
      case State::kHunting:
        if (c == '$') {
          state_ = State::kInFrame;
          line_.clear();
        } else {
          ++counters_.garbage_bytes;
        }
        break;
      case State::kInFrame:
        if (c == '$') {  // a new frame started before this one ended
          reject(counters_.truncated, "frame interrupted by a new '$'");
          line_.clear();
        } else if (c == '\n') {
          finish_line(sink);
          state_ = State::kHunting;
        } else if (line_.size() + 2 >= kMaxLine) {  // '$' + line + this byte would pass the limit with '\n'
          reject(counters_.oversize, "line longer than " + std::to_string(kMaxLine) + " bytes");
          state_ = State::kDiscarding;
        } else {
          line_.push_back(c);
        }
        break;
      case State::kDiscarding:
        if (c == '\n') {
          state_ = State::kHunting;
        } else if (c == '$') {
          state_ = State::kInFrame;
          line_.clear();
        }
        break;
    }
  }
}

std::vector<Frame> Parser::feed(std::string_view bytes) {
  std::vector<Frame> out;
  feed(std::span(reinterpret_cast<const uint8_t*>(bytes.data()), bytes.size()),
       [&out](const Frame& f) { out.push_back(f); });
  return out;
}

void Parser::finish_line(const Sink& sink) {
  std::string_view line = line_;
  if (!line.empty() && line.back() == '\r') line.remove_suffix(1);  // tolerate CRLF senders
  const std::size_t star = line.rfind('*');
  if (star == std::string_view::npos || line.size() - star != 5) {
    reject(counters_.truncated, "no '*CRC' tail");
    return;
  }
  const auto crc = hex4(line.substr(star + 1));
  if (!crc) {
    reject(counters_.truncated, "CRC tail is not 4 hex digits");
    return;
  }
  const std::string_view body = line.substr(0, star);
  if (crc16(body) != *crc) {
    reject(counters_.bad_checksum, "CRC mismatch");
    return;
  }
  const auto fields = split(body);
  if (fields.size() < 3) {
    reject(counters_.bad_fields, "fewer than version, seq and type");
    return;
  }
  const auto version = to_int<int>(fields[0], 0, 255);
  if (!version) {
    reject(counters_.bad_fields, "version is not a number");
    return;
  }
  if (*version != kProtocolVersion) {
    reject(counters_.unknown_version, "protocol version " + std::to_string(*version));
    return;
  }
  const auto seq = to_int<uint16_t>(fields[1], 0, 65535);
  if (!seq) {
    reject(counters_.bad_fields, "bad sequence number");
    return;
  }
  bool known = false;
  const std::vector<std::string_view> rest(fields.begin() + 3, fields.end());
  auto msg = decode_fields(fields[2], rest, known);
  if (!known) {
    reject(counters_.unknown_type, "unknown type '" + sanitize_text(fields[2]) + "'");
    return;
  }
  if (!msg) {
    reject(counters_.bad_fields, "bad fields for " + std::string(fields[2]));
    return;
  }
  ++counters_.frames;
  sink(Frame{*seq, std::move(*msg)});
}

}  // namespace harvest::endeffector
