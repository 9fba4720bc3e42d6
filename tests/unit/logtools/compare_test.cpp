#include "logtools/compare.hpp"

#include <gtest/gtest.h>

#include <cmath>

#include "harvest/fruit_detections_t.hpp"
#include "harvest/targets_t.hpp"
#include "runtime/log_io.hpp"

namespace lt = harvest::logtools;
namespace rt = harvest::rt;

namespace {

harvest::fruit_detections_t detections(int64_t utime, float u, int64_t publish) {
  harvest::fruit_detections_t d{};
  d.header.utime = utime;
  d.header.seq = utime / 100;
  d.header.publish_utime = publish;
  d.camera = "fixed";
  d.num_fruits = 1;
  d.fruits.resize(1);
  d.fruits[0].id = 4;
  d.fruits[0].u_px = u;
  d.fruits[0].depth_m = 1.25f;
  return d;
}

rt::LogRecord rec(const std::string& channel, const harvest::fruit_detections_t& d) {
  return {d.header.publish_utime, channel, rt::encode(d)};
}

}  // namespace

TEST(Compare, IdenticalMessagesPassAndPublishTimeIsIgnored) {
  std::vector<rt::LogRecord> a = {rec("FRUIT_FIXED", detections(100, 10.f, 105)),
                                  rec("FRUIT_FIXED", detections(200, 11.f, 205))};
  std::vector<rt::LogRecord> b = {rec("FRUIT_FIXED", detections(100, 10.f, 999)),
                                  rec("FRUIT_FIXED", detections(200, 11.f, 1999))};
  lt::CompareOptions o;
  o.max_fields_per_message = 100;
  auto r = lt::compare_logs(a, b, {"FRUIT_FIXED"}, o);
  EXPECT_TRUE(r.ok) << lt::format_report(r, o);
  ASSERT_EQ(r.channels.size(), 1u);
  EXPECT_EQ(r.channels[0].identical, 2u);
  EXPECT_EQ(r.channels[0].type, "harvest.fruit_detections_t");
}

TEST(Compare, AChangedFieldIsReportedWithPathAndValues) {
  std::vector<rt::LogRecord> a = {rec("FRUIT_FIXED", detections(100, 10.f, 105)),
                                  rec("FRUIT_FIXED", detections(200, 11.f, 205))};
  std::vector<rt::LogRecord> b = {rec("FRUIT_FIXED", detections(100, 10.f, 105)),
                                  rec("FRUIT_FIXED", detections(200, 11.5f, 205))};
  lt::CompareOptions o;
  auto r = lt::compare_logs(a, b, {"FRUIT_FIXED"}, o);
  EXPECT_FALSE(r.ok);
  const auto& c = r.channels[0];
  EXPECT_EQ(c.differing, 1u);
  ASSERT_EQ(c.diffs.size(), 1u);
  EXPECT_EQ(c.diffs[0].recorded_index, 1u);
  ASSERT_EQ(c.diffs[0].fields.size(), 1u);
  EXPECT_EQ(c.diffs[0].fields[0].path, "fruits[0].u_px");
  EXPECT_EQ(c.diffs[0].fields[0].recorded, "11");
  EXPECT_EQ(c.diffs[0].fields[0].replayed, "11.5");
  const std::string text = lt::format_report(r, o);
  EXPECT_NE(text.find("DIFF FRUIT_FIXED"), std::string::npos) << text;
  EXPECT_NE(text.find("FRUIT_FIXED.fruits[0].u_px: recorded 11, replayed 11.5"), std::string::npos) << text;
}

TEST(Compare, TolerancesByChannelWildcardAndParentPath) {
  std::vector<rt::LogRecord> a = {rec("FRUIT_FIXED", detections(100, 10.f, 105))};
  std::vector<rt::LogRecord> b = {rec("FRUIT_FIXED", detections(100, 10.25f, 105))};
  for (const std::string spec : {"FRUIT_FIXED.fruits[].u_px=0.3", "*.fruits[].u_px=0.3", "FRUIT_FIXED.fruits[]=0.3"}) {
    lt::CompareOptions o;
    o.add_tolerance(spec);
    EXPECT_TRUE(lt::compare_logs(a, b, {"FRUIT_FIXED"}, o).ok) << spec;
  }
  lt::CompareOptions tight;
  tight.add_tolerance("FRUIT_FIXED.fruits[].u_px=0.2");
  EXPECT_FALSE(lt::compare_logs(a, b, {"FRUIT_FIXED"}, tight).ok);
  lt::CompareOptions other;
  other.add_tolerance("FRUIT_HAND.fruits[].u_px=1");
  EXPECT_FALSE(lt::compare_logs(a, b, {"FRUIT_FIXED"}, other).ok);
  lt::CompareOptions ignore;
  ignore.add_ignore("*.fruits[].u_px");
  EXPECT_TRUE(lt::compare_logs(a, b, {"FRUIT_FIXED"}, ignore).ok);
  EXPECT_THROW(tight.add_tolerance("u_px=1"), std::invalid_argument);
  EXPECT_THROW(tight.add_tolerance("FRUIT_FIXED.u_px=abc"), std::invalid_argument);
}

TEST(Compare, DefaultFloatToleranceIsSmallAndIntsAreExact) {
  std::vector<rt::LogRecord> a = {rec("FRUIT_FIXED", detections(100, 100.f, 105))};
  auto d = detections(100, std::nextafter(100.f, 200.f), 105);
  std::vector<rt::LogRecord> b = {rec("FRUIT_FIXED", d)};
  lt::CompareOptions o;
  EXPECT_TRUE(lt::compare_logs(a, b, {"FRUIT_FIXED"}, o).ok);
  d.fruits[0].id = 5;
  b = {rec("FRUIT_FIXED", d)};
  auto r = lt::compare_logs(a, b, {"FRUIT_FIXED"}, o);
  EXPECT_FALSE(r.ok);
  EXPECT_EQ(r.channels[0].diffs[0].fields[0].path, "fruits[0].id");
}

TEST(Compare, MessagesArePairedByUtimeAndUnpairedOnesFail) {
  // Replay lacks the first message (e.g. its input was not in the log) and
  // has an extra one at the end.
  std::vector<rt::LogRecord> a = {rec("FRUIT_FIXED", detections(100, 1.f, 105)),
                                  rec("FRUIT_FIXED", detections(200, 2.f, 205))};
  std::vector<rt::LogRecord> b = {rec("FRUIT_FIXED", detections(200, 2.f, 205)),
                                  rec("FRUIT_FIXED", detections(300, 3.f, 305))};
  lt::CompareOptions o;
  auto r = lt::compare_logs(a, b, {"FRUIT_FIXED"}, o);
  EXPECT_FALSE(r.ok);
  const auto& c = r.channels[0];
  EXPECT_EQ(c.identical, 1u);
  ASSERT_EQ(c.only_recorded.size(), 1u);
  EXPECT_EQ(c.only_recorded_utime[0], 100);
  ASSERT_EQ(c.only_replayed.size(), 1u);
  EXPECT_EQ(c.only_replayed_utime[0], 300);
  o.allow_unmatched = true;
  EXPECT_TRUE(lt::compare_logs(a, b, {"FRUIT_FIXED"}, o).ok);
}

TEST(Compare, ArraySizeChangesShowAbsentFields) {
  auto d1 = detections(100, 1.f, 105);
  auto d2 = d1;
  d2.num_fruits = 2;
  d2.fruits.push_back(d2.fruits[0]);
  std::vector<rt::LogRecord> a = {rec("FRUIT_FIXED", d1)}, b = {rec("FRUIT_FIXED", d2)};
  lt::CompareOptions o;
  o.max_fields_per_message = 100;
  auto r = lt::compare_logs(a, b, {"FRUIT_FIXED"}, o);
  ASSERT_FALSE(r.ok);
  bool absent = false;
  for (const auto& f : r.channels[0].diffs[0].fields)
    if (f.path == "fruits[1].u_px" && f.recorded == "(absent)") absent = true;
  EXPECT_TRUE(absent) << lt::format_report(r, o);
}
