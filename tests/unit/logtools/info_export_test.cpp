#include <gtest/gtest.h>

#include <sstream>

#include "harvest/fruit_detections_t.hpp"
#include "harvest/ir_range_t.hpp"
#include "logtools/export.hpp"
#include "logtools/log_info.hpp"
#include "runtime/log_io.hpp"

namespace lt = harvest::logtools;
namespace rt = harvest::rt;

namespace {

std::vector<rt::LogRecord> sample_log() {
  std::vector<rt::LogRecord> log;
  // IR_RANGE at 100 Hz for 1 s with a 0.5 s hole; FRUIT_FIXED 3 messages.
  for (int k = 0; k <= 100; ++k) {
    if (k > 40 && k < 90) continue;
    harvest::ir_range_t ir{};
    ir.header.utime = 1'000'000 + k * 10'000;
    ir.raw = k;
    ir.range_m = 0.01f * static_cast<float>(k);
    log.push_back({ir.header.utime, "IR_RANGE", rt::encode(ir)});
  }
  for (int k = 0; k < 3; ++k) {
    harvest::fruit_detections_t d{};
    d.header.utime = 1'000'000 + k * 100'000;
    d.camera = "fixed, \"quoted\"";
    d.num_fruits = k;
    d.fruits.resize(static_cast<std::size_t>(k));
    for (int j = 0; j < k; ++j) d.fruits[static_cast<std::size_t>(j)].u_px = static_cast<float>(10 * j + k);
    log.push_back({d.header.utime + 5, "FRUIT_FIXED", rt::encode(d)});
  }
  log.push_back({2'000'000, "JUNK", {1, 2, 3, 4, 5, 6, 7, 8, 9}});
  std::stable_sort(log.begin(), log.end(), [](const auto& a, const auto& b) { return a.timestamp < b.timestamp; });
  return log;
}

}  // namespace

TEST(LogInfo, ChannelsTypesCountsRatesAndGaps) {
  const auto info = lt::log_info(sample_log());
  EXPECT_EQ(info.events, 52 + 3 + 1);
  EXPECT_EQ(info.first, 1'000'000);
  EXPECT_EQ(info.last, 2'000'000);
  ASSERT_EQ(info.channels.size(), 3u);
  const auto& fruit = info.channels[0];
  EXPECT_EQ(fruit.channel, "FRUIT_FIXED");
  EXPECT_EQ(fruit.type, "harvest.fruit_detections_t");
  EXPECT_EQ(fruit.count, 3);
  EXPECT_NEAR(fruit.rate_hz, 10.0, 1e-9);
  const auto& ir = info.channels[1];
  EXPECT_EQ(ir.channel, "IR_RANGE");
  EXPECT_EQ(ir.count, 52);
  EXPECT_EQ(ir.median_interval, 10'000);
  ASSERT_EQ(ir.gaps.size(), 1u);
  EXPECT_EQ(ir.gaps[0].start, 1'400'000);
  EXPECT_EQ(ir.gaps[0].length, 500'000);
  EXPECT_EQ(info.channels[2].type.rfind("unknown 0x", 0), 0u);
  const std::string text = lt::format_info("x.lcmlog", info);
  EXPECT_NE(text.find("IR_RANGE"), std::string::npos);
  EXPECT_NE(text.find("0.500 s without a message"), std::string::npos) << text;
}

TEST(Export, CsvHasOneRowPerMessageAndTheUnionOfColumns) {
  std::ostringstream os;
  lt::ExportOptions o;
  EXPECT_EQ(lt::export_channel(sample_log(), "FRUIT_FIXED", o, os), 3);
  std::istringstream is(os.str());
  std::string header, row;
  std::getline(is, header);
  EXPECT_EQ(header.rfind("log_utime,header.utime,header.seq", 0), 0u) << header;
  EXPECT_NE(header.find("fruits[1].u_px"), std::string::npos);
  std::vector<std::string> rows;
  while (std::getline(is, row)) rows.push_back(row);
  ASSERT_EQ(rows.size(), 3u);
  EXPECT_EQ(rows[0].rfind("1000005,1000000,", 0), 0u) << rows[0];
  EXPECT_NE(rows[0].find("\"fixed, \"\"quoted\"\"\""), std::string::npos) << rows[0];
  EXPECT_NE(rows[2].find(",12,"), std::string::npos) << rows[2];  // fruits[1].u_px of message 2
}

TEST(Export, JsonLinesWithFieldSelection) {
  std::ostringstream os;
  lt::ExportOptions o;
  o.format = lt::ExportFormat::kJsonl;
  o.fields = {"header.utime", "range_m"};
  EXPECT_EQ(lt::export_channel(sample_log(), "IR_RANGE", o, os), 52);
  std::istringstream is(os.str());
  std::string line;
  std::getline(is, line);
  EXPECT_EQ(line, "{\"log_utime\":1000000,\"header.utime\":1000000,\"range_m\":0.0}");  // a float stays a float
  std::getline(is, line);
  EXPECT_EQ(line.rfind("{\"log_utime\":1010000,\"header.utime\":1010000,\"range_m\":0.00999999978", 0), 0u) << line;
  EXPECT_THROW(lt::export_channel(sample_log(), "NOPE", o, os), std::runtime_error);
}

TEST(Export, ACorruptEventIsReportedNeverDecoded) {
  // The 58-byte EMERGENCY_STOP of issue 16 (header.frame_id length 0) in a log.
  harvest::ir_range_t ir{};
  ir.header.frame_id = "x";
  auto bad = rt::encode(ir);
  bad[24] = bad[25] = bad[26] = bad[27] = 0;
  bad.erase(bad.begin() + 28, bad.begin() + 30);
  auto log = sample_log();
  log.push_back({3'000'000, "IR_RANGE", bad});
  std::ostringstream csv, problems;
  lt::ExportOptions o;
  o.problems = &problems;
  EXPECT_EQ(lt::export_channel(log, "IR_RANGE", o, csv), 53);
  EXPECT_NE(csv.str().find("\n3000000,,"), std::string::npos);
  EXPECT_EQ(problems.str(),
            "harvest-log: IR_RANGE event at log time 3000000 not decoded: malformed harvest.ir_range_t (53 bytes): "
            "header.frame_id: string length 0 (must be >= 1, it counts the NUL)\n");
  const auto info = lt::log_info(log);
  EXPECT_EQ(info.channels[1].decode_errors, 1);
  EXPECT_NE(lt::format_info("x.lcmlog", info).find("IR_RANGE: 1 malformed messages"), std::string::npos);
}
