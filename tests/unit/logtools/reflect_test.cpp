#include "logtools/reflect.hpp"

#include <gtest/gtest.h>

#include "harvest/fruit_detections_t.hpp"
#include "harvest/image_t.hpp"
#include "harvest/targets_t.hpp"
#include "runtime/log_io.hpp"

namespace lt = harvest::logtools;
namespace rt = harvest::rt;

TEST(Reflect, EveryTypeIsKnownByItsFingerprint) {
  const auto& types = lt::known_types();
  EXPECT_GE(types.size(), 20u);
  const auto* t = lt::type_by_name("fruit_detections_t");
  ASSERT_NE(t, nullptr);
  EXPECT_EQ(t->name, "harvest.fruit_detections_t");
  EXPECT_EQ(t->hash, harvest::fruit_detections_t::getHash());
  EXPECT_EQ(lt::type_by_hash(harvest::image_t::getHash())->name, "harvest.image_t");
}

TEST(Reflect, FlattensNestedArraysWithIndexedPaths) {
  harvest::fruit_detections_t d{};
  d.header.utime = 123;
  d.header.frame_id = "fixed";
  d.camera = "fixed";
  d.num_fruits = 2;
  d.fruits.resize(2);
  d.fruits[1].u_px = 12.5f;
  d.fruits[1].bbox_px[3] = 7;
  d.fruits[1].selected = true;
  const auto bytes = rt::encode(d);
  const auto dec = lt::decode_any(bytes.data(), bytes.size());
  ASSERT_NE(dec.type, nullptr) << dec.error;
  const auto* u = dec.fields.find("fruits[1].u_px");
  ASSERT_NE(u, nullptr);
  EXPECT_EQ(u->kind, lt::FieldKind::kFloat);
  EXPECT_DOUBLE_EQ(u->d, 12.5);
  ASSERT_NE(dec.fields.find("fruits[1].bbox_px[3]"), nullptr);
  EXPECT_EQ(dec.fields.find("fruits[1].bbox_px[3]")->i, 7);
  EXPECT_EQ(dec.fields.find("fruits[1].selected")->kind, lt::FieldKind::kBool);
  EXPECT_EQ(dec.fields.find("header.utime")->i, 123);
  EXPECT_EQ(dec.fields.find("camera")->s, "fixed");
  EXPECT_EQ(dec.fields.find("fruits[2].u_px"), nullptr);
  EXPECT_EQ(lt::generic_path("fruits[1].bbox_px[3]"), "fruits[].bbox_px[]");
}

TEST(Reflect, ByteArraysAreOneBlob) {
  harvest::image_t img{};
  img.size = 5;
  img.data = {1, 2, 3, 4, 5};
  const auto bytes = rt::encode(img);
  const auto dec = lt::decode_any(bytes.data(), bytes.size());
  ASSERT_NE(dec.type, nullptr);
  const auto* data = dec.fields.find("data");
  ASSERT_NE(data, nullptr);
  EXPECT_EQ(data->kind, lt::FieldKind::kBytes);
  EXPECT_EQ(data->s.size(), 5u);
  EXPECT_EQ(lt::value_text(*data), "<5 bytes>");
}

TEST(Reflect, UnknownAndTruncatedMessagesAreReportedNotDecoded) {
  std::vector<uint8_t> junk = {1, 2, 3, 4, 5, 6, 7, 8, 9};
  auto dec = lt::decode_any(junk.data(), junk.size());
  EXPECT_EQ(dec.type, nullptr);
  EXPECT_NE(dec.error.find("unknown type"), std::string::npos);

  harvest::targets_t t{};
  t.num_targets = 1;
  t.targets.resize(1);
  auto bytes = rt::encode(t);
  bytes.resize(bytes.size() - 3);
  dec = lt::decode_any(bytes.data(), bytes.size());
  EXPECT_EQ(dec.type, nullptr);
  EXPECT_NE(dec.error.find("malformed harvest.targets_t"), std::string::npos);
}
