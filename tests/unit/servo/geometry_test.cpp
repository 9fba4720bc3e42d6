#include "servo/geometry.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

namespace harvest::servo {
namespace {

// Hand-worked: the x axis, and a ray up the y axis from (2, -1, 0.1), pass
// closest at (2, 0, 0) and (2, 0, 0.1), at right angles.
TEST(CrossRays, SkewRaysMeetHalfWayAcrossTheirGap) {
  const auto c = cross_rays({0, 0, 0}, {1, 0, 0}, {2, -1, 0.1}, {0, 1, 0});
  ASSERT_TRUE(c);
  EXPECT_NEAR(c->point.x(), 2.0, 1e-12);
  EXPECT_NEAR(c->point.y(), 0.0, 1e-12);
  EXPECT_NEAR(c->point.z(), 0.05, 1e-12);
  EXPECT_NEAR(c->gap, 0.1, 1e-12);
  EXPECT_NEAR(c->angle, std::numbers::pi / 2, 1e-12);
}

// Two cameras 0.7 m apart seeing a point 1 m away: the crossing is the point.
TEST(CrossRays, RaysThroughOnePointCrossThere) {
  const Eigen::Vector3d p(-0.23, 1.07, -0.54), a(-0.25, 0.2, -0.38), b(-0.65, 0.79, -0.25);
  const auto c = cross_rays(a, (p - a).normalized(), b, (p - b).normalized());
  ASSERT_TRUE(c);
  EXPECT_LT((c->point - p).norm(), 1e-9);
  EXPECT_LT(c->gap, 1e-9);
}

TEST(CrossRays, ParallelRaysOrACrossingBehindACameraGiveNothing) {
  EXPECT_FALSE(cross_rays({0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {1, 0, 0}));
  // The lines cross at (2, 0, 0), behind the second ray's origin.
  EXPECT_FALSE(cross_rays({0, 0, 0}, {1, 0, 0}, {2, 1, 0}, {0, 1, 0}));
  EXPECT_FALSE(cross_rays({0, 0, 0}, {1, 0, 0}, {-2, -1, 0}, {0, 1, 0}));  // ... behind the first's
}

}  // namespace
}  // namespace harvest::servo
