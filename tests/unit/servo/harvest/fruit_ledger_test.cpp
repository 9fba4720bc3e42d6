#include "servo/harvest/fruit_ledger.hpp"

#include <gtest/gtest.h>

namespace harvest::servo {
namespace {

const Eigen::Vector3d kTool(0.0, 0.5, 0.0);
const Eigen::Vector3d kAt(0.0, 1.0, 0.0);

Fruit fruit(int id, const Eigen::Vector3d& at, std::optional<Eigen::Vector3d> sight = std::nullopt) {
  Fruit f;
  f.id = id;
  f.estimate = at;
  f.selected_from = at;
  if (sight) {
    SightLine l;
    l.direction = sight->normalized();
    f.sight = l;
  }
  return f;
}

void fail(FruitLedger& l, const Fruit& f) {
  l.begin_attempt(f.id);
  l.record(fruit_outcome_t::FAILED_GRASP, f.id, f.estimate, "missed", 1.0, kTool, &f);
}

TEST(FruitLedger, AFailedFruitIsTriedUntilItsAttemptsAreUsedUp) {
  FruitLedger l({2, 0.05, 0.02, 0.15});
  const Fruit f = fruit(3, kAt);
  EXPECT_TRUE(l.selectable(3, kAt, std::nullopt));
  fail(l, f);
  EXPECT_EQ(l.attempts(3), 1);
  EXPECT_TRUE(l.selectable(3, kAt, std::nullopt));
  EXPECT_FALSE(l.finished(3));
  fail(l, f);
  EXPECT_TRUE(l.out_of_attempts(3));
  EXPECT_TRUE(l.finished(3));
  EXPECT_FALSE(l.selectable(3, kAt, std::nullopt));
  EXPECT_EQ(l.tally().failed_grasp, 2);
  ASSERT_EQ(l.outcomes().size(), 2u);
  EXPECT_EQ(l.outcomes()[1].detail, "missed");
  EXPECT_DOUBLE_EQ(l.outcomes()[1].final_tool_position[1], 0.5);
}

TEST(FruitLedger, AFruitGivenUpIsNotTakenForNewUnderANewIdNearby) {
  FruitLedger l({1, 0.05, 0.02, 0.15});
  fail(l, fruit(3, kAt));
  // The tracker renumbered it: 4 cm from where it was given up is the same fruit ...
  EXPECT_FALSE(l.selectable(8, kAt + Eigen::Vector3d(0.04, 0, 0), std::nullopt));
  EXPECT_TRUE(l.finished(8));
  // ... 6 cm away another one.
  EXPECT_TRUE(l.selectable(9, kAt + Eigen::Vector3d(0.06, 0, 0), std::nullopt));
}

// A fruit that failed once and was renumbered before its second attempt
// (the arm hid it from the fixed camera): the new id near where it failed,
// or along its line of sight, carries its attempt, so the second failure
// gives it up for good; an id 6 cm away is another fruit with its own two.
TEST(FruitLedger, ARenumberedFruitKeepsItsAttempts) {
  FruitLedger l({2, 0.05, 0.02, 0.15});
  const Eigen::Vector3d sight(0.0, 1.0, 0.0);
  fail(l, fruit(3, kAt, sight));
  const Eigen::Vector3d moved = kAt + Eigen::Vector3d(0.03, 0, 0);
  EXPECT_TRUE(l.selectable(8, moved, std::nullopt));
  EXPECT_EQ(l.attempts(8), 1);
  fail(l, fruit(8, moved));
  EXPECT_TRUE(l.finished(8));
  EXPECT_FALSE(l.selectable(9, kAt, std::nullopt));  // given up: under any new id
  // Along the first failure's line of sight, its depth 20 cm off: the same fruit, one attempt made.
  FruitLedger s({2, 0.05, 0.02, 0.15});
  fail(s, fruit(3, kAt, sight));
  EXPECT_TRUE(s.selectable(8, kAt + 0.2 * sight, sight));
  EXPECT_EQ(s.attempts(8), 1);
  EXPECT_TRUE(s.selectable(9, kAt + Eigen::Vector3d(0.06, 0, 0), std::nullopt));
  EXPECT_EQ(s.attempts(9), 0);
}

TEST(FruitLedger, AFruitGivenUpIsRecognisedByItsLineOfSightWhenItsDepthJumps) {
  FruitLedger l({1, 0.05, 0.02, 0.15});
  const Eigen::Vector3d sight(0.0, 1.0, 0.0);
  fail(l, fruit(3, kAt, sight));
  // 30 cm deeper along the same line of sight (0.01 rad off): the same fruit.
  const Eigen::Vector3d deeper = 1.3 * Eigen::Vector3d(std::sin(0.01), std::cos(0.01), 0.0);
  EXPECT_FALSE(l.selectable(8, deeper, deeper.normalized()));
  // 0.03 rad off: another fruit.
  const Eigen::Vector3d beside = 1.3 * Eigen::Vector3d(std::sin(0.03), std::cos(0.03), 0.0);
  EXPECT_TRUE(l.selectable(9, beside, beside.normalized()));
}

TEST(FruitLedger, AFinishedIdSeenFarFromWhereItFinishedIsAnotherFruit) {
  FruitLedger l({1, 0.05, 0.02, 0.15});
  fail(l, fruit(3, kAt, Eigen::Vector3d(0.0, 1.0, 0.0)));
  EXPECT_FALSE(l.selectable(3, kAt + Eigen::Vector3d(0.10, 0, 0), std::nullopt));  // within 15 cm: itself
  // 20 cm away, along another line of sight: the tracker passed the id on.
  const Eigen::Vector3d other = kAt + Eigen::Vector3d(0.2, 0, 0);
  EXPECT_TRUE(l.selectable(3, other, other.normalized()));
  EXPECT_FALSE(l.finished(3));
  EXPECT_EQ(l.attempts(3), 0);
}

TEST(FruitLedger, APickedIdMayBeTriedAgain) {
  FruitLedger l({1, 0.05, 0.02, 0.15});
  const Fruit f = fruit(3, kAt);
  l.begin_attempt(3);
  l.record(fruit_outcome_t::PICKED, 3, kAt, "", 4.0, kTool, &f);
  EXPECT_EQ(l.attempts(3), 0);
  EXPECT_FALSE(l.finished(3));
  EXPECT_TRUE(l.selectable(3, kAt, std::nullopt));  // still seen: a fruit still there
  EXPECT_EQ(l.tally().picked, 1);
}

TEST(FruitLedger, ACertainVerdictUsesUpEveryAttempt) {
  FruitLedger l({3, 0.05, 0.02, 0.15});
  l.use_up_attempts(5);
  l.record(fruit_outcome_t::UNREACHABLE, 5, kAt, "out of reach", 0.0, kTool, nullptr);
  EXPECT_TRUE(l.finished(5));
  EXPECT_FALSE(l.selectable(5, kAt, std::nullopt));
  EXPECT_EQ(l.tally().unreachable, 1);
}

TEST(FruitLedger, TalliesCountEveryOutcome) {
  FruitLedger l({5, 0.05, 0.02, 0.15});
  for (int8_t o : {fruit_outcome_t::PICKED, fruit_outcome_t::LOST, fruit_outcome_t::LOST, fruit_outcome_t::UNREACHABLE,
                   fruit_outcome_t::FAILED_GRASP, fruit_outcome_t::ABORTED})
    l.record(o, 1, kAt, "", 0.0, kTool, nullptr);
  const Tally& t = l.tally();
  EXPECT_EQ(t.picked, 1);
  EXPECT_EQ(t.lost, 2);
  EXPECT_EQ(t.unreachable, 1);
  EXPECT_EQ(t.failed_grasp, 1);
  EXPECT_EQ(t.aborted, 1);
  EXPECT_STREQ(outcome_name(fruit_outcome_t::FAILED_GRASP), "failed grasp");
}

}  // namespace
}  // namespace harvest::servo
