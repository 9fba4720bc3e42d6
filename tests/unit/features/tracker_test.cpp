// Tracking over a sequence: features follow a known motion, lost ones are
// dropped, new ones replenished, ids stay stable.
#include <gtest/gtest.h>

#include <map>

#include "features/tracker.hpp"
#include "synthetic.hpp"

namespace f = harvest::features;
namespace ft = harvest::features::testing;

TEST(FeatureTracker, FollowsKnownMotionDropsAndReplenishes) {
  const ft::WaveTexture tex(11);
  const cv::Size size(320, 240);
  f::TrackerParams p;
  p.corners.quality_level = 0.05;
  p.min_features = 40;
  p.max_features = 60;
  f::FeatureTracker tracker(p);
  auto u = tracker.update(tex.render(size));
  EXPECT_EQ(u.lost, 0);
  EXPECT_EQ(u.added, 60);
  std::map<int, cv::Point2f> first;
  for (const auto& t : tracker.tracks()) first[t.id] = t.pt;

  // Ten frames moving by (0.7, -0.4) px each: every feature stays.
  for (int k = 1; k <= 10; ++k) {
    u = tracker.update(tex.render(size, 0.7 * k, -0.4 * k));
    EXPECT_EQ(u.lost, 0) << k;
    EXPECT_EQ(u.added, 0) << k;
  }
  double worst = 0;
  for (const auto& t : tracker.tracks()) {
    ASSERT_TRUE(first.count(t.id));
    EXPECT_EQ(t.age, 10);
    worst = std::max(worst, cv::norm(t.pt - (first[t.id] + cv::Point2f(7.f, -4.f))));
  }
  std::printf("after 10 frames: worst accumulated error %.3f px\n", worst);
  EXPECT_LT(worst, 0.5);

  // The region shrinks to the right half: features on the left are dropped,
  // the right half is replenished up to max_features, new ids are fresh.
  const cv::Rect right(size.width / 2, 0, size.width / 2, size.height);
  u = tracker.update(tex.render(size, 7.0, -4.0), right);
  EXPECT_GT(u.lost, 10);
  EXPECT_GT(u.added, 0);
  int fresh = 0;
  for (const auto& t : tracker.tracks()) {
    EXPECT_TRUE(right.contains(cv::Point(t.pt)));
    if (!first.count(t.id)) {
      ++fresh;
      EXPECT_EQ(t.age, 0);
    }
  }
  EXPECT_EQ(fresh, u.added);
  EXPECT_LE(static_cast<int>(tracker.tracks().size()), p.max_features);

  // A blank frame loses everything and finds nothing.
  u = tracker.update(cv::Mat1b(size, uint8_t(128)));
  EXPECT_EQ(u.added, 0);
  EXPECT_TRUE(tracker.tracks().empty());
}
