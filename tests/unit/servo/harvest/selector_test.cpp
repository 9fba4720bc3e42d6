#include "servo/harvest/selector.hpp"

#include <gtest/gtest.h>

#include "config/config.hpp"
#include "servo/geometry.hpp"
#include "servo/harvest/aiming.hpp"

namespace harvest::servo {
namespace {

// Default configuration: pickable means inside the workspace and y >= 0.835
// (home at y 0.785, gripper axis along base +y).
const Eigen::Vector3d kCamera(-0.24, 0.23, -0.40);
const Eigen::Vector3d kHome(-0.655, 0.785, -0.251);

struct View {
  targets_t msg{};
  View() {
    msg.source_camera = "fixed";
    msg.camera_known = true;
    for (int i = 0; i < 3; ++i) msg.camera_position_base[i] = kCamera[i];
  }
  View& add(int id, const Eigen::Vector3d& p, float cost = 1.0f) {
    target_t t{};
    t.fruit_id = id;
    for (int i = 0; i < 3; ++i) t.position_base[i] = p[i];
    t.cost = cost;
    t.diameter_m = 0.075f;
    msg.targets.push_back(t);
    msg.num_targets = static_cast<int32_t>(msg.targets.size());
    return *this;
  }
};

ServoConfig defaults() { return ServoConfig::from_yaml(config::Document::load_string("{}").root()); }

FruitLedger ledger() { return FruitLedger({2, 0.05, 0.02, 0.15}); }

TEST(SelectFruit, LowestCostThenLowestIdAmongUntriedPlausibleFruit) {
  const ServoConfig c = defaults();
  FruitLedger l = ledger();
  View v;
  v.add(7, {-0.5, 1.0, -0.25}, 2.0f).add(5, {-0.4, 1.0, -0.25}, 1.0f).add(4, {-0.3, 1.0, -0.25}, 1.0f);
  const Selection s = select_fruit(c, v.msg, l, kHome, 42);
  ASSERT_TRUE(s.fruit.has_value());
  EXPECT_EQ(s.fruit->id, 4);
  EXPECT_EQ(s.fruit->selected_at, 42);
  EXPECT_FALSE(s.fruit->depth_doubtful);
  EXPECT_DOUBLE_EQ(s.fruit->diameter, 0.075f);
  EXPECT_TRUE(s.fruit->sight.has_value());
  EXPECT_TRUE(s.rejected.empty());
  EXPECT_EQ(l.attempts(4), 0);  // the attempt is the caller's to count
}

TEST(SelectFruit, UntriedFruitComeBeforeAFailedOneAndPlausibleDepthsBeforeDoubtfulOnes) {
  const ServoConfig c = defaults();
  FruitLedger l = ledger();
  l.begin_attempt(1);  // tried once and failed
  View v;
  v.add(1, {-0.5, 1.0, -0.25}, 0.1f);
  // Far beyond the workspace along its line of sight: doubtful, aimed along the line.
  const Eigen::Vector3d far = kCamera + 3.0 * (Eigen::Vector3d(-0.3, 1.1, -0.25) - kCamera);
  v.add(2, far, 0.2f);
  v.add(3, {-0.4, 1.1, -0.25}, 0.3f);
  EXPECT_EQ(select_fruit(c, v.msg, l, kHome, 0).fruit->id, 3);
  View without3;  // the failed one listed last: the order of the view does not matter
  without3.add(2, far, 0.2f).add(1, {-0.5, 1.0, -0.25}, 0.1f);
  const Selection s = select_fruit(c, without3.msg, l, kHome, 0);
  ASSERT_TRUE(s.fruit.has_value());
  EXPECT_EQ(s.fruit->id, 2);
  EXPECT_TRUE(s.fruit->depth_doubtful);
  EXPECT_TRUE(pickable(c, s.fruit->estimate));
  const SightLine& line = *s.fruit->sight;
  const double along = (s.fruit->estimate - line.origin).dot(line.direction);
  EXPECT_LT((line.at(along) - s.fruit->estimate).norm(), 1e-9);  // on the line of sight
  EXPECT_EQ(s.fruit->selected_from, far);
}

// fruit_order travel: among fruit of equal standing, the one whose aim from
// home is the smallest turn from where the tool points; cost: the detector's.
TEST(SelectFruit, ByTravelTheSmallestTurnFromTheToolComesFirst) {
  ServoConfig c = defaults();
  ASSERT_EQ(c.fruit_order, "travel");
  const Eigen::Vector3d nearly_ahead(-0.6, 1.0, -0.25), aside(-0.3, 1.0, -0.25);
  View v;
  v.add(7, nearly_ahead, 2.0f).add(4, aside, 1.0f);
  FruitLedger l = ledger();
  const Eigen::Matrix3d at_home = c.home_pose.linear();
  EXPECT_EQ(select_fruit(c, v.msg, l, kHome, 0, at_home).fruit->id, 7);
  // Turned toward the other one (the end of its retreat): that one is the shorter way.
  Eigen::Isometry3d home = c.home_pose;
  home.translation() = kHome;
  const Eigen::Matrix3d toward_aside = aim_rotation(home, aside + Eigen::Vector3d(0.05, 0.0, 0.0));
  EXPECT_EQ(select_fruit(c, v.msg, l, kHome, 0, toward_aside).fruit->id, 4);
  // Without the tool's orientation, or ordered by cost: the cheaper one.
  EXPECT_EQ(select_fruit(c, v.msg, l, kHome, 0).fruit->id, 4);
  c.fruit_order = "cost";
  EXPECT_EQ(select_fruit(c, v.msg, l, kHome, 0, at_home).fruit->id, 4);
  // Attempts still come first.
  c.fruit_order = "travel";
  l.begin_attempt(7);
  EXPECT_EQ(select_fruit(c, v.msg, l, kHome, 0, at_home).fruit->id, 4);
}

TEST(SelectFruit, ATargetOutOfReachAlongItsWholeLineOfSightIsUnreachableForGood) {
  const ServoConfig c = defaults();
  FruitLedger l = ledger();
  View v;
  v.add(6, {-0.5, -0.5, -0.25});  // behind the camera from the tree: no pickable point on its line
  const Selection s = select_fruit(c, v.msg, l, kHome, 0);
  EXPECT_FALSE(s.fruit.has_value());
  ASSERT_EQ(s.rejected.size(), 1u);
  EXPECT_EQ(s.rejected[0].fruit_id, 6);
  EXPECT_EQ(s.rejected[0].outcome, +fruit_outcome_t::UNREACHABLE);
  EXPECT_EQ(s.rejected[0].detail, "out of reach along its whole line of sight");
  EXPECT_TRUE(l.finished(6));
  EXPECT_TRUE(select_fruit(c, v.msg, l, kHome, 0).rejected.empty());  // recorded once
}

TEST(SelectFruit, WithoutTheCameraPoseTheEstimateIsAllThereIs) {
  const ServoConfig c = defaults();
  FruitLedger l = ledger();
  View v;
  v.msg.camera_known = false;
  v.add(1, {0.2, 1.6, -0.3}).add(2, {-0.5, 0.6, -0.25}).add(3, {-0.5, 1.0, -0.25});
  const Selection s = select_fruit(c, v.msg, l, kHome, 0);
  ASSERT_EQ(s.rejected.size(), 2u);
  EXPECT_EQ(s.rejected[0].detail, "outside the reachable workspace");
  EXPECT_EQ(s.rejected[1].detail, "not ahead of the gripper at home");
  ASSERT_TRUE(s.fruit.has_value());
  EXPECT_EQ(s.fruit->id, 3);
  EXPECT_FALSE(s.fruit->sight.has_value());
}

TEST(SelectFruit, NothingSelectableIsNoFruit) {
  const ServoConfig c = defaults();
  FruitLedger l = ledger();
  View v;
  v.add(1, {-0.5, 1.0, -0.25});
  l.use_up_attempts(1);
  EXPECT_FALSE(select_fruit(c, v.msg, l, kHome, 0).fruit.has_value());
  EXPECT_FALSE(select_fruit(c, View().msg, l, kHome, 0).fruit.has_value());
}

}  // namespace
}  // namespace harvest::servo
