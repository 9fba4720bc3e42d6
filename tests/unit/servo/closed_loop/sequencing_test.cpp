// Closed-loop tests (closed_loop/loop.hpp): the way from one fruit to the next
// (straight_to_next) and the end of the release (release_opening).
#include <gtest/gtest.h>

#include <algorithm>
#include <string>
#include <vector>

#include "closed_loop/loop.hpp"
#include "servo/geometry.hpp"

namespace harvest::servo::testing {
namespace {

// Two fruit of experiment I's kind, the fixed camera exact: the aims are known.
WorldSpec two_fruit() {
  WorldSpec spec = experiment_one();
  spec.fixed_error.setZero();
  spec.fruits = {{1, {-0.2667, 1.0160, -0.5402}, 0.075}, {2, {-0.0686, 1.1684, -0.3751}, 0.075}};
  return spec;
}

// When each state in `states` was first published.
rt::Micros first_published(const Loop& loop, const std::string& state, rt::Micros after = 0) {
  for (const auto& [time, st] : loop.bus.messages<harvest_status_t>(ch::kHarvestStatus))
    if (time > after && st.state == state) return time;
  return 0;
}

// The state published right after the first `state`.
std::string after_first(const std::vector<std::string>& states, const std::string& state) {
  const auto it = std::find(states.begin(), states.end(), state);
  return it == states.end() || it + 1 == states.end() ? "" : *(it + 1);
}

// After a pick the next fruit is selected at the end of the retreat, and
// ORIENT goes from there to its aim from home (the tool at home's position,
// the gripper axis on the fruit): no stop at home, no SELECT in between.
TEST(ClosedLoopSequencing, TheNextFruitIsTurnedToStraightFromTheEndOfTheRetreat) {
  Loop loop(two_fruit());
  ASSERT_TRUE(loop.cfg.straight_to_next);
  loop.start();
  ASSERT_TRUE(loop.run_until_state(State::kRetreat, 30.0)) << loop.ctrl.machine().summary();
  ASSERT_TRUE(loop.run_until_state(State::kAcquire, 30.0)) << loop.ctrl.machine().summary();
  const int second = loop.ctrl.machine().current_fruit();
  ASSERT_TRUE(second == 1 || second == 2);
  const Eigen::Isometry3d tool = loop.arm.tool();
  EXPECT_LT((tool.translation() - loop.cfg.home_pose.translation()).norm(), 0.006);
  const Eigen::Vector3d fruit = loop.spec.fruits[second == 1 ? 0 : 1].position;
  const Eigen::Vector3d to = (fruit - tool.translation()).normalized();
  EXPECT_LT(std::acos(std::clamp(tool.linear().col(2).dot(to), -1.0, 1.0)), 0.03);
  ASSERT_TRUE(loop.run_until_state(State::kDone, 60.0)) << loop.ctrl.machine().summary();
  EXPECT_TRUE(loop.world.fruit_picked(1));
  EXPECT_TRUE(loop.world.fruit_picked(2));
  const auto states = published_states(loop);
  EXPECT_EQ(after_first(states, "RETREAT"), "ORIENT");
  // Home once, at the end: nothing left to select from the end of the last retreat.
  EXPECT_EQ(std::count(states.begin(), states.end(), "RETURN"), 1);
  EXPECT_EQ(std::count(states.begin(), states.end(), "SELECT"), 2);  // the first fruit and the end
  expect_within_limits(loop);
  expect_motion_stopped(loop);
}

// turn_while_retreating: the way out after the first fruit turns the gripper to the second one's aim as it
// backs out, so the retreat ends aimed at it and ORIENT has only the rest of the way to home's position to do.
// Only while the fixed camera sees the tree still (turn_in_wind false): with both fruit swaying the way out does
// not turn, unless turn_in_wind.
TEST(ClosedLoopSequencing, TurningWhileRetreatingEndsTheRetreatAimedAtTheNextFruit) {
  struct Aimed {
    double angle_at_orient;  // [rad] the gripper axis off the second fruit (the middle of its sway) as ORIENT begins
    double orient_s;         // ORIENT's duration
  };
  const auto run = [](bool turn, bool wind, bool turn_in_wind) {
    ServoConfig cfg = test_config();
    cfg.turn_while_retreating = turn;
    cfg.turn_in_wind = turn_in_wind;
    cfg.sway.tree_min_fruit = 1;  // two fruit on this tree: the gauge tells from what it has
    WorldSpec spec = two_fruit();
    if (wind) {
      for (auto& f : spec.fruits) {
        f.sway = Eigen::Vector3d(0.02, 0.0, 0.0);
        f.sway_hz = 0.4;
      }
    }
    Loop loop(spec, cfg);
    loop.start();
    EXPECT_TRUE(loop.run_until_state(State::kRetreat, 30.0)) << loop.ctrl.machine().summary();
    EXPECT_TRUE(loop.run_until_state(State::kOrient, 30.0)) << loop.ctrl.machine().summary();
    const int second = loop.ctrl.machine().current_fruit();
    const Eigen::Isometry3d tool = loop.arm.tool();
    const Eigen::Vector3d fruit = loop.spec.fruits[second == 1 ? 0 : 1].position;
    const Eigen::Vector3d to = (fruit - tool.translation()).normalized();
    const double angle = std::acos(std::clamp(tool.linear().col(2).dot(to), -1.0, 1.0));
    const rt::Micros orient_at = first_published(loop, "ORIENT", first_published(loop, "RETREAT"));
    EXPECT_TRUE(loop.run_until_state(State::kDone, 60.0)) << loop.ctrl.machine().summary();
    if (!wind) {
      EXPECT_TRUE(loop.world.fruit_picked(1));
      EXPECT_TRUE(loop.world.fruit_picked(2));
    }
    expect_within_limits(loop);
    expect_motion_stopped(loop);
    return Aimed{angle, rt::to_seconds(first_published(loop, "ACQUIRE", orient_at) - orient_at)};
  };
  const Aimed off = run(false, false, false), on = run(true, false, false);
  EXPECT_GT(off.angle_at_orient, 0.15);  // the two aims are ~0.3 rad apart
  EXPECT_LT(on.angle_at_orient, 0.05);
  EXPECT_LT(on.orient_s, off.orient_s - 0.2) << "ORIENT " << on.orient_s << " s against " << off.orient_s << " s";
  const Aimed windy = run(true, true, false), windy_turned = run(true, true, true);
  EXPECT_GT(windy.angle_at_orient, 0.15) << "in wind the way out does not turn";
  EXPECT_LT(windy_turned.angle_at_orient, 0.05) << "... unless turn_in_wind";
}

// straight_to_next: false is the thesis's sequence, home between fruit; the
// same tree takes longer.
TEST(ClosedLoopSequencing, WithoutItTheArmReturnsHomeBetweenFruitAndTakesLonger) {
  Loop straight(two_fruit());
  straight.start();
  ASSERT_TRUE(straight.run_until_state(State::kDone, 90.0));
  ServoConfig cfg = test_config();
  cfg.straight_to_next = false;
  Loop thesis(two_fruit(), cfg);
  thesis.start();
  ASSERT_TRUE(thesis.run_until_state(State::kDone, 90.0)) << thesis.ctrl.machine().summary();
  EXPECT_TRUE(thesis.world.fruit_picked(1));
  EXPECT_TRUE(thesis.world.fruit_picked(2));
  const auto states = published_states(thesis);
  EXPECT_EQ(after_first(states, "RETREAT"), "RETURN");
  EXPECT_EQ(std::count(states.begin(), states.end(), "RETURN"), 2);
  EXPECT_EQ(std::count(states.begin(), states.end(), "SELECT"), 3);
  const double t_straight = rt::to_seconds(first_published(straight, "DONE") - kT0);
  const double t_thesis = rt::to_seconds(first_published(thesis, "DONE") - kT0);
  EXPECT_LT(t_straight, t_thesis - 0.5) << "straight " << t_straight << " s, thesis " << t_thesis << " s";
}

// After an approach during which the robot link reported a joint at its limit
// (kFlagJointLimit), the next fruit waits for a trip home, where the link
// returns to the home posture (on the tree the arm's redundancy drifted into a
// branch with the shoulder roll at its limit and stalled approach after
// approach); the flag is cleared there, so only one extra trip per episode.
TEST(ClosedLoopSequencing, AJointAtItsLimitGoingInSendsTheArmHomeBeforeTheNextFruit) {
  WorldSpec spec = two_fruit();
  spec.arm_joint_limit_in_twists = true;
  Loop loop(spec);
  loop.start();
  ASSERT_TRUE(loop.run_until_state(State::kDone, 90.0)) << loop.ctrl.machine().summary();
  EXPECT_TRUE(loop.world.fruit_picked(1));
  EXPECT_TRUE(loop.world.fruit_picked(2));
  const auto states = published_states(loop);
  EXPECT_EQ(after_first(states, "RETREAT"), "RETURN");
  EXPECT_EQ(std::count(states.begin(), states.end(), "RETURN"), 2);
  EXPECT_EQ(std::count(states.begin(), states.end(), "SELECT"), 3);

  ServoConfig cfg = test_config();
  cfg.home_after_joint_limit = false;
  Loop off(spec, cfg);
  off.start();
  ASSERT_TRUE(off.run_until_state(State::kDone, 90.0)) << off.ctrl.machine().summary();
  EXPECT_EQ(after_first(published_states(off), "RETREAT"), "ORIENT");
}

// The trip home clears it: a joint limit met on the first fruit only sends
// the arm home once; from the second fruit on it turns straight again.
TEST(ClosedLoopSequencing, TheTripHomeClearsTheJointLimitMet) {
  WorldSpec spec = two_fruit();
  spec.fruits.push_back({3, {-0.4126, 1.0114, -0.5289}, 0.075});
  spec.arm_joint_limit_in_twists = true;
  Loop loop(spec);
  loop.start();
  ASSERT_TRUE(loop.run_until_state(State::kGrasp, 30.0)) << loop.ctrl.machine().summary();
  loop.spec.arm_joint_limit_in_twists = false;  // the arm double reads the loop's spec
  ASSERT_TRUE(loop.run_until_state(State::kDone, 120.0)) << loop.ctrl.machine().summary();
  for (int id : {1, 2, 3}) EXPECT_TRUE(loop.world.fruit_picked(id)) << id;
  const auto states = published_states(loop);
  std::vector<std::string> after_retreats;
  for (std::size_t i = 0; i + 1 < states.size(); ++i)
    if (states[i] == "RETREAT") after_retreats.push_back(states[i + 1]);
  ASSERT_EQ(after_retreats.size(), 3u);
  EXPECT_EQ(after_retreats[0], "RETURN");  // the limit met going in: home first
  EXPECT_EQ(after_retreats[1], "ORIENT");  // cleared at home: straight on
  EXPECT_EQ(after_retreats[2], "RETURN");  // nothing left
}

// A fruit given up before the gripper went in (not seen by the camera-in-hand)
// leaves the tool out of the canopy, near home: the next fruit is turned to
// from there too, not from home.
TEST(ClosedLoopSequencing, AFruitGivenUpBeforeGoingInIsFollowedStraightByTheNext) {
  WorldSpec spec = two_fruit();
  spec.hide_hand_after_s = 0.0;
  spec.hide_hand_for_s = 4.0;  // the first fruit's ACQUIRE (3 s) sees nothing
  Loop loop(spec);
  loop.start();
  ASSERT_TRUE(loop.run_until_state(State::kDone, 90.0)) << loop.ctrl.machine().summary();
  const auto states = published_states(loop);
  ASSERT_GE(states.size(), 5u);
  EXPECT_EQ(after_first(states, "ACQUIRE"), "ORIENT");
  const auto& outcomes = loop.ctrl.machine().outcomes();
  ASSERT_EQ(outcomes.size(), 2u);
  EXPECT_EQ(outcomes[0].outcome, +fruit_outcome_t::LOST);
  EXPECT_EQ(outcomes[1].outcome, +fruit_outcome_t::PICKED);
  expect_within_limits(loop);
}

// The gripper takes 0.6 s to open: with release_opening 0.5 RELEASE ends
// once it reports OPENING half open (the fruit is free), with 1 only at OPEN.
// (RELEASE at rest: release_while_retreating off.)
TEST(ClosedLoopSequencing, ReleaseEndsOnceTheGripperHasOpenedReleaseOpeningOfTheWay) {
  for (const double opening : {0.5, 1.0}) {
    WorldSpec spec = experiment_one();
    spec.gripper_open_s = 0.6;
    ServoConfig cfg = test_config();
    cfg.release_while_retreating = false;
    cfg.release_opening = opening;
    Loop loop(spec, cfg);
    loop.start();
    ASSERT_TRUE(loop.run_until_state(State::kDone, 60.0)) << loop.ctrl.machine().summary();
    EXPECT_EQ(loop.outcome(1)->outcome, +fruit_outcome_t::PICKED);
    EXPECT_TRUE(loop.world.fruit_picked(1));
    const rt::Micros release = first_published(loop, "RELEASE");
    const rt::Micros retreat = first_published(loop, "RETREAT", release);
    ASSERT_GT(release, 0);
    ASSERT_GT(retreat, 0);
    const double dwell = rt::to_seconds(retreat - release);
    // The gripper reports every 50 ms.
    if (opening < 1.0) {
      EXPECT_GE(dwell, 0.3 - 1e-6) << opening;
      EXPECT_LE(dwell, 0.4) << opening;
    } else {
      EXPECT_GE(dwell, 0.6 - 1e-6) << opening;
    }
  }
}

}  // namespace
}  // namespace harvest::servo::testing
