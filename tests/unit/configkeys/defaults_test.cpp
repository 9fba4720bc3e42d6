// Where a loader's declared defaults and a parameter struct's initialisers
// both exist, they must agree: an empty configuration gives the struct's
// defaults, and the effective configuration written back loads the same.
#include <gtest/gtest.h>

#include "config/config.hpp"
#include "features/nodes.hpp"

namespace {

using harvest::config::Document;
namespace f = harvest::features;

TEST(DeclaredDefaults, FeatureTrackerKeysGiveTheParameterStructsDefaults) {
  auto doc = Document::load_string("", "empty.yaml");
  const auto c = f::FeatureTrackerConfig::from_yaml(doc.root());
  const f::FeatureTrackerConfig d;
  const f::TrackerParams t;
  const f::MatcherParams m;
  EXPECT_EQ(c.camera, d.camera);
  EXPECT_EQ(c.region, d.region);
  EXPECT_EQ(c.fruit_margin, d.fruit_margin);
  EXPECT_EQ(c.fruit_max_age_s, d.fruit_max_age_s);
  EXPECT_EQ(c.matching, d.matching);
  EXPECT_EQ(c.tracker.corners.window, t.corners.window);
  EXPECT_EQ(c.tracker.corners.min_eigenvalue, t.corners.min_eigenvalue);
  EXPECT_EQ(c.tracker.corners.quality_level, t.corners.quality_level);
  EXPECT_EQ(c.tracker.corners.min_distance, t.corners.min_distance);
  EXPECT_EQ(c.tracker.corners.border, t.corners.border);
  EXPECT_EQ(c.tracker.lk.window, t.lk.window);
  EXPECT_EQ(c.tracker.lk.levels, t.lk.levels);
  EXPECT_EQ(c.tracker.lk.max_iterations, t.lk.max_iterations);
  EXPECT_EQ(c.tracker.lk.epsilon_px, t.lk.epsilon_px);
  EXPECT_EQ(c.tracker.lk.min_eigenvalue, t.lk.min_eigenvalue);
  EXPECT_EQ(c.tracker.max_error, t.max_error);
  EXPECT_EQ(c.tracker.max_features, t.max_features);
  EXPECT_EQ(c.tracker.min_features, t.min_features);
  EXPECT_EQ(c.matcher.orb_features, m.orb_features);
  EXPECT_EQ(c.matcher.orb_levels, m.orb_levels);
  EXPECT_EQ(c.matcher.orb_scale, m.orb_scale);
  EXPECT_EQ(c.matcher.fast_threshold, m.fast_threshold);
  EXPECT_EQ(c.matcher.ratio, m.ratio);
  EXPECT_EQ(c.matcher.mutual, m.mutual);
  EXPECT_EQ(c.matcher.ransac_threshold_px, m.ransac_threshold_px);
  EXPECT_EQ(c.matcher.ransac_iterations, m.ransac_iterations);
  EXPECT_EQ(c.matcher.seed, m.seed);
  EXPECT_EQ(c.matcher.min_inliers, m.min_inliers);
  EXPECT_EQ(c.matcher.refine, m.refine);
  EXPECT_EQ(c.matcher.refine_lk.window, m.refine_lk.window);
  EXPECT_EQ(c.matcher.refine_max_shift_px, m.refine_max_shift_px);
  EXPECT_EQ(c.matcher.track, m.track);
  EXPECT_EQ(c.matcher.track_corners, m.track_corners);
  EXPECT_EQ(c.matcher.track_levels, m.track_levels);
  EXPECT_EQ(c.matcher.track_min_fraction, m.track_min_fraction);
  EXPECT_NO_THROW(doc.check_unused());
  auto again = Document::load_string(doc.emit(), "again.yaml");
  EXPECT_EQ(f::FeatureTrackerConfig::from_yaml(again.root()).matcher.refine_lk.window, m.refine_lk.window);
}

}  // namespace
