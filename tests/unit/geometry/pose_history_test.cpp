// PoseHistory: the camera pose at an image's capture time.
#include "geometry/pose_history.hpp"

#include <gtest/gtest.h>

namespace harvest::geometry {
namespace {

TEST(PoseHistory, InterpolatesAndRefusesGaps) {
  PoseHistory h;
  Eigen::Isometry3d a = Eigen::Isometry3d::Identity(), b = Eigen::Isometry3d::Identity();
  b.translation() << 0.1, 0, 0;
  b.linear() = Eigen::AngleAxisd(0.2, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  h.add(1'000'000, a);
  h.add(1'040'000, b);
  const auto mid = h.at(1'010'000, 100'000);
  ASSERT_TRUE(mid);
  EXPECT_NEAR(mid->translation().x(), 0.025, 1e-12);
  EXPECT_NEAR(Eigen::AngleAxisd(mid->linear()).angle(), 0.05, 1e-9);
  EXPECT_FALSE(h.at(1'020'000, 30'000));         // states 40 ms apart, 30 ms allowed, 20 ms to either
  EXPECT_TRUE(h.at(1'050'000, 30'000));          // 10 ms after the last one: nearest
  EXPECT_FALSE(h.at(1'100'000, 100'000));        // 60 ms after the last one
  EXPECT_FALSE(PoseHistory().at(0, 1'000'000));  // nothing yet
}

TEST(PoseHistory, OutOfOrderSamplesAreSortedAndTheCapacityKeepsTheNewest) {
  PoseHistory h(2);
  Eigen::Isometry3d p = Eigen::Isometry3d::Identity();
  for (const int64_t t : {3'000, 1'000, 2'000}) {
    p.translation().x() = static_cast<double>(t);
    h.add(t, p);
  }
  // 1'000 was dropped (oldest), 2'000 and 3'000 kept in order.
  EXPECT_NEAR(h.at(2'500, 2'000)->translation().x(), 2'500.0, 1e-9);
  EXPECT_FALSE(h.at(1'000, 1'000));
}

}  // namespace
}  // namespace harvest::geometry
