// The wire check (runtime/wire_check.hpp, generated from lcmtypes/*.lcm):
// hand-built byte strings with the attacks of issue 16, every type's valid
// messages, every truncation, and random corruption never reaching a decoder
// that throws.
#include "runtime/wire_check.hpp"

#include <gtest/gtest.h>

#include <cstring>
#include <filesystem>
#include <harvest/emergency_stop_t.hpp>
#include <harvest/fruit_detections_t.hpp>
#include <harvest/harvest_status_t.hpp>
#include <harvest/image_t.hpp>
#include <harvest/process_status_t.hpp>
#include <harvest/robot_command_t.hpp>
#include <map>
#include <random>
#include <set>
#include <stdexcept>

#include "runtime/log_io.hpp"

using namespace harvest;

namespace {

// Big-endian LCM encoding by hand, so a test can write what no encoder would.
struct Bytes {
  std::vector<uint8_t> b;
  Bytes& i8(int8_t v) { return put(static_cast<uint8_t>(v), 1); }
  Bytes& i32(int64_t v) { return put(static_cast<uint64_t>(v), 4); }
  Bytes& i64(int64_t v) { return put(static_cast<uint64_t>(v), 8); }
  Bytes& f64(double v) {
    uint64_t u = 0;
    std::memcpy(&u, &v, 8);
    return put(u, 8);
  }
  Bytes& str(const std::string& s) {  // well-formed: length counts the NUL
    i32(static_cast<int64_t>(s.size()) + 1);
    b.insert(b.end(), s.begin(), s.end());
    b.push_back(0);
    return *this;
  }
  // auth_t of an unsigned command: empty sender, seq, utime, 32 MAC bytes.
  Bytes& auth() { return str("").i64(0).i64(0).raw(32); }
  Bytes& raw(std::size_t n, uint8_t v = 0) {
    b.insert(b.end(), n, v);
    return *this;
  }
  Bytes& put(uint64_t v, int n) {
    for (int i = n - 1; i >= 0; --i) b.push_back(static_cast<uint8_t>(v >> (8 * i)));
    return *this;
  }
  // header_t with frame_id written by the caller's function
  template <class F>
  Bytes& header(F frame_id) {
    i64(1'700'000'000'000'000).i64(7);
    frame_id(*this);
    return i64(-1).i64(1'700'000'000'000'000);
  }
  Bytes& header() {
    return header([](Bytes& x) { x.str("base"); });
  }
};

template <class T>
std::string check(const Bytes& x) {
  return rt::wire_check<T>(x.b.data(), x.b.size());
}

// The 58-byte packet of issue 16 that killed robot-link, servo-controller
// and ee-bridge at once: EMERGENCY_STOP whose header.frame_id length is 0.
Bytes estop_zero_frame_id() {
  Bytes x;
  x.i64(emergency_stop_t::getHash());
  x.header([](Bytes& h) { h.i32(0); });
  x.i8(1).i8(0).str("").str("ab");
  return x;
}

Bytes robot_command_with_count(int64_t num_joints, int data_doubles) {
  Bytes x;
  x.i64(robot_command_t::getHash()).header().i8(robot_command_t::TYPE_JOINT_GOAL).i64(200'000);
  x.raw(6 * 8).raw(7 * 8);  // twist, pose_goal
  x.i32(num_joints);
  for (int i = 0; i < data_doubles; ++i) x.f64(0.1);
  x.f64(0).f64(0).i64(1).auth();
  return x;
}

}  // namespace

TEST(WireCheck, ZeroLengthStringIsRejectedBeforeTheDecoderThrows) {
  const Bytes x = estop_zero_frame_id();
  EXPECT_EQ(x.b.size(), 58u);
  EXPECT_EQ(check<emergency_stop_t>(x), "header.frame_id: string length 0 (must be >= 1, it counts the NUL)");
  // What the guard stands in front of: the generated decoder throws on it.
  emergency_stop_t m;
  EXPECT_THROW(m.decode(x.b.data(), 0, static_cast<int>(x.b.size())), std::length_error);
  // decode_checked says why and leaves it at that.
  EXPECT_NE(rt::decode_checked(x.b.data(), x.b.size(), m).find("string length 0"), std::string::npos);
}

TEST(WireCheck, StringLengthsOutsideTheBufferAreRejected) {
  for (int64_t len : {-1LL, -2147483648LL, 1000LL, 2147483647LL}) {
    Bytes x;
    x.i64(emergency_stop_t::getHash()).header().i8(1).i8(0);
    x.i32(len).raw(3);
    x.str("r");
    const std::string why = check<emergency_stop_t>(x);
    EXPECT_NE(why.find("source: string length " + std::to_string(len)), std::string::npos) << len << ": " << why;
  }
}

TEST(WireCheck, StringsMustBeTextWithOneFinalNul) {
  auto with_source = [](const std::vector<uint8_t>& bytes) {
    Bytes x;
    x.i64(emergency_stop_t::getHash()).header().i8(1).i8(0);
    x.i32(static_cast<int64_t>(bytes.size()));
    x.b.insert(x.b.end(), bytes.begin(), bytes.end());
    x.str("r").auth();
    return check<emergency_stop_t>(x);
  };
  EXPECT_EQ(with_source({'o', 'p', 0}), "");
  EXPECT_EQ(with_source({'o', 'p', 'x'}), "source: string of 3 bytes does not end with a NUL");
  EXPECT_EQ(with_source({'o', 0, 'p', 0}), "source: string of 4 bytes has a NUL inside");
}

TEST(WireCheck, NegativeArrayCountIsRejected) {
  const Bytes x = robot_command_with_count(-1, 0);
  EXPECT_EQ(check<robot_command_t>(x), "joint_goal: array count -1 (negative)");
  robot_command_t m;
  EXPECT_THROW(m.decode(x.b.data(), 0, static_cast<int>(x.b.size())), std::length_error);
}

TEST(WireCheck, HugeArrayCountsAreRejectedWithoutAllocating) {
  // num_joints = 1e8 with no data: the decoder would resize to 800 MB first.
  EXPECT_NE(check<robot_command_t>(robot_command_with_count(100'000'000, 0)).find("joint_goal: array count 100000000"),
            std::string::npos);
  // One element more than the data: the array takes the next field's bytes, the message ends short.
  EXPECT_NE(check<robot_command_t>(robot_command_with_count(7, 6)), "");
  EXPECT_EQ(check<robot_command_t>(robot_command_with_count(6, 6)), "");

  // An image declaring size = 1e8 (100 MB) in a small datagram.
  Bytes img;
  img.i64(image_t::getHash()).header().i8(image_t::ENCODING_MONO8).i32(10).i32(10).i32(10);
  img.raw(16).i32(10).i32(10).i32(100'000'000).raw(100);
  EXPECT_NE(check<image_t>(img).find("data: array count 100000000"), std::string::npos);

  // A string array's count is bounded by 5 bytes per string, not 1.
  process_status_t ps{};
  ps.num_counters = 0;
  auto bytes = rt::encode(ps);
  // num_counters is the last int32 before the (empty) arrays: the last 4 bytes.
  bytes[bytes.size() - 4] = 0;
  bytes[bytes.size() - 3] = 0;
  bytes[bytes.size() - 2] = 0;
  bytes[bytes.size() - 1] = 2;
  bytes.insert(bytes.end(), {0, 0, 0, 1, 0, 0, 0});  // one empty string and 3 bytes: not room for a second
  EXPECT_NE(rt::wire_check<process_status_t>(bytes.data(), bytes.size()).find("counter_names: array of 2 elements"),
            std::string::npos)
      << rt::wire_check<process_status_t>(bytes.data(), bytes.size());
}

TEST(WireCheck, TruncatedAndMalformedNestedTypesNameTheField) {
  // The count passes the up-front bound (2 x the fewest bytes an outcome
  // takes) but the second outcome's detail runs past the end.
  harvest_status_t s{};
  s.num_outcomes = 2;
  s.outcomes.resize(2);
  s.outcomes[1].detail = std::string(30, 'x');
  auto bytes = rt::encode(s);
  EXPECT_EQ(rt::wire_check<harvest_status_t>(bytes.data(), bytes.size()), "");
  bytes.resize(bytes.size() - 20);
  EXPECT_EQ(rt::wire_check<harvest_status_t>(bytes.data(), bytes.size()),
            "outcomes[1].detail: string length 31, 11 bytes left");

  // Too many fruits for the bytes: refused before any element is walked.
  fruit_detections_t d{};
  d.num_fruits = 2;
  d.fruits.resize(2);
  bytes = rt::encode(d);
  bytes.resize(bytes.size() - 20);
  EXPECT_EQ(rt::wire_check<fruit_detections_t>(bytes.data(), bytes.size()),
            "fruits: array of 2 elements of >= 65 bytes, only 110 bytes left");

  // A zero string length inside an element of a nested array: the detail
  // string, last in the message, is [0 0 0 1][NUL]; its length set to 0.
  s.num_outcomes = 1;
  s.outcomes.resize(1);
  s.outcomes[0].detail = "";
  bytes = rt::encode(s);
  bytes[bytes.size() - 2] = 0;
  EXPECT_EQ(rt::wire_check<harvest_status_t>(bytes.data(), bytes.size()),
            "outcomes[0].detail: string length 0 (must be >= 1, it counts the NUL)");
  harvest_status_t raw;
  EXPECT_THROW(raw.decode(bytes.data(), 0, static_cast<int>(bytes.size())), std::length_error);
}

TEST(WireCheck, WrongFingerprintAndShortBuffersAreRejected) {
  emergency_stop_t e{};
  const auto bytes = rt::encode(e);
  EXPECT_EQ(rt::wire_check<robot_command_t>(bytes.data(), bytes.size()), "fingerprint is not robot_command_t");
  EXPECT_NE(rt::wire_check<emergency_stop_t>(bytes.data(), 5).find("shorter than a fingerprint"), std::string::npos);
  EXPECT_NE(rt::wire_check<emergency_stop_t>(nullptr, 0).find("shorter than a fingerprint"), std::string::npos);
}

// Every type: a default message passes, and every strict prefix of it fails.
TEST(WireCheck, EveryTypeDefaultMessagePassesAndEveryTruncationFails) {
  int types = 0;
  rt::for_each_wire_type([&]<class T>(const char* name) {
    ++types;
    T m{};
    const auto bytes = rt::encode(m);
    EXPECT_EQ(rt::wire_check<T>(bytes.data(), bytes.size()), "") << name;
    EXPECT_EQ(bytes.size(), 8 + rt::WireType<T>::kMinSize) << name << ": a default message is the smallest";
    for (std::size_t n = 0; n < bytes.size(); ++n)
      EXPECT_NE(rt::wire_check<T>(bytes.data(), n), "") << name << " cut to " << n << " bytes";
  });
  int lcm_files = 0;
  for (const auto& e : std::filesystem::directory_iterator("lcmtypes")) lcm_files += e.path().extension() == ".lcm";
  EXPECT_EQ(types, lcm_files) << "a type in lcmtypes/ has no wire check";
}

namespace {

// Every message of the reference logs, by type name.
std::map<std::string, std::vector<std::vector<uint8_t>>> logged_messages() {
  std::map<int64_t, std::string> names;
  rt::for_each_wire_type([&]<class T>(const char* name) { names[T::getHash()] = name; });
  std::map<std::string, std::vector<std::vector<uint8_t>>> out;
  for (const auto& e : std::filesystem::directory_iterator("logs")) {
    if (e.path().extension() != ".lcmlog") continue;
    for (auto& r : rt::read_log(e.path())) {
      if (r.data.size() < 8) continue;
      int64_t h = 0;
      for (int i = 0; i < 8; ++i) h = static_cast<int64_t>((static_cast<uint64_t>(h) << 8) | r.data[i]);
      auto it = names.find(h);
      if (it != names.end() && out[it->second].size() < 50) out[it->second].push_back(std::move(r.data));
    }
  }
  return out;
}

}  // namespace

// Every recorded message passes and decodes to the same bytes; no prefix
// passes; random corruption either fails the check or decodes cleanly.
TEST(WireCheck, RecordedMessagesPassAndCorruptionNeverReachesAThrowingDecoder) {
  const auto logged = logged_messages();
  std::set<std::string> covered;
  std::mt19937 rng(16);
  int64_t corrupted = 0, passed_corrupt = 0;
  rt::for_each_wire_type([&]<class T>(const char* name) {
    auto it = logged.find(name);
    if (it == logged.end()) return;
    covered.insert(name);
    for (const auto& bytes : it->second) {
      T m;
      ASSERT_EQ(rt::decode_checked(bytes.data(), bytes.size(), m), "") << name;
      EXPECT_EQ(rt::encode(m), bytes) << name;
      for (std::size_t n = bytes.size() > 400 ? bytes.size() - 400 : 0; n < bytes.size(); ++n)
        ASSERT_NE(rt::wire_check<T>(bytes.data(), n), "") << name << " cut to " << n;
      for (int k = 0; k < 40; ++k) {
        auto bad = bytes;
        const int flips = 1 + static_cast<int>(rng() % 4);
        for (int f = 0; f < flips; ++f) {
          // Mostly small values near the start, where lengths and counts are.
          const std::size_t at = rng() % std::min<std::size_t>(bad.size(), 200);
          bad[at] = static_cast<uint8_t>(rng() % 3 == 0 ? 0 : rng());
        }
        ++corrupted;
        if (!rt::wire_check<T>(bad.data(), bad.size()).empty()) continue;
        ++passed_corrupt;
        T d;
        int used = -1;
        EXPECT_NO_THROW(used = d.decode(bad.data(), 0, static_cast<int>(bad.size()))) << name;
        EXPECT_GE(used, 0) << name;
      }
    }
  });
  // The reference logs hold most types; the rest are covered by the default messages above.
  EXPECT_GE(covered.size(), 12u);
  EXPECT_GT(passed_corrupt, 0);
  EXPECT_LT(passed_corrupt, corrupted);
  std::string list;
  for (const auto& c : covered) list += c + " ";
  RecordProperty("types_from_logs", list);
}
