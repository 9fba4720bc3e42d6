// Line protocol: encoding, CRC, every frame type and every error class.
#include "endeffector/protocol.hpp"

#include <gtest/gtest.h>

#include "endeffector/parser.hpp"

namespace ee = harvest::endeffector;

namespace {

ee::Frame roundtrip_one(const ee::Frame& in) {
  ee::Parser p;
  const auto out = p.feed(ee::encode(in));
  EXPECT_EQ(out.size(), 1u);
  EXPECT_EQ(p.counters().frames, 1);
  EXPECT_EQ(p.counters().errors(), 0);
  EXPECT_EQ(p.counters().garbage_bytes, 0);
  return out.empty() ? ee::Frame{} : out.front();
}

}  // namespace

TEST(EeCrc16, CcittFalseCheckValue) {
  // The catalogue check value of CRC-16/CCITT-FALSE.
  EXPECT_EQ(ee::crc16("123456789"), 0x29B1);
  EXPECT_EQ(ee::crc16(""), 0xFFFF);
}

TEST(EeEncode, ExactBytesOfAnIrFrame) {
  const std::string line = ee::encode({7, ee::IrSample{5300}});
  const std::string body = "1,7,IR,5300";
  char crc[5];
  std::snprintf(crc, sizeof crc, "%04X", ee::crc16(body));
  EXPECT_EQ(line, "$" + body + "*" + crc + "\n");
}

TEST(EeEncode, FreeTextCannotBreakFraming) {
  const std::string line = ee::encode({1, ee::Fault{3, "motor $stall,*\n"}});
  EXPECT_EQ(line.find('$', 1), std::string::npos);
  EXPECT_EQ(std::count(line.begin(), line.end(), '*'), 1);
  EXPECT_EQ(std::count(line.begin(), line.end(), '\n'), 1);
  const auto f = roundtrip_one({1, ee::Fault{3, "motor $stall,*\n"}});
  EXPECT_EQ(std::get<ee::Fault>(f.message).text, "motor _stall___");
}

TEST(EeParser, EveryFrameTypeRoundTrips) {
  EXPECT_EQ(std::get<ee::Ping>(roundtrip_one({1, ee::Ping{4000000000u}}).message).token, 4000000000u);
  EXPECT_TRUE(std::holds_alternative<ee::Open>(roundtrip_one({2, ee::Open{}}).message));
  EXPECT_EQ(std::get<ee::Close>(roundtrip_one({3, ee::Close{2500}}).message).force_mn, 2500);
  const auto mv = std::get<ee::Move>(roundtrip_one({4, ee::Move{350, 1200}}).message);
  EXPECT_EQ(mv.position_permille, 350);
  EXPECT_EQ(mv.force_mn, 1200);
  EXPECT_TRUE(std::holds_alternative<ee::Stop>(roundtrip_one({5, ee::Stop{}}).message));
  const auto ir = roundtrip_one({65535, ee::IrSample{5300}});
  EXPECT_EQ(ir.seq, 65535);
  EXPECT_EQ(std::get<ee::IrSample>(ir.message).raw, 5300);
  const auto g = std::get<ee::Grip>(roundtrip_one({6, ee::Grip{ee::GripState::kHolding, 120, 8000}}).message);
  EXPECT_EQ(g.state, ee::GripState::kHolding);
  EXPECT_EQ(g.position_permille, 120);
  EXPECT_EQ(g.force_mn, 8000);
  const auto fa = std::get<ee::Fault>(roundtrip_one({7, ee::Fault{12, "overcurrent"}}).message);
  EXPECT_EQ(fa.code, 12);
  EXPECT_EQ(fa.text, "overcurrent");
  const auto po = std::get<ee::Pong>(roundtrip_one({8, ee::Pong{99, 1, "eeboard-2.3"}}).message);
  EXPECT_EQ(po.token, 99u);
  EXPECT_EQ(po.version, 1);
  EXPECT_EQ(po.firmware, "eeboard-2.3");
  const auto ack = std::get<ee::Ack>(roundtrip_one({9, ee::Ack{4, -2}}).message);
  EXPECT_EQ(ack.command_seq, 4);
  EXPECT_EQ(ack.status, -2);
}

TEST(EeParser, ByteAtATimeGivesTheSameFrames) {
  std::string stream;
  for (int i = 0; i < 20; ++i) stream += ee::encode({static_cast<uint16_t>(i), ee::IrSample{1000 + i}});
  ee::Parser p;
  int n = 0;
  for (const char c : stream) {
    const uint8_t b = static_cast<uint8_t>(c);
    p.feed(std::span(&b, 1), [&](const ee::Frame& f) {
      EXPECT_EQ(f.seq, n);
      EXPECT_EQ(std::get<ee::IrSample>(f.message).raw, 1000 + n);
      ++n;
    });
  }
  EXPECT_EQ(n, 20);
}

TEST(EeParser, CrLfTerminatorAccepted) {
  std::string line = ee::encode({1, ee::Open{}});
  line.pop_back();
  line += "\r\n";
  ee::Parser p;
  EXPECT_EQ(p.feed(line).size(), 1u);
}

TEST(EeParser, BadChecksumCountedAndNextFrameKept) {
  std::string bad = ee::encode({1, ee::IrSample{5300}});
  bad[8] = '4';  // one payload digit flipped: 5300 -> 5400
  ee::Parser p;
  const auto out = p.feed(bad + ee::encode({2, ee::IrSample{5301}}));
  ASSERT_EQ(out.size(), 1u);
  EXPECT_EQ(out[0].seq, 2);
  EXPECT_EQ(p.counters().bad_checksum, 1);
  EXPECT_EQ(p.counters().errors(), 1);
}

TEST(EeParser, TruncatedFrameCountedWhenANewFrameStarts) {
  const std::string full = ee::encode({1, ee::IrSample{5300}});
  ee::Parser p;
  const auto out = p.feed(full.substr(0, 7) + ee::encode({2, ee::IrSample{42}}));
  ASSERT_EQ(out.size(), 1u);
  EXPECT_EQ(std::get<ee::IrSample>(out[0].message).raw, 42);
  EXPECT_EQ(p.counters().truncated, 1);
  EXPECT_EQ(p.counters().errors(), 1);
}

TEST(EeParser, LineWithoutCrcTailIsTruncated) {
  ee::Parser p;
  EXPECT_TRUE(p.feed("$1,3,OPEN\n").empty());
  EXPECT_TRUE(p.feed("$1,3,OPEN*12\n").empty());
  EXPECT_EQ(p.counters().truncated, 2);
}

TEST(EeParser, ResetMidFrameCountsTruncatedAndResynchronises) {
  const std::string full = ee::encode({1, ee::IrSample{5300}});
  ee::Parser p;
  EXPECT_TRUE(p.feed(full.substr(0, 9)).empty());
  p.reset();
  EXPECT_EQ(p.counters().truncated, 1);
  // The rest of the old frame is now garbage; the next frame is parsed.
  const auto out = p.feed(full.substr(9) + full);
  EXPECT_EQ(out.size(), 1u);
  EXPECT_EQ(p.counters().garbage_bytes, static_cast<int64_t>(full.size() - 9));
  p.reset();  // between frames: nothing lost, nothing counted
  EXPECT_EQ(p.counters().truncated, 1);
}

TEST(EeParser, GarbageBetweenFramesCountedByteForByte) {
  const std::string noise = "\x01\xff hello\r\n\x80";
  ee::Parser p;
  const auto out = p.feed(noise + ee::encode({1, ee::Open{}}) + noise + ee::encode({2, ee::Stop{}}));
  EXPECT_EQ(out.size(), 2u);
  EXPECT_EQ(p.counters().garbage_bytes, static_cast<int64_t>(2 * noise.size()));
  EXPECT_EQ(p.counters().errors(), 0);
}

TEST(EeParser, OversizeLineDroppedOnceAndNextFrameKept) {
  ee::Parser p;
  const std::string longline = "$1,1,FAULT,1," + std::string(300, 'x') + "*0000\n";
  const auto out = p.feed(longline + ee::encode({2, ee::IrSample{7}}));
  ASSERT_EQ(out.size(), 1u);
  EXPECT_EQ(out[0].seq, 2);
  EXPECT_EQ(p.counters().oversize, 1);
  EXPECT_EQ(p.counters().garbage_bytes, 0);
  EXPECT_EQ(p.counters().errors(), 1);
}

TEST(EeParser, LineOfExactlyMaxLengthIsNotOversize) {
  // An intact line of exactly kMaxLine bytes reaches decoding (here: unknown type); one byte more is oversize.
  const std::string base = ee::encode_raw(1, "1,LONG,");
  const std::size_t pad = ee::kMaxLine - base.size();
  const std::string exact = ee::encode_raw(1, "1,LONG," + std::string(pad, 'v'));
  ASSERT_EQ(exact.size(), ee::kMaxLine);
  ee::Parser p;
  EXPECT_TRUE(p.feed(exact).empty());
  EXPECT_EQ(p.counters().unknown_type, 1);
  EXPECT_EQ(p.counters().oversize, 0);
  const std::string over = ee::encode_raw(1, "1,LONG," + std::string(pad + 1, 'v'));
  ASSERT_EQ(over.size(), ee::kMaxLine + 1);
  EXPECT_TRUE(p.feed(over).empty());
  EXPECT_EQ(p.counters().oversize, 1);
  EXPECT_EQ(p.counters().unknown_type, 1);
}

TEST(EeParser, UnknownVersionCounted) {
  ee::Parser p;
  EXPECT_TRUE(p.feed(ee::encode_raw(2, "1,IR,5300")).empty());
  EXPECT_EQ(p.counters().unknown_version, 1);
  EXPECT_EQ(p.counters().errors(), 1);
}

TEST(EeParser, UnknownTypeCounted) {
  ee::Parser p;
  EXPECT_TRUE(p.feed(ee::encode_raw(1, "1,TEMP,25")).empty());
  EXPECT_EQ(p.counters().unknown_type, 1);
  EXPECT_EQ(p.counters().errors(), 1);
}

TEST(EeParser, BadFieldsCounted) {
  ee::Parser p;
  for (const char* payload : {"1,IR", "1,IR,abc", "1,IR,-5", "1,IR,70000", "1,IR,5,6", "1,MOVE,1001,0", "1,GRIP,9,0,0",
                              "1,OPEN,1", "x,IR,5", "1", "1,FAULT,1,a;b"}) {
    EXPECT_TRUE(p.feed(ee::encode_raw(1, payload)).empty()) << payload;
  }
  EXPECT_EQ(p.counters().bad_fields, 11);
  EXPECT_EQ(p.counters().frames, 0);
}

TEST(EeParser, MixedStreamEveryErrorCountedOnceAndEveryGoodFrameKeptInOrder) {
  std::string bad_crc = ee::encode({11, ee::IrSample{5300}});
  bad_crc[bad_crc.size() - 2] = bad_crc[bad_crc.size() - 2] == '0' ? '1' : '0';  // last CRC digit
  const std::string good1 = ee::encode({1, ee::IrSample{100}});
  const std::string good2 = ee::encode({2, ee::Grip{ee::GripState::kClosing, 500, 0}});
  const std::string good3 = ee::encode({3, ee::Ack{7, 0}});
  const std::string good4 = ee::encode({4, ee::Pong{1, 1, "fw"}});
  const std::string stream = "zz" + good1 + bad_crc + good2.substr(0, 6) /* truncated */ + good2 +
                             ee::encode_raw(3, "5,IR,1") /* unknown version */ + good3 + "$1,6," +
                             std::string(200, 'A') + "\n" /* oversize */ + ee::encode_raw(1, "7,HUM,40") +
                             ee::encode_raw(1, "8,IR,x") + "q" + good4;
  ee::Parser p;
  const auto out = p.feed(stream);
  ASSERT_EQ(out.size(), 4u);
  for (std::size_t i = 0; i < out.size(); ++i) EXPECT_EQ(out[i].seq, i + 1);
  EXPECT_EQ(std::get<ee::IrSample>(out[0].message).raw, 100);
  EXPECT_EQ(std::get<ee::Grip>(out[1].message).state, ee::GripState::kClosing);
  EXPECT_EQ(std::get<ee::Ack>(out[2].message).command_seq, 7);
  EXPECT_EQ(std::get<ee::Pong>(out[3].message).firmware, "fw");
  const auto& c = p.counters();
  EXPECT_EQ(c.frames, 4);
  EXPECT_EQ(c.garbage_bytes, 3);  // "zz" and "q"
  EXPECT_EQ(c.bad_checksum, 1);
  EXPECT_EQ(c.truncated, 1);
  EXPECT_EQ(c.unknown_version, 1);
  EXPECT_EQ(c.oversize, 1);
  EXPECT_EQ(c.unknown_type, 1);
  EXPECT_EQ(c.bad_fields, 1);
  EXPECT_EQ(c.errors(), 6);
  EXPECT_FALSE(p.last_error().empty());
}
