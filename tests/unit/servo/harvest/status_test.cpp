#include "servo/harvest/status.hpp"

#include <gtest/gtest.h>

#include <set>
#include <string>

namespace harvest::servo {
namespace {

TEST(Status, SummaryLineSaysStateFlagsFruitTalliesAndTheLatestNote) {
  FruitLedger l({2, 0.05, 0.02, 0.15});
  l.record(fruit_outcome_t::PICKED, 1, Eigen::Vector3d::Zero(), "", 4.0, Eigen::Vector3d::Zero(), nullptr);
  l.record(fruit_outcome_t::LOST, 2, Eigen::Vector3d::Zero(), "x", 4.0, Eigen::Vector3d::Zero(), nullptr);
  EXPECT_EQ(summary_line({State::kApproach, true, false, 3, "resumed"}, l.tally()),
            "APPROACH (paused) fruit 3 | picked 1, lost 1, unreachable 0, failed grasp 0, aborted 0 | resumed");
  EXPECT_EQ(summary_line({State::kEstop, false, true, std::nullopt, ""}, l.tally()),
            "ESTOP [E-STOP latched] | picked 1, lost 1, unreachable 0, failed grasp 0, aborted 0");
}

TEST(Status, MessageCountsTheFruitLeftAndCarriesOnlyTheNewestOutcomes) {
  FruitLedger l({1, 0.05, 0.02, 0.15});
  for (int i = 0; i < 60; ++i) {
    l.begin_attempt(100 + i);
    l.record(fruit_outcome_t::LOST, 100 + i, Eigen::Vector3d::Zero(), "", 1.0, Eigen::Vector3d::Zero(), nullptr);
  }
  targets_t fixed{};
  for (int id : {100, 5, 6, 7}) {  // 100 is finished (out of attempts), 6 is the current fruit
    target_t t{};
    t.fruit_id = id;
    fixed.targets.push_back(t);
  }
  robot_state_t robot{};
  robot.header.utime = 77;
  robot.header.seq = 8;
  const harvest_status_t s = status_message({State::kApproach, false, false, 6, ""}, l, &fixed, &robot);
  EXPECT_EQ(s.state, "APPROACH");
  EXPECT_EQ(s.current_fruit_id, 6);
  EXPECT_EQ(s.remaining, 2);
  EXPECT_EQ(s.lost, 60);
  ASSERT_EQ(s.num_outcomes, 50);
  EXPECT_EQ(s.outcomes.front().fruit_id, 110);
  EXPECT_EQ(s.outcomes.back().fruit_id, 159);
  EXPECT_EQ(s.header.utime, 77);
  EXPECT_EQ(s.header.source_seq, 8);
  const harvest_status_t none = status_message({}, FruitLedger({}), nullptr, nullptr);
  EXPECT_EQ(none.current_fruit_id, -1);
  EXPECT_EQ(none.remaining, 0);
  EXPECT_EQ(none.header.source_seq, -1);
  EXPECT_EQ(none.state, "IDLE");
}

// Every depth source has its own words in the IR-guidance note (tools and docs quote them).
TEST(Status, EveryDepthSourceIsNamedApart) {
  std::set<std::string> seen;
  for (const auto d : {Fruit::Depth::kSize, Fruit::Depth::kConfirmed, Fruit::Depth::kCrossing, Fruit::Depth::kNear,
                       Fruit::Depth::kFixed})
    EXPECT_TRUE(seen.insert(depth_source(d)).second) << depth_source(d);
  EXPECT_STREQ(depth_source(Fruit::Depth::kConfirmed), "depth from size, confirmed by the rays' crossing");
}

}  // namespace
}  // namespace harvest::servo
