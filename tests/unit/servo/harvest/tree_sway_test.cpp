#include "servo/harvest/tree_sway.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

namespace harvest::servo {
namespace {

target_t fruit(int id, double u, double v, double diameter_px = 20.0, double diameter_m = 0.07) {
  target_t t{};
  t.fruit_id = id;
  t.source_camera = "fixed";
  t.u_px = static_cast<float>(u);
  t.v_px = static_cast<float>(v);
  t.diameter_px = static_cast<float>(diameter_px);
  t.diameter_m = diameter_m;
  return t;
}

targets_t frame(double t_s, std::vector<target_t> targets, const char* camera = "fixed") {
  targets_t m{};
  m.header.utime = static_cast<int64_t>(std::llround(t_s * 1e6));
  m.source_camera = camera;
  m.targets = std::move(targets);
  m.num_targets = static_cast<int32_t>(m.targets.size());
  return m;
}

// One fruit whose centroid alternates between u = 100 and 102 px: 1 px rms about its mean, at 0.07 m / 20 px =
// 3.5 mm per px: 3.5 mm rms (hand-worked), below tree_still_rms (4 mm): still.
TEST(TreeSwayGauge, SpreadIsTheCentroidsRmsInMetresAtTheFruit) {
  ServoConfig::Sway p;
  p.tree_min_fruit = 1;
  TreeSwayGauge g(p);
  for (int i = 1; i <= 120; ++i) g.add(frame(i / 30.0, {fruit(7, i % 2 ? 102.0 : 100.0, 50.0)}));
  EXPECT_EQ(g.reading().fruit, 1);  // 120 views, 60 at each: exactly 1 px rms
  EXPECT_NEAR(g.reading().rms, 0.0035, 1e-9);
  EXPECT_EQ(g.reading().verdict, TreeSwayGauge::Verdict::kStill);
  // The same spread 8 mm apart (4 px at 3.5 mm): 7 mm rms, swaying.
  TreeSwayGauge h(p);
  for (int i = 1; i <= 120; ++i) h.add(frame(i / 30.0, {fruit(7, i % 2 ? 104.0 : 100.0, 50.0)}));
  EXPECT_NEAR(h.reading().rms, 0.007, 1e-9);
  EXPECT_EQ(h.reading().verdict, TreeSwayGauge::Verdict::kSwaying);
}

// Ten fruit of a still tree (0.2 px of noise), two of them behind the moving arm (their centroids jump 8 px):
// still, from the fruit at the quarter. In wind (every fruit 15 mm at 0.4 Hz along u, 0.07 m / 20 px): swaying,
// about 15 / sqrt(2) = 10.6 mm rms.
TEST(TreeSwayGauge, TheArmBeforeAFewFruitIsNotWindButWindMovesThemAll) {
  TreeSwayGauge still{ServoConfig::Sway{}}, windy{ServoConfig::Sway{}};
  for (int i = 0; i <= 150; ++i) {
    const double t = i / 30.0;
    std::vector<target_t> a, b;
    for (int f = 0; f < 10; ++f) {
      const double noise = 0.2 * std::sin(1.7 * i + f);
      const double arm = f < 2 && (i / 10) % 2 ? 8.0 : 0.0;
      a.push_back(fruit(f, 30.0 * f + noise + arm, 100.0));
      const double sway_px = 15.0 / 3.5 * std::sin(2 * std::numbers::pi * 0.4 * t + f);
      b.push_back(fruit(f, 30.0 * f + sway_px + noise, 100.0));
    }
    still.add(frame(t, a));
    windy.add(frame(t, b));
  }
  EXPECT_EQ(still.reading().fruit, 10);
  EXPECT_EQ(still.reading().verdict, TreeSwayGauge::Verdict::kStill);
  EXPECT_LT(still.reading().rms, 0.001);
  EXPECT_EQ(windy.reading().verdict, TreeSwayGauge::Verdict::kSwaying);
  EXPECT_NEAR(windy.reading().rms, 0.0106, 0.0015);
}

// Too few fruit, views spanning too little, another camera's targets, no size, or the gauge off: it cannot tell.
// A fruit not seen for a window is forgotten.
TEST(TreeSwayGauge, CannotTellFromTooLittle) {
  ServoConfig::Sway p;  // window 4 s, span 3 s, 3 fruit
  TreeSwayGauge g(p);
  auto three = [] { return std::vector<target_t>{fruit(1, 10, 10), fruit(2, 50, 10), fruit(3, 90, 10)}; };
  for (int i = 0; i < 80; ++i) g.add(frame(i / 30.0, three()));  // 2.6 s: too short a span
  EXPECT_EQ(g.reading().verdict, TreeSwayGauge::Verdict::kUnknown);
  for (int i = 80; i <= 100; ++i) g.add(frame(i / 30.0, three()));
  EXPECT_EQ(g.reading().verdict, TreeSwayGauge::Verdict::kStill);
  EXPECT_EQ(g.reading().fruit, 3);
  // Fruit 3 gone for good: after a window only two are counted.
  for (int i = 101; i <= 250; ++i) g.add(frame(i / 30.0, {fruit(1, 10, 10), fruit(2, 50, 10)}));
  EXPECT_EQ(g.reading().fruit, 2);
  EXPECT_EQ(g.reading().verdict, TreeSwayGauge::Verdict::kUnknown);

  TreeSwayGauge hand(p), sizeless(p);
  for (int i = 0; i <= 150; ++i) {
    hand.add(frame(i / 30.0, three(), "hand"));
    sizeless.add(frame(i / 30.0, {fruit(1, 10, 10, 0.0), fruit(2, 50, 10, 0.0), fruit(3, 90, 10, 0.0)}));
  }
  EXPECT_EQ(hand.reading().fruit, 0);
  EXPECT_EQ(sizeless.reading().fruit, 0);

  p.tree_window = 0.0;
  TreeSwayGauge off(p);
  for (int i = 0; i <= 150; ++i) off.add(frame(i / 30.0, three()));
  EXPECT_FALSE(off.enabled());
  EXPECT_EQ(off.reading().verdict, TreeSwayGauge::Verdict::kUnknown);
}

// The quantile picks the tree's fruit: spreads of 1, 2, 3 and 10 px (x 3.5 mm) at quantile 0.25 -> the first
// (floor(0.25 x 3) = 0), at 0.5 -> the second, at 1 -> the largest.
TEST(TreeSwayGauge, TheFruitAtTheQuantileStandsForTheTree) {
  for (const auto& [q, want] : {std::pair{0.25, 1.0}, std::pair{0.5, 2.0}, std::pair{1.0, 10.0}}) {
    ServoConfig::Sway p;
    p.tree_quantile = q;
    TreeSwayGauge g(p);
    for (int i = 1; i <= 120; ++i) {
      const double s = i % 2 ? 1.0 : -1.0;
      g.add(frame(i / 30.0, {fruit(1, 10 + s, 10), fruit(2, 50 + 2 * s, 10), fruit(3, 90 + 3 * s, 10),
                             fruit(4, 130 + 10 * s, 10)}));
    }
    EXPECT_NEAR(g.reading().rms, want * 0.0035, 1e-9) << "quantile " << q;
  }
}

// A flood of ids is not watched without bound: at most kMaxFruit ids are kept; old ones age out within a window.
TEST(TreeSwayGauge, AFloodOfIdsIsBounded) {
  TreeSwayGauge g{ServoConfig::Sway{}};
  for (int i = 0; i < 40; ++i) {
    std::vector<target_t> many;
    for (int f = 0; f < 100; ++f) many.push_back(fruit(i * 100 + f, f, 10));
    g.add(frame(i / 30.0, many));
  }
  EXPECT_EQ(g.tracked(), TreeSwayGauge::kMaxFruit);
  g.add(frame(10.0, {fruit(1, 10, 10)}));  // 8 s later: the flood has aged out
  EXPECT_EQ(g.tracked(), 1);
}

}  // namespace
}  // namespace harvest::servo
