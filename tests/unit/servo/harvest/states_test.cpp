#include "servo/harvest/states.hpp"

#include <gtest/gtest.h>

#include <set>
#include <string>

namespace harvest::servo {
namespace {

constexpr State kAll[] = {State::kIdle,      State::kSelect,     State::kOrient,  State::kAcquire, State::kApproach,
                          State::kReacquire, State::kIrApproach, State::kBackoff, State::kGrasp,   State::kDetach,
                          State::kDrop,      State::kRelease,    State::kRetreat, State::kReturn,  State::kHoming,
                          State::kDone,      State::kFault,      State::kEstop};

TEST(StateTable, NamesAreThePublishedOnesAndUnique) {
  std::set<std::string> names;
  for (State s : kAll) names.insert(state_name(s));
  EXPECT_EQ(names.size(), std::size(kAll));
  EXPECT_STREQ(state_name(State::kIrApproach), "IR_APPROACH");
  EXPECT_STREQ(state_name(State::kEstop), "ESTOP");
}

// A harvest never waits forever: every state of a running harvest has a
// timeout, and says what its expiry leads to.
TEST(StateTable, EveryRunningStateIsBoundedInTime) {
  for (State s : kAll) {
    const StateSpec& row = spec(s);
    EXPECT_EQ(row.state, s);
    if (row.running) {
      EXPECT_NE(row.timeout, nullptr) << row.name;
      EXPECT_NE(row.expiry, Expiry::kNone) << row.name;
    } else {
      EXPECT_EQ(row.timeout, nullptr) << row.name;
      EXPECT_EQ(row.expiry, Expiry::kNone) << row.name;
    }
    // A pose goal (or the turn of ORIENT_PD) that does not complete is judged by motion_blocked; a
    // fruit given up on a timeout gets an outcome with a reason.
    if (row.motion == Motion::kPoseGoal || s == State::kOrientPd) {
      EXPECT_EQ(row.expiry, Expiry::kMotionBlocked) << row.name;
    }
    if (row.expiry == Expiry::kGiveUp || row.expiry == Expiry::kGiveUpRetreat || row.expiry == Expiry::kIrAttempt) {
      EXPECT_NE(row.outcome, +fruit_outcome_t::PICKED) << row.name;
      EXPECT_STRNE(row.detail, "") << row.name;
    }
  }
}

TEST(StateTable, OnlyTheApproachStatesFollowTheFruitAndOnlyIdleAndDoneRest) {
  std::set<State> follows, rests, twists;
  for (State s : kAll) {
    if (spec(s).follows_fruit) follows.insert(s);
    if (spec(s).rests) rests.insert(s);
    if (spec(s).motion == Motion::kTwist) twists.insert(s);
  }
  EXPECT_EQ(follows, (std::set<State>{State::kAcquire, State::kApproach, State::kReacquire, State::kIrApproach}));
  EXPECT_EQ(rests, (std::set<State>{State::kIdle, State::kDone}));
  // GRASP goes on along the axis while the fingers close: a twist state too.
  EXPECT_EQ(twists,
            (std::set<State>{State::kAcquire, State::kApproach, State::kReacquire, State::kIrApproach, State::kGrasp}));
  EXPECT_TRUE(keeps_twist(State::kApproach, State::kReacquire));
  EXPECT_TRUE(keeps_twist(State::kIrApproach, State::kGrasp));
  EXPECT_FALSE(keeps_twist(State::kOrient, State::kAcquire));
  EXPECT_FALSE(keeps_twist(State::kGrasp, State::kDetach));
}

TEST(StateTable, TimeoutsAreTheDocumentedKeys) {
  Timeouts t;
  t.select = 1;
  t.motion = 2;
  t.acquire = 3;
  t.approach = 4;
  t.reacquire = 5;
  t.ir_approach = 6;
  t.grasp = 7;
  t.release = 8;
  auto of = [&](State s) { return t.*spec(s).timeout; };
  EXPECT_EQ(of(State::kSelect), 1);
  for (State s :
       {State::kOrient, State::kBackoff, State::kDetach, State::kDrop, State::kRetreat, State::kReturn, State::kHoming})
    EXPECT_EQ(of(s), 2) << state_name(s);
  EXPECT_EQ(of(State::kAcquire), 3);
  EXPECT_EQ(of(State::kApproach), 4);
  EXPECT_EQ(of(State::kReacquire), 5);
  EXPECT_EQ(of(State::kIrApproach), 6);
  EXPECT_EQ(of(State::kGrasp), 7);
  EXPECT_EQ(of(State::kRelease), 8);
}

}  // namespace
}  // namespace harvest::servo
