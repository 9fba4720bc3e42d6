#include "servo/harvest/hand_tracker.hpp"

#include <gtest/gtest.h>

#include <cmath>

namespace harvest::servo {
namespace {

// The hand camera at the base origin looking along +z, no distortion; the
// fruit 0.5 m ahead on its axis; the fixed camera 0.3 m to the side, its
// line of sight through the fruit crossing the optical axis at 0.54 rad.
ServoConfig config() {
  ServoConfig c;
  c.hand_camera.dist = {};
  return c;
}
const Eigen::Isometry3d kCamera = Eigen::Isometry3d::Identity();
constexpr rt::Micros kT = 1'000'000;

Fruit fruit_ahead() {
  Fruit f;
  f.id = 1;
  f.estimate = Eigen::Vector3d(0.0, 0.0, 0.5);
  f.diameter = 0.075;
  SightLine l;
  l.origin = Eigen::Vector3d(-0.3, 0.0, 0.0);
  l.direction = (f.estimate - l.origin).normalized();
  l.near = 0.2;
  l.far = 1.0;
  f.sight = l;
  return f;
}

fruit_t detection(double u, double v, double diameter_px) {
  fruit_t f{};
  f.u_px = static_cast<float>(u);
  f.v_px = static_cast<float>(v);
  f.diameter_px = static_cast<float>(diameter_px);
  const int r = static_cast<int>(diameter_px / 2);
  f.bbox_px[0] = static_cast<int>(u) - r;
  f.bbox_px[1] = static_cast<int>(v) - r;
  f.bbox_px[2] = f.bbox_px[3] = 2 * r;
  return f;
}

fruit_detections_t image(rt::Micros utime, std::vector<fruit_t> fruits) {
  fruit_detections_t m{};
  m.header.utime = utime;
  m.image_width = 640;
  m.image_height = 480;
  m.status = fruit_detections_t::STATUS_OK;
  m.fruits = std::move(fruits);
  m.num_fruits = static_cast<int32_t>(m.fruits.size());
  return m;
}

targets_t hand_target(rt::Micros utime, int id, const fruit_t& at, const Eigen::Vector3d& p) {
  targets_t m{};
  m.header.utime = utime;
  m.source_camera = "hand";
  target_t t{};
  t.fruit_id = id;
  t.u_px = at.u_px;
  t.v_px = at.v_px;
  for (int i = 0; i < 3; ++i) t.position_base[i] = p[i];
  m.targets.push_back(t);
  m.num_targets = 1;
  return m;
}

TEST(HandTracker, FollowsTheDetectionNearestTheFruitWithinTheGate) {
  HandTracker h(config());
  const Fruit f = fruit_ahead();
  // The estimate projects at the principal point (319.5, 239.5).
  h.on_detections(image(1, {detection(450, 240, 60), detection(340, 250, 60)}), f, kCamera, kT);
  ASSERT_TRUE(h.fresh(kT).has_value());
  EXPECT_FLOAT_EQ(h.fresh(kT)->u, 340.0f);
  EXPECT_EQ(h.fresh(kT)->utime, 1);
  EXPECT_EQ(h.seen_at(), kT);
  // Then it follows its last centroid: the detection that moved on, not the one at the estimate.
  h.on_detections(image(2, {detection(320, 240, 60), detection(380, 250, 60)}), f, kCamera, kT + 33'000);
  EXPECT_FLOAT_EQ(h.fresh(kT + 33'000)->u, 320.0f);  // 20 px from 340, nearer than 380
  // Stale after timeouts.lost.
  EXPECT_FALSE(h.fresh(kT + 33'000 + rt::from_seconds(0.31)).has_value());
}

// The line of sight images onto v = 239.5. (450, 240) lies on it (0.5 px) 130 px from the predicted point,
// (340, 250) 10.5 px off it 23 px from the point: scores 0.5 + 0.25 x 130 = 33 against 10.5 + 0.25 x 23 = 16.2
// with association_tie_weight 0.25, the second chosen; with 0 the line alone decides, the first.
TEST(HandTracker, TheTieWeightTradesTheLineOfSightAgainstThePredictedPoint) {
  for (const double weight : {0.25, 0.0}) {
    ServoConfig c = config();
    c.association_tie_weight = weight;
    HandTracker h(c);
    h.on_detections(image(1, {detection(450, 240, 60), detection(340, 250, 60)}), fruit_ahead(), kCamera, kT);
    ASSERT_TRUE(h.fresh(kT).has_value());
    EXPECT_FLOAT_EQ(h.fresh(kT)->u, weight > 0.0 ? 340.0f : 450.0f);
  }
}

// While following, a detection of another apparent size (beyond a factor
// 1.6: a piece of the fruit, a neighbour nearer or farther) is not the fruit,
// however near; one within the factor is. A new fruit starts afresh.
TEST(HandTracker, AFollowedFruitIsNotFollowedOntoAPieceOfAnotherSize) {
  ServoConfig sized = config();
  sized.association_size_ratio = 1.6;  // off by default
  HandTracker h(sized);
  const Fruit f = fruit_ahead();
  h.on_detections(image(1, {detection(320, 240, 200)}), f, kCamera, kT);
  ASSERT_TRUE(h.fresh(kT).has_value());
  // The fruit broke into pieces: the nearest is 10 px away but 60 px across.
  h.on_detections(image(2, {detection(330, 240, 60), detection(250, 240, 130)}), f, kCamera, kT + 33'000);
  EXPECT_EQ(h.fresh(kT + 33'000)->utime, 2);  // 130 px (0.65 of 200) is within the factor: followed, 70 px away
  EXPECT_FLOAT_EQ(h.fresh(kT + 33'000)->u, 250.0f);
  h.on_detections(image(3, {detection(255, 240, 60), detection(250, 250, 300)}), f, kCamera, kT + 66'000);
  EXPECT_EQ(h.fresh(kT + 66'000)->utime, 2);  // 60 / 130 and 300 / 130: neither; the last stays until timeouts.lost
  h.on_detections(image(4, {detection(255, 240, 200)}), f, kCamera, kT + 99'000);
  EXPECT_EQ(h.fresh(kT + 99'000)->utime, 4);  // 200 / 130 = 1.54
  ServoConfig off = config();
  off.association_size_ratio = 0.0;
  HandTracker any(off);
  any.on_detections(image(1, {detection(320, 240, 200)}), f, kCamera, kT);
  any.on_detections(image(2, {detection(330, 240, 60)}), f, kCamera, kT + 33'000);
  EXPECT_EQ(any.fresh(kT + 33'000)->utime, 2);
  // Not following (lost for timeouts.lost): any size is taken again.
  h.on_detections(image(5, {detection(320, 240, 40)}), f, kCamera, kT + 99'000 + rt::from_seconds(0.31));
  EXPECT_EQ(h.fresh(kT + 99'000 + rt::from_seconds(0.31))->utime, 5);
  h.forget_fruit();
  h.on_detections(image(6, {detection(320, 240, 300)}), f, kCamera, kT + rt::from_seconds(1.0));
  EXPECT_EQ(h.fresh(kT + rt::from_seconds(1.0))->utime, 6);
}

// The size a followed fruit should have is the last one grown by how far the camera came toward the estimate:
// coming from 0.5 to 0.35 m the fruit grows from 100 to 143 px by itself and is followed at a factor of 1.3; a
// detection 1.5 times that (a nearer fruit merged with it) is not, nor a piece.
TEST(HandTracker, TheSizeGateAllowsForTheCameraComingNearer) {
  ServoConfig sized = config();
  sized.association_size_ratio = 1.3;
  HandTracker h(sized);
  const Fruit f = fruit_ahead();
  h.on_detections(image(1, {detection(320, 240, 100)}), f, kCamera, kT);
  ASSERT_TRUE(h.fresh(kT).has_value());
  Eigen::Isometry3d nearer = kCamera;
  nearer.translation() = Eigen::Vector3d(0.0, 0.0, 0.15);
  h.on_detections(image(2, {detection(322, 240, 214)}), f, nearer, kT + 33'000);
  EXPECT_EQ(h.fresh(kT + 33'000)->utime, 1);  // 214 / 143: merged with a nearer fruit
  h.on_detections(image(3, {detection(322, 240, 70)}), f, nearer, kT + 66'000);
  EXPECT_EQ(h.fresh(kT + 66'000)->utime, 1);  // a piece
  h.on_detections(image(4, {detection(322, 240, 150)}), f, nearer, kT + 99'000);
  EXPECT_EQ(h.fresh(kT + 99'000)->utime, 4);  // 150 / 143: the fruit, grown
  // Seen from the same place again, 150 px stays the size: 1.3 times more is refused.
  h.on_detections(image(5, {detection(322, 240, 200)}), f, nearer, kT + 132'000);
  EXPECT_EQ(h.fresh(kT + 132'000)->utime, 4);
}

TEST(HandTracker, NothingWithinTheGateIsNoMeasurement) {
  HandTracker h(config());
  Fruit f = fruit_ahead();
  f.sight.reset();  // no line of sight: gated on the distance to the projected estimate
  h.on_detections(image(1, {detection(319.5 + 81, 239.5, 60)}), f, kCamera, kT);  // 81 px > 80 px gate
  EXPECT_FALSE(h.fresh(kT).has_value());
  h.on_detections(image(1, {detection(319.5 + 79, 239.5, 60)}), f, kCamera, kT);
  EXPECT_TRUE(h.fresh(kT).has_value());
}

// With a line of sight the gate is on the distance to its image: a detection
// on it far from the projected estimate (a doubtful depth) is taken, one off
// it is not.
TEST(HandTracker, TheGateFollowsTheImageOfTheLineOfSight) {
  HandTracker h(config());
  const Fruit f = fruit_ahead();  // its line of sight images onto the row v = 239.5
  h.on_detections(image(1, {detection(150, 239.5 + 85, 60)}), f, kCamera, kT);
  EXPECT_FALSE(h.fresh(kT).has_value());
  h.on_detections(image(1, {detection(150, 239.5 + 5, 60)}), f, kCamera, kT);
  EXPECT_TRUE(h.fresh(kT).has_value());
}

// Hand-worked: the rays cross at the fruit, 0.5 m from the camera: a size
// depth within max(0.1, 0.3 x 0.5) = 0.15 m of it is kept (confirmed), a
// leaf-cut fruit's 2.5 times too deep one is replaced by the crossing.
// The crossing at 0.5 m; the size agrees within 0.15 m (0.3 of the range).
// A size that disagrees is replaced only where it puts the fruit at least
// crossing_beyond (0.7 m) from the camera: at 0.66 m it stays (kNear);
// at 0.70 and 1.25 m the crossing replaces it; with crossing_beyond 0, at 0.66
// too.
TEST(HandTracker, TheRaysCrossingConfirmsOrReplacesTheSizeDepth) {
  const fruit_t d = detection(319.5, 239.5, 125);
  struct Case {
    double sized, beyond;
    Fruit::Depth depth;
    double z;
  };
  for (const Case& c : {Case{0.64, 0.7, Fruit::Depth::kConfirmed, 0.64}, Case{0.66, 0.7, Fruit::Depth::kNear, 0.66},
                        Case{0.70, 0.7, Fruit::Depth::kCrossing, 0.5}, Case{1.25, 0.7, Fruit::Depth::kCrossing, 0.5},
                        Case{0.66, 0.0, Fruit::Depth::kCrossing, 0.5}}) {
    ServoConfig cfg = config();
    cfg.crossing_beyond = c.beyond;
    HandTracker h(cfg);
    Fruit f = fruit_ahead();
    h.on_detections(image(7, {d}), f, kCamera, kT);
    h.on_hand_targets(hand_target(7, 99, d, {0.0, 0.0, c.sized}), f, kCamera, kT);
    EXPECT_EQ(f.depth, c.depth) << c.sized << " " << c.beyond;
    EXPECT_NEAR(f.estimate.z(), c.z, 1e-6) << c.sized << " " << c.beyond;
  }
}

TEST(HandTracker, WithoutACrossingTheSizeDepthIsTakenAsInTheThesis) {
  ServoConfig c = config();
  c.triangulation_gap = 0.0;  // the thesis's eq. 6-15
  HandTracker h(c);
  Fruit f = fruit_ahead();
  f.depth_doubtful = true;
  const fruit_t d = detection(319.5, 239.5, 125);
  h.on_detections(image(7, {d}), f, kCamera, kT);
  h.on_hand_targets(hand_target(7, 99, d, {0.0, 0.0, 1.25}), f, kCamera, kT);
  EXPECT_EQ(f.depth, Fruit::Depth::kSize);
  EXPECT_NEAR(f.estimate.z(), 1.25, 1e-12);
  EXPECT_FALSE(f.depth_doubtful);
}

// No crossing (no line of sight here) and a size that puts the fruit beyond
// the workspace (z <= 0.8 m here): a leaf-cut fruit looks small and far. The
// hand's ray (the optical axis) passing 2 cm from the fixed camera's estimate
// at z 0.55 gives the depth: (0, 0, 0.55). Not when the ray passes 10 cm off
// it (another fruit), when that point is outside too, when the size was
// inside, or with fixed_depth_gap 0.
TEST(HandTracker, ASizeOutsideTheWorkspaceTakesTheFixedCamerasDepthAlongTheRay) {
  struct Case {
    Eigen::Vector3d fixed, sized;
    double gap;
    bool fixed_depth;
  };
  for (const Case& k :
       {Case{{0.02, 0.0, 0.55}, {0.0, 0.0, 1.25}, 0.06, true}, Case{{0.10, 0.0, 0.55}, {0.0, 0.0, 1.25}, 0.06, false},
        Case{{0.02, 0.0, 0.90}, {0.0, 0.0, 1.25}, 0.06, false}, Case{{0.02, 0.0, 0.55}, {0.0, 0.0, 0.70}, 0.06, false},
        Case{{0.02, 0.0, 0.55}, {0.0, 0.0, 1.25}, 0.0, false}}) {
    ServoConfig c = config();
    c.workspace.min = Eigen::Vector3d(-1.0, -1.0, 0.0);
    c.workspace.max = Eigen::Vector3d(1.0, 1.0, 0.8);
    c.fixed_depth_gap = k.gap;
    HandTracker h(c);
    Fruit f = fruit_ahead();
    f.sight.reset();
    f.selected_from = k.fixed;
    const fruit_t d = detection(319.5, 239.5, 125);
    h.on_detections(image(7, {d}), f, kCamera, kT);
    h.on_hand_targets(hand_target(7, 99, d, k.sized), f, kCamera, kT);
    if (k.fixed_depth) {
      EXPECT_EQ(f.depth, Fruit::Depth::kFixed);
      EXPECT_NEAR((f.estimate - Eigen::Vector3d(0.0, 0.0, 0.55)).norm(), 0.0, 1e-9);
    } else {
      EXPECT_EQ(f.depth, Fruit::Depth::kSize) << k.fixed.transpose() << " / " << k.sized.z() << " / " << k.gap;
      EXPECT_NEAR((f.estimate - k.sized).norm(), 0.0, 1e-12);
    }
  }
}

TEST(HandTracker, AFruitCutByTheBorderOrFillingTheImageGivesNoDepth) {
  for (const fruit_t& d : {detection(319.5, 239.5, 400),  // 400 px of 480: fills the view
                           detection(40, 239.5, 78)}) {   // bbox from x = 1: on the border
    HandTracker h(config());
    Fruit f = fruit_ahead();
    h.on_detections(image(7, {d}), f, kCamera, kT);
    ASSERT_TRUE(h.fresh(kT).has_value()) << d.u_px;
    h.on_hand_targets(hand_target(7, 99, d, {0.0, 0.0, 0.55}), f, kCamera, kT);
    EXPECT_NEAR(f.estimate.z(), 0.5, 1e-12) << d.u_px;
  }
  // A target of another image, or at another pixel, is not this detection's either.
  HandTracker h(config());
  Fruit f = fruit_ahead();
  const fruit_t d = detection(319.5, 239.5, 125);
  h.on_detections(image(7, {d}), f, kCamera, kT);
  h.on_hand_targets(hand_target(8, 99, d, {0.0, 0.0, 0.55}), f, kCamera, kT);
  h.on_hand_targets(hand_target(7, 99, detection(321, 239.5, 125), {0.0, 0.0, 0.55}), f, kCamera, kT);
  EXPECT_NEAR(f.estimate.z(), 0.5, 1e-12);
}

// whole_min_visible: a detection less visible than that is a piece of a fruit (the learned detector sizes the piece:
// on the field look it read 0.17-0.86 of the fruit's size), its size no depth; off (0), any piece gives one.
TEST(HandTracker, APieceOfAFruitGivesNoDepthWithWholeMinVisible) {
  for (const double min_visible : {0.0, 0.4}) {
    for (const double visible : {0.2, 0.5}) {
      ServoConfig c = config();
      c.whole_min_visible = min_visible;
      HandTracker h(c);
      Fruit f = fruit_ahead();
      fruit_t d = detection(319.5, 239.5, 125);
      d.visible_fraction = static_cast<float>(visible);
      h.on_detections(image(7, {d}), f, kCamera, kT);
      ASSERT_TRUE(h.fresh(kT).has_value());
      EXPECT_EQ(h.whole(), visible >= min_visible) << min_visible << " " << visible;
      h.on_hand_targets(hand_target(7, 99, d, {0.0, 0.0, 0.55}), f, kCamera, kT);
      EXPECT_NEAR(f.estimate.z(), visible >= min_visible ? 0.55 : 0.5, 1e-12) << min_visible << " " << visible;
    }
  }
}

// Hand-worked: a detection 420 px across (of 480) covering the image centre,
// its centre 42 px off it, while the fruit aimed at should look 125 px
// across (833.57 x 0.075 / 0.5): a nearer fruit 0.1 diameters = 7.5 mm off the axis.
TEST(HandTracker, ANearerFruitFillingTheViewOnTheAxisIsReportedWithItsOffset) {
  HandTracker h(config());
  const Fruit f = fruit_ahead();
  h.on_detections(image(1, {detection(319.5 + 42, 239.5, 420)}), f, kCamera, kT);
  ASSERT_TRUE(h.fruit_in_front(kT).has_value());
  EXPECT_NEAR(*h.fruit_in_front(kT), 42.0 / 420.0 * 0.075, 1e-6);
  EXPECT_FALSE(h.fruit_in_front(kT + rt::from_seconds(0.31)).has_value());
  // Filling the view but no larger than 1.5 times the fruit aimed at: that fruit itself.
  HandTracker near(config());
  Fruit close = fruit_ahead();
  close.estimate.z() = 0.14;  // looks 447 px across
  near.on_detections(image(1, {detection(319.5, 239.5, 420)}), close, kCamera, kT);
  EXPECT_FALSE(near.fruit_in_front(kT).has_value());
}

}  // namespace
}  // namespace harvest::servo

namespace harvest::servo {
namespace {

// far_view_age 0.15 s (the default): the followed fruit, whole in an image 0.1 or 0.15 s old, is seen whole; not
// once the image is 0.16 s old, nor cut by the image border, nor filling the view.
TEST(HandTracker, AFruitIsSeenWholeOnlyInAFreshImageClearOfTheBorder) {
  const rt::Micros taken = kT;
  const auto follow = [&](const fruit_t& d) {
    HandTracker h(config());
    Fruit f = fruit_ahead();
    h.on_detections(image(taken, {d}), f, kCamera, taken + 30'000);
    return h;
  };
  const HandTracker small = follow(detection(319.5, 239.5, 125));
  EXPECT_TRUE(small.seen_whole(taken + rt::from_seconds(0.1)));
  EXPECT_TRUE(small.seen_whole(taken + rt::from_seconds(0.15)));
  EXPECT_FALSE(small.seen_whole(taken + rt::from_seconds(0.16)));
  EXPECT_FALSE(follow(detection(60, 239.5, 125)).seen_whole(taken + 50'000));     // cut by the left border
  EXPECT_FALSE(follow(detection(319.5, 239.5, 400)).seen_whole(taken + 50'000));  // fills the view (0.8 x 480)
  EXPECT_FALSE(HandTracker(config()).seen_whole(taken));                          // nothing followed
}

}  // namespace
}  // namespace harvest::servo

namespace harvest::servo {
namespace {

// axis_fruit_area 0.6 (the default) of a 640 x 480 image is 184,320 px^2: a detection of that mask area over the
// image centre is a fruit on the axis in a hand image up to far_view_age (0.15 s) old; one px^2 less, one beside the
// centre, an older image or the key at 0 is not.
TEST(HandTracker, AFruitCoveringTheImageCentreIsOnTheAxisWhileTheImageIsFresh) {
  const rt::Micros taken = kT;
  const auto seen = [&](double u, float area, double key = 0.6) {
    ServoConfig c = config();
    c.axis_fruit_area = key;
    HandTracker h(c);
    fruit_t d = detection(u, 239.5, 600);  // bbox 300 px either side of u
    d.area_px = area;
    h.on_detections(image(taken, {d}), fruit_ahead(), kCamera, taken + 30'000);
    return h;
  };
  EXPECT_TRUE(seen(319.5, 184320).fruit_on_axis(taken + rt::from_seconds(0.15)));
  EXPECT_FALSE(seen(319.5, 184320).fruit_on_axis(taken + rt::from_seconds(0.16)));
  EXPECT_FALSE(seen(319.5, 184319).fruit_on_axis(taken + 50'000));
  EXPECT_FALSE(seen(-20.0, 250000).fruit_on_axis(taken + 50'000));  // bbox ends at u 280: beside the centre
  EXPECT_TRUE(seen(20.0, 250000).fruit_on_axis(taken + 50'000));    // ... at 320: over it (centre 319.5)
  EXPECT_FALSE(seen(319.5, 250000, 0.0).fruit_on_axis(taken + 50'000));
  EXPECT_FALSE(HandTracker(config()).fruit_on_axis(taken));
}

}  // namespace
}  // namespace harvest::servo
