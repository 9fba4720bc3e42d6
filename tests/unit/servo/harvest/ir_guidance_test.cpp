#include "servo/harvest/ir_guidance.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <functional>

namespace harvest::servo {
namespace {

// The tool at the origin, its axis along +z; the fruit's estimated centre
// `ahead` metres along it. Default gains: grasp range 15 mm, braking
// 0.8 m/s^2, speeds 0.04..0.381 m/s, IR stale after 0.3 s.
const Eigen::Isometry3d kTool = Eigen::Isometry3d::Identity();
constexpr rt::Micros kT = 10'000'000;

Fruit fruit(double ahead, Fruit::Depth depth = Fruit::Depth::kSize) {
  Fruit f;
  f.estimate = Eigen::Vector3d(0.0, 0.0, ahead);
  f.depth = depth;
  return f;
}

ir_range_t reading(double range, int8_t validity = ir_range_t::VALID) {
  ir_range_t m{};
  m.validity = validity;
  m.range_m = static_cast<float>(range);
  return m;
}

Eigen::Isometry3d tool_at(double z) {
  Eigen::Isometry3d t = kTool;
  t.translation().z() = z;
  return t;
}

IrGuidance guiding(rt::Micros now = kT) {
  IrGuidance g{ServoConfig{}};
  g.begin(kTool.translation(), now);
  return g;
}

// Hand-worked: v = sqrt(2 a d) clamped to [0.04, 0.381] m/s.
TEST(IrGuidance, ForwardSpeedBrakesAtAConstantRateToTheGraspRange) {
  IrGuidance g = guiding();
  EXPECT_NEAR(g.forward_speed(kTool, fruit(0.1), false), 0.381, 1e-12);  // sqrt(0.16) = 0.4, capped
  EXPECT_NEAR(g.forward_speed(kTool, fruit(0.02), false), std::sqrt(2 * 0.8 * 0.02), 1e-12);
  EXPECT_NEAR(g.forward_speed(kTool, fruit(0.0005), false), 0.04, 1e-12);  // never below the minimum
  // The IR range, if shorter, is the range to go: 35 mm read, 15 mm grasp range: 20 mm.
  g.on_reading(reading(0.035), kT, true);
  EXPECT_NEAR(g.forward_speed(kTool, fruit(0.1), true), std::sqrt(2 * 0.8 * 0.02), 1e-6);
  // ... but a far reading (the fold-back) never speeds the arm up beyond the estimate's.
  g.on_reading(reading(0.3), kT, true);
  EXPECT_NEAR(g.forward_speed(kTool, fruit(0.02), true), std::sqrt(2 * 0.8 * 0.02), 1e-12);
}

TEST(IrGuidance, AdvancesAtTheBrakingSpeedAndClosesAtTheGraspRange) {
  IrGuidance g = guiding();
  g.on_reading(reading(0.035), kT, true);
  IrStep s = g.step(kT, kTool, fruit(0.06), std::nullopt);
  EXPECT_EQ(s.action, IrStep::Action::kAdvance);
  EXPECT_NEAR(s.forward_speed, std::sqrt(2 * 0.8 * 0.02), 1e-6);
  g.on_reading(reading(0.015), kT, true);
  EXPECT_EQ(g.step(kT, kTool, fruit(0.04), std::nullopt).action, IrStep::Action::kClose);
  g.on_reading(reading(0.0, ir_range_t::TOO_NEAR), kT, true);
  EXPECT_EQ(g.step(kT, kTool, fruit(0.04), std::nullopt).action, IrStep::Action::kClose);
}

TEST(IrGuidance, NeverAdvancesOnAStaleReading) {
  IrGuidance g = guiding();
  EXPECT_EQ(g.step(kT, kTool, fruit(0.1), std::nullopt).action, IrStep::Action::kHold);  // none yet
  g.on_reading(reading(0.1), kT, true);
  EXPECT_EQ(g.step(kT + rt::from_seconds(0.3), kTool, fruit(0.1), std::nullopt).action, IrStep::Action::kAdvance);
  EXPECT_EQ(g.step(kT + rt::from_seconds(0.31), kTool, fruit(0.1), std::nullopt).action, IrStep::Action::kHold);
}

// The sensor folds back nearer than its peak: 30 mm (within 20 mm above the
// grasp range) then 300 mm (more than 30 mm farther) is the fruit inside.
TEST(IrGuidance, AFoldBackJumpIsTheFruitInsideTheGraspRange) {
  IrGuidance g = guiding();
  g.on_reading(reading(0.030), kT, true);
  g.on_reading(reading(0.300), kT, true);
  EXPECT_EQ(g.step(kT, kTool, fruit(0.02), std::nullopt).action, IrStep::Action::kClose);
  // Not from readings taken outside IR guidance, nor from one not near enough first.
  IrGuidance before = guiding();
  before.on_reading(reading(0.030), kT, false);
  before.on_reading(reading(0.300), kT, true);
  EXPECT_EQ(before.step(kT, kTool, fruit(0.02), std::nullopt).action, IrStep::Action::kAdvance);
  IrGuidance far = guiding();
  far.on_reading(reading(0.036), kT, true);
  far.on_reading(reading(0.300), kT, true);
  EXPECT_EQ(far.step(kT, kTool, fruit(0.02), std::nullopt).action, IrStep::Action::kAdvance);
  // A new attempt forgets it.
  g.retry(kTool.translation(), kT);
  g.on_reading(reading(0.300), kT, true);
  EXPECT_EQ(g.step(kT, kTool, fruit(0.02), std::nullopt).action, IrStep::Action::kAdvance);
}

// A grasp reading with the checked estimate 20 cm ahead (more than 7 cm) is a
// leaf: noted once, passed. A depth from the size alone never overrules the IR,
// nor does a size near the fruit that set a disagreeing crossing aside.
TEST(IrGuidance, ALeafInFrontOfACheckedEstimateIsPassedOnce) {
  IrGuidance g = guiding();
  g.on_reading(reading(0.010), kT, true);
  IrStep s = g.step(kT, kTool, fruit(0.2, Fruit::Depth::kConfirmed), std::nullopt);
  EXPECT_EQ(s.action, IrStep::Action::kAdvance);
  ASSERT_TRUE(s.note.has_value());
  EXPECT_EQ(*s.note, "IR at 10 mm, fruit 200 mm ahead: past a leaf");
  // Braking by the leaf's distance, sqrt(2 x 0.8 x 0.010), not the estimate's (0.381): the "leaf" may be the fruit.
  EXPECT_NEAR(s.forward_speed, std::sqrt(2.0 * 0.8 * 0.010), 1e-6);
  s = g.step(kT, kTool, fruit(0.2, Fruit::Depth::kCrossing), std::nullopt);
  EXPECT_EQ(s.action, IrStep::Action::kAdvance);
  EXPECT_FALSE(s.note.has_value());
  // Short of where the leaf was, a grasp reading is the leaf whatever the estimate says by then.
  EXPECT_EQ(g.step(kT, tool_at(0.005), fruit(0.04, Fruit::Depth::kConfirmed), std::nullopt).action,
            IrStep::Action::kAdvance);
  EXPECT_EQ(g.step(kT, tool_at(0.011), fruit(0.04, Fruit::Depth::kConfirmed), std::nullopt).action,
            IrStep::Action::kClose);  // past it, 4 cm ahead (<= 5 cm): the fruit
  // An estimate just over the limit, then under it: still the leaf until the sensor has passed it (it closed 20 ms
  // after "past a leaf" with the fruit out of the fingers' reach).
  IrGuidance edge = guiding();
  edge.on_reading(reading(0.010), kT, true);
  EXPECT_EQ(edge.step(kT, kTool, fruit(0.051, Fruit::Depth::kConfirmed), std::nullopt).action,
            IrStep::Action::kAdvance);
  EXPECT_EQ(edge.step(kT, tool_at(0.002), fruit(0.049, Fruit::Depth::kConfirmed), std::nullopt).action,
            IrStep::Action::kAdvance);
  IrGuidance size_only = guiding();
  size_only.on_reading(reading(0.010), kT, true);
  EXPECT_EQ(size_only.step(kT, kTool, fruit(0.2, Fruit::Depth::kSize), std::nullopt).action, IrStep::Action::kClose);
  // Nor a size near the fruit that set a disagreeing crossing aside (a leaf-cut fruit may look too far there too).
  IrGuidance near = guiding();
  near.on_reading(reading(0.010), kT, true);
  EXPECT_EQ(near.step(kT, kTool, fruit(0.2, Fruit::Depth::kNear), std::nullopt).action, IrStep::Action::kClose);
}

// Leaf or fruit (ir_split_close 7.5 cm, ir_split_max 3 cm, the shipped grasp range 35 mm): a grasp reading of 33 mm
// puts a fruit's centre 33 + 35 (half the 70 mm diameter) - 50 (the palm behind the tool point) = 18 mm ahead of the
// tool point, the checked estimate 70 mm: the arm goes on half the 52 mm between them, 26 mm, at the slowest speed
// (the reading is at the grasp range), whatever the IR reads meanwhile (folded back, far), then closes. No farther
// than ir_split_max (2 cm by default). Beyond the limit the reading is a leaf as before, within the agreement the
// fruit; not from a depth the crossing did not check, nor with a nearer fruit filling the view, nor with the key off.
TEST(IrGuidance, LeafOrFruitGoesOnHalfTheGapThenCloses) {
  ServoConfig cfg;
  cfg.ir_grasp_range = 0.035;
  cfg.ir_split_close = 0.075;
  cfg.ir_split_max = 0.03;
  const auto start = [&cfg](double range) {
    IrGuidance g(cfg);
    g.begin(kTool.translation(), kT);
    g.on_reading(reading(range), kT, true);
    return g;
  };
  IrGuidance g = start(0.033);
  IrStep s = g.step(kT, kTool, fruit(0.07, Fruit::Depth::kConfirmed), std::nullopt);
  EXPECT_EQ(s.action, IrStep::Action::kAdvance);
  EXPECT_NEAR(s.forward_speed, 0.04, 1e-12);
  ASSERT_TRUE(s.note.has_value());
  EXPECT_EQ(*s.note, "IR at 33 mm, fruit 70 mm ahead: leaf or fruit, closing 26 mm on");
  // Nothing in range (past a leaf): braking to the point, sqrt(2 x 0.8 x (0.026 - 0.006)), not to the estimate.
  g.on_reading(reading(0.8, ir_range_t::TOO_FAR), kT + 5'000, true);
  s = g.step(kT + 5'000, tool_at(0.006), fruit(0.064, Fruit::Depth::kCrossing), std::nullopt);
  EXPECT_EQ(s.action, IrStep::Action::kAdvance);
  EXPECT_NEAR(s.forward_speed, std::sqrt(2 * 0.8 * 0.020), 1e-6);
  g.on_reading(reading(0.300), kT + 10'000, true);  // folded back (or past a leaf): no matter
  s = g.step(kT + 10'000, tool_at(0.0255), fruit(0.045, Fruit::Depth::kCrossing), std::nullopt);
  EXPECT_EQ(s.action, IrStep::Action::kAdvance);
  EXPECT_FALSE(s.note.has_value());
  g.on_reading(reading(0.020), kT + 20'000, true);  // a grasp reading short of the point: not yet
  EXPECT_EQ(g.step(kT + 20'000, tool_at(0.0255), fruit(0.045, Fruit::Depth::kCrossing), std::nullopt).action,
            IrStep::Action::kAdvance);
  EXPECT_EQ(g.step(kT + 20'000, tool_at(0.0261), fruit(0.044, Fruit::Depth::kCrossing), std::nullopt).action,
            IrStep::Action::kClose);
  // A new attempt forgets the point.
  g.retry(tool_at(0.0261).translation(), kT + 30'000);
  g.on_reading(reading(0.300), kT + 30'000, true);
  EXPECT_EQ(g.step(kT + 30'000, tool_at(0.03), fruit(0.2, Fruit::Depth::kConfirmed), std::nullopt).action,
            IrStep::Action::kAdvance);

  cfg.ir_split_max = ServoConfig{}.ir_split_max;
  IrGuidance capped = start(0.033);
  s = capped.step(kT, kTool, fruit(0.07, Fruit::Depth::kConfirmed), std::nullopt);
  ASSERT_TRUE(s.note.has_value());
  EXPECT_EQ(*s.note, "IR at 33 mm, fruit 70 mm ahead: leaf or fruit, closing 20 mm on");
  EXPECT_EQ(capped.step(kT, tool_at(0.0195), fruit(0.05, Fruit::Depth::kConfirmed), std::nullopt).action,
            IrStep::Action::kAdvance);
  EXPECT_EQ(capped.step(kT, tool_at(0.0201), fruit(0.05, Fruit::Depth::kConfirmed), std::nullopt).action,
            IrStep::Action::kClose);
  IrGuidance beyond = start(0.033);
  s = beyond.step(kT, kTool, fruit(0.076, Fruit::Depth::kConfirmed), std::nullopt);
  ASSERT_TRUE(s.note.has_value());
  EXPECT_EQ(*s.note, "IR at 33 mm, fruit 76 mm ahead: past a leaf");
  IrGuidance within = start(0.033);
  EXPECT_EQ(within.step(kT, kTool, fruit(0.049, Fruit::Depth::kConfirmed), std::nullopt).action,
            IrStep::Action::kClose);
  IrGuidance size_only = start(0.033);
  EXPECT_EQ(size_only.step(kT, kTool, fruit(0.07, Fruit::Depth::kSize), std::nullopt).action, IrStep::Action::kClose);
  IrGuidance front = start(0.033);
  EXPECT_EQ(front.step(kT, kTool, fruit(0.07, Fruit::Depth::kConfirmed), 0.010).action, IrStep::Action::kClose);
  cfg.ir_split_close = 0.0;
  IrGuidance off = start(0.033);
  s = off.step(kT, kTool, fruit(0.07, Fruit::Depth::kConfirmed), std::nullopt);
  ASSERT_TRUE(s.note.has_value());
  EXPECT_EQ(*s.note, "IR at 33 mm, fruit 70 mm ahead: past a leaf");
}

// A fruit covering the centre of a fresh hand image (HandTracker::fruit_on_axis) is what the IR reads: a grasp
// reading then is closed on at once, with the checked estimate beyond the agreement (6.1 cm ahead, the crossing's
// depth too deep), in the leaf-or-fruit band, or with the fruit seen whole 20 cm off. Once going on past a leaf, a
// reading short of where the leaf was is that leaf still.
TEST(IrGuidance, AGraspReadingWithAFruitOnTheAxisIsNeverALeaf) {
  constexpr bool kWhole = true, kOnAxis = true;
  IrGuidance checked = guiding();
  checked.on_reading(reading(0.010), kT, true);
  IrStep s =
      checked.step(kT, kTool, fruit(0.061, Fruit::Depth::kCrossing), std::nullopt, std::nullopt, !kWhole, kOnAxis);
  EXPECT_EQ(s.action, IrStep::Action::kClose);
  ASSERT_TRUE(s.note.has_value());
  EXPECT_EQ(*s.note, "IR at 10 mm, fruit 61 mm ahead, a fruit over the hand image: no leaf");
  ServoConfig split_cfg;
  split_cfg.ir_split_close = 0.10;
  IrGuidance split(split_cfg);
  split.begin(kTool.translation(), kT);
  split.on_reading(reading(0.010), kT, true);
  EXPECT_EQ(
      split.step(kT, kTool, fruit(0.08, Fruit::Depth::kConfirmed), std::nullopt, std::nullopt, !kWhole, kOnAxis).action,
      IrStep::Action::kClose);
  IrGuidance whole = guiding();
  whole.on_reading(reading(0.010), kT, true);
  EXPECT_EQ(whole.step(kT, kTool, fruit(0.2, Fruit::Depth::kSize), std::nullopt, std::nullopt, kWhole, kOnAxis).action,
            IrStep::Action::kClose);
  IrGuidance passing = guiding();
  passing.on_reading(reading(0.010), kT, true);
  EXPECT_EQ(passing.step(kT, kTool, fruit(0.2, Fruit::Depth::kConfirmed), std::nullopt).action,
            IrStep::Action::kAdvance);
  EXPECT_EQ(
      passing
          .step(kT, tool_at(0.005), fruit(0.2, Fruit::Depth::kConfirmed), std::nullopt, std::nullopt, !kWhole, kOnAxis)
          .action,
      IrStep::Action::kAdvance);
}

// A fruit seen whole in a fresh hand image with its estimate 10 cm or more ahead is far, whatever its depth's
// source: a grasp reading then is a leaf in front of it (in wind the crossing disagrees with a fruit that has swung
// on: its depth is the size's alone). Not 9 cm ahead, not unless seen whole, not with a nearer fruit filling the view.
TEST(IrGuidance, AGraspReadingWhileTheFruitIsSeenWholeAndFarIsALeaf) {
  for (const Fruit::Depth depth : {Fruit::Depth::kSize, Fruit::Depth::kNear}) {
    IrGuidance g = guiding();
    g.on_reading(reading(0.010), kT, true);
    const IrStep s = g.step(kT, kTool, fruit(0.1, depth), std::nullopt, std::nullopt, true);
    EXPECT_EQ(s.action, IrStep::Action::kAdvance);
    ASSERT_TRUE(s.note.has_value());
    EXPECT_EQ(*s.note, "IR at 10 mm, fruit 100 mm ahead, seen whole: past a leaf");
    // Past the leaf, a grasp reading with the fruit 4 cm ahead is the fruit.
    EXPECT_EQ(g.step(kT, tool_at(0.011), fruit(0.04, depth), std::nullopt, std::nullopt, true).action,
              IrStep::Action::kClose);
    IrGuidance nearer = guiding();
    nearer.on_reading(reading(0.010), kT, true);
    EXPECT_EQ(nearer.step(kT, kTool, fruit(0.09, depth), std::nullopt, std::nullopt, true).action,
              IrStep::Action::kClose);
    IrGuidance unseen = guiding();
    unseen.on_reading(reading(0.010), kT, true);
    EXPECT_EQ(unseen.step(kT, kTool, fruit(0.2, depth), std::nullopt, std::nullopt, false).action,
              IrStep::Action::kClose);
  }
  IrGuidance front = guiding();
  front.on_reading(reading(0.010), kT, true);
  EXPECT_EQ(front.step(kT, kTool, fruit(0.2, Fruit::Depth::kSize), 0.010, std::nullopt, true).action,
            IrStep::Action::kClose);
  ServoConfig off_cfg;
  off_cfg.far_view_ahead = 0.0;
  IrGuidance off(off_cfg);
  off.begin(kTool.translation(), kT);
  off.on_reading(reading(0.010), kT, true);
  EXPECT_EQ(off.step(kT, kTool, fruit(0.2, Fruit::Depth::kSize), std::nullopt, std::nullopt, true).action,
            IrStep::Action::kClose);
}

// A nearer fruit filling the view: closed on within 15 mm of the axis, left beside it.
TEST(IrGuidance, ANearerFruitInTheWayIsClosedOnOnlyNearTheAxis) {
  IrGuidance g = guiding();
  g.on_reading(reading(0.010), kT, true);
  // Never taken for a leaf: the IR reads that fruit.
  EXPECT_EQ(g.step(kT, kTool, fruit(0.2, Fruit::Depth::kConfirmed), 0.010).action, IrStep::Action::kClose);
  const IrStep s = g.step(kT, kTool, fruit(0.2, Fruit::Depth::kConfirmed), 0.020);
  EXPECT_EQ(s.action, IrStep::Action::kFruitInTheWay);
  EXPECT_DOUBLE_EQ(s.offset, 0.020);
}

// Past a leaf read 10 mm ahead of the sensor, the sensor passes it after
// 10 mm of travel; a grasp reading after that, with a nearer fruit filling
// the hand image 20 mm off the axis, is that fruit (left, not pushed off by
// the palm) or, 10 mm off, closed on. While the sensor is still short of the
// leaf the same view changes nothing: it is the leaf's reading.
TEST(IrGuidance, BeyondALeafTheNextReadingIsJudgedAfresh) {
  const Fruit far = fruit(0.3, Fruit::Depth::kConfirmed);
  IrGuidance g = guiding();
  g.on_reading(reading(0.010), kT, true);
  IrStep s = g.step(kT, tool_at(0.0), far, std::nullopt);
  ASSERT_EQ(s.action, IrStep::Action::kAdvance);
  ASSERT_TRUE(s.note.has_value());
  g.on_reading(reading(0.005), kT + 10'000, true);
  EXPECT_EQ(g.step(kT + 10'000, tool_at(0.005), fruit(0.295, Fruit::Depth::kConfirmed), 0.020).action,
            IrStep::Action::kAdvance);  // still short of the leaf
  g.on_reading(reading(0.010), kT + 20'000, true);
  s = g.step(kT + 20'000, tool_at(0.012), fruit(0.288, Fruit::Depth::kConfirmed), 0.020);
  EXPECT_EQ(s.action, IrStep::Action::kFruitInTheWay);
  EXPECT_DOUBLE_EQ(s.offset, 0.020);
  EXPECT_FALSE(s.note.has_value());
  EXPECT_EQ(g.step(kT + 20'000, tool_at(0.012), fruit(0.288, Fruit::Depth::kConfirmed), 0.010).action,
            IrStep::Action::kClose);
  // With no fruit in view it is another leaf: passed, not noted again.
  s = g.step(kT + 20'000, tool_at(0.012), fruit(0.288, Fruit::Depth::kConfirmed), std::nullopt);
  EXPECT_EQ(s.action, IrStep::Action::kAdvance);
  EXPECT_FALSE(s.note.has_value());
}

TEST(IrGuidance, AnAttemptEndsOutOfTravelPastTheFruitOrBlocked) {
  IrGuidance g = guiding();
  g.on_reading(reading(0.2, ir_range_t::TOO_FAR), kT, true);
  EXPECT_EQ(g.step(kT, tool_at(0.59), fruit(1.0), std::nullopt).action, IrStep::Action::kAdvance);
  EXPECT_EQ(g.step(kT, tool_at(0.61), fruit(1.0), std::nullopt).action, IrStep::Action::kGiveUp);  // 0.6 m
  IrGuidance past = guiding();
  past.on_reading(reading(0.2, ir_range_t::TOO_FAR), kT, true);
  EXPECT_EQ(past.step(kT, tool_at(0.2), fruit(0.151), std::nullopt).action, IrStep::Action::kAdvance);
  EXPECT_EQ(past.step(kT, tool_at(0.2), fruit(0.149), std::nullopt).action, IrStep::Action::kGiveUp);  // 51 mm past
  // Blocked: less than 5 mm of motion in the stall time (2 s).
  IrGuidance blocked = guiding();
  const auto at = [&](double s) { return kT + rt::from_seconds(s); };
  blocked.on_reading(reading(0.2, ir_range_t::TOO_FAR), at(1.9), true);
  EXPECT_NE(blocked.step(at(1.9), tool_at(0.004), fruit(0.5), std::nullopt).action, IrStep::Action::kGiveUp);
  blocked.on_reading(reading(0.2, ir_range_t::TOO_FAR), at(2.1), true);
  EXPECT_EQ(blocked.step(at(2.1), tool_at(0.004), fruit(0.5), std::nullopt).action, IrStep::Action::kGiveUp);
  IrGuidance moving = guiding();
  moving.on_reading(reading(0.2, ir_range_t::TOO_FAR), at(2.1), true);
  EXPECT_NE(moving.step(at(1.9), tool_at(0.006), fruit(0.5), std::nullopt).action, IrStep::Action::kGiveUp);
  EXPECT_NE(moving.step(at(2.1), tool_at(0.006), fruit(0.5), std::nullopt).action, IrStep::Action::kGiveUp);
}

// An estimate 10 cm short (fruit estimated 0.1 m ahead): the IR reads a
// surface that stays put 0.22 m ahead while the tool comes on in 1 cm steps.
// Past the estimate by more than ir_overshoot (5 cm) the approach goes on,
// up to ir_surface_reach (12 cm) more, and closes where the IR reads the
// grasp range (35 mm: tool at 0.185 m). A reading that does not stay put (a
// leaf pushed along: always 0.2 m) or nothing read gives up at 5 cm past.
TEST(IrGuidance, ASurfaceThatStaysPutAheadIsFollowedPastAShortEstimate) {
  const auto approach = [](const std::function<double(double)>& range, ServoConfig cfg = ServoConfig{}) {
    cfg.ir_grasp_range = 0.035;
    IrGuidance g{cfg};
    g.begin(kTool.translation(), kT);
    for (int i = 0; i <= 40; ++i) {
      const double z = 0.01 * i;
      const rt::Micros now = kT + rt::from_seconds(0.02 * i);
      g.on_reading(reading(range(z)), now, true);
      const IrStep s = g.step(now, tool_at(z), fruit(0.1), std::nullopt);
      if (s.action != IrStep::Action::kAdvance) return std::make_pair(s.action, z);
    }
    return std::make_pair(IrStep::Action::kAdvance, 0.4);
  };
  const auto [action, z] = approach([](double z) { return 0.22 - z; });
  EXPECT_EQ(action, IrStep::Action::kClose);
  EXPECT_NEAR(z, 0.19, 1e-9);  // the first 1 cm step at or past 0.185
  const auto [pushed, z_pushed] = approach([](double) { return 0.2; });
  EXPECT_EQ(pushed, IrStep::Action::kGiveUp);
  EXPECT_NEAR(z_pushed, 0.16, 1e-9);  // 6 cm past the estimate
  // Followed no farther than ir_surface_reach beyond ir_overshoot: 17 cm past the estimate (a surface 0.5 m ahead).
  const auto [far, z_far] = approach([](double z) { return 0.5 - z; });
  EXPECT_EQ(far, IrStep::Action::kGiveUp);
  EXPECT_NEAR(z_far, 0.275, 0.006);  // 0.27 lies on the bound: its rounding decides
  ServoConfig off;
  off.ir_surface_reach = 0.0;
  const auto [without, z_without] = approach([](double z) { return 0.22 - z; }, off);
  EXPECT_EQ(without, IrStep::Action::kGiveUp);
  EXPECT_NEAR(z_without, 0.16, 1e-9);
  // Readings scattered beyond ir_surface_tolerance (2 cm) are no surface that stays put.
  const auto [scattered, z_scattered] =
      approach([](double z) { return 0.22 - z + (std::lround(z * 100) % 2 ? 0.03 : 0.0); });
  EXPECT_EQ(scattered, IrStep::Action::kGiveUp);
  EXPECT_NEAR(z_scattered, 0.16, 1e-9);
}

// Standing off a swaying fruit 0.2 m short of it: the braking speed to there,
// zero there and nearer (no floor), the IR's shorter range still governing;
// a tool standing there longer than the stall time is not blocked, and
// what its IR read standing there is no fold-back.
TEST(IrGuidance, HoldingOffAFruitStopsShortOfItAndIsNoStall) {
  IrGuidance g = guiding();
  EXPECT_NEAR(g.forward_speed(kTool, fruit(0.3), false, 0.2), 0.381, 1e-12);  // sqrt(2 0.8 0.1) = 0.4, capped
  EXPECT_NEAR(g.forward_speed(kTool, fruit(0.21), false, 0.2), std::sqrt(2 * 0.8 * 0.01), 1e-12);
  EXPECT_EQ(g.forward_speed(kTool, fruit(0.2), false, 0.2), 0.0);
  EXPECT_EQ(g.forward_speed(kTool, fruit(0.15), false, 0.2), 0.0);
  g.on_reading(reading(0.035), kT, true);  // 20 mm to the grasp range
  EXPECT_NEAR(g.forward_speed(kTool, fruit(0.3), true, 0.2), std::sqrt(2 * 0.8 * 0.02), 1e-6);
  const auto at = [&](double s) { return kT + rt::from_seconds(s); };
  IrGuidance held = guiding(), unheld = guiding();
  for (double s = 0.5; s <= 3.0; s += 0.5) {
    held.on_reading(reading(0.3), at(s), true);
    const IrStep h = held.step(at(s), kTool, fruit(0.2), std::nullopt, 0.2);
    EXPECT_EQ(h.action, IrStep::Action::kAdvance) << s;
    EXPECT_EQ(h.forward_speed, 0.0) << s;
  }
  unheld.on_reading(reading(0.3), at(2.1), true);
  EXPECT_EQ(unheld.step(at(2.1), kTool, fruit(0.2), std::nullopt).action, IrStep::Action::kGiveUp);
  // A leaf just above the grasp range in the beam of the standing tool, then gone: no fold-back, no close.
  IrGuidance leafy = guiding();
  leafy.on_reading(reading(0.04), at(0.1), true);
  leafy.on_reading(reading(0.3), at(0.2), true);
  EXPECT_EQ(leafy.step(at(0.2), kTool, fruit(0.2), std::nullopt, 0.2).action, IrStep::Action::kAdvance);
  leafy.on_reading(reading(0.3), at(0.3), true);
  EXPECT_EQ(leafy.step(at(0.3), kTool, fruit(0.2), std::nullopt).action, IrStep::Action::kAdvance);
}

TEST(IrGuidance, ARetryCountsTheAttemptAndKeepsWhereGuidanceBegan) {
  IrGuidance g{ServoConfig{}};
  g.begin({0.0, 0.0, 0.1}, kT);
  EXPECT_EQ(g.attempt(), 1);
  EXPECT_TRUE(g.attempts_left());
  g.retry({0.0, 0.0, 0.3}, kT);
  EXPECT_EQ(g.attempt(), 2);
  EXPECT_FALSE(g.attempts_left());  // ir_attempts 2
  EXPECT_DOUBLE_EQ(g.start().z(), 0.1);
}

TEST(IrGuidance, TheGripperGoesOnAlongItsAxisWhileItCloses) {
  IrGuidance g = guiding();
  g.closing_at(kTool.translation());
  const auto first = g.grasp_twist(kTool);
  ASSERT_TRUE(first.has_value());
  EXPECT_NEAR(first->linear.z(), 0.04, 1e-12);
  EXPECT_NEAR(first->linear.head<2>().norm(), 0.0, 1e-12);
  EXPECT_TRUE(g.grasp_twist(tool_at(0.0149)).has_value());
  EXPECT_FALSE(g.grasp_twist(tool_at(0.015)).has_value());  // grasp_advance reached: stop
}

// grasp_stop_at_joint_limit: a joint held at its limit during the close stops the advance for the rest of it (on a
// tree the clipped axial twist took the tool 6-11 mm sideways while the fingers closed, from 15-20 mm off a fruit to
// 26-30: knocked off); the next close advances again. Off: the limit changes nothing.
TEST(IrGuidance, AJointAtItsLimitStopsTheAdvanceWhileItCloses) {
  ServoConfig cfg;
  cfg.grasp_stop_at_joint_limit = true;
  IrGuidance g{cfg};
  g.begin(kTool.translation(), kT);
  g.on_joint_limit(true);  // before the close, then clear: forgotten when it begins
  g.on_joint_limit(false);
  g.closing_at(kTool.translation());
  ASSERT_TRUE(g.grasp_twist(tool_at(0.005)).has_value());
  g.on_joint_limit(true);
  g.on_joint_limit(false);
  EXPECT_FALSE(g.grasp_twist(tool_at(0.005)).has_value());
  EXPECT_FALSE(g.grasp_twist(tool_at(0.006)).has_value());  // for good, though the limit may clear
  g.closing_at(kTool.translation());
  EXPECT_TRUE(g.grasp_twist(kTool).has_value());
  cfg.grasp_stop_at_joint_limit = false;
  IrGuidance off{cfg};
  off.begin(kTool.translation(), kT);
  off.closing_at(kTool.translation());
  off.on_joint_limit(true);
  EXPECT_TRUE(off.grasp_twist(tool_at(0.005)).has_value());
}

}  // namespace
}  // namespace harvest::servo
