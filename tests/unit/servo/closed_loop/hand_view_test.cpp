// Closed-loop tests (closed_loop/loop.hpp): Following the fruit in the camera-in-hand image: acquiring it, losing it,
// its depth from the apparent size and from where the two cameras' rays cross.
#include <gtest/gtest.h>

#include <algorithm>
#include <limits>

#include "closed_loop/loop.hpp"

namespace harvest::servo::testing {
namespace {

TEST(ClosedLoop, FruitNeverSeenByTheHandCameraIsLost) {
  WorldSpec spec = experiment_one();
  spec.hide_hand_after_s = 0.0;
  Loop loop(spec);
  loop.start();
  ASSERT_TRUE(loop.run_until_state(State::kDone, 60.0));
  ASSERT_NE(loop.outcome(1), nullptr);
  EXPECT_EQ(loop.outcome(1)->outcome, +fruit_outcome_t::LOST);
  EXPECT_FALSE(loop.world.close_position().has_value());
  // Not retried forever: one attempt, then done.
  EXPECT_EQ(loop.ctrl.machine().outcomes().size(), 1u);
  expect_published(loop, 1, fruit_outcome_t::LOST, "not seen by the camera-in-hand");
  expect_motion_stopped(loop);
}

// A long visual approach (IR switch close in) during which the fruit vanishes.
ServoConfig long_visual_approach() {
  ServoConfig c = test_config();
  c.ir_switch_distance = 0.08;
  return c;
}

TEST(ClosedLoop, FruitLostDuringApproachStopsMotionAndGivesUp) {
  WorldSpec spec = experiment_one();
  Loop probe(spec, long_visual_approach());
  probe.start();
  ASSERT_TRUE(probe.run_until_state(State::kApproach, 20.0));
  const double hide = probe.t() + 0.2;

  spec.hide_hand_after_s = hide;
  Loop loop(spec, long_visual_approach());
  loop.start();
  ASSERT_TRUE(loop.run_until_state(State::kReacquire, 20.0));
  // Holding still while re-acquiring: the commanded twist ramps to zero.
  loop.at(loop.t() + 0.8);
  EXPECT_EQ(loop.ctrl.machine().state(), State::kReacquire);
  const auto held = loop.commands_after(loop.t() - 0.1);
  ASSERT_FALSE(held.empty());
  for (const auto& c : held) EXPECT_EQ(linear_speed(c), 0.0);
  ASSERT_TRUE(loop.run_until_state(State::kDone, 60.0));
  EXPECT_EQ(loop.outcome(1)->outcome, +fruit_outcome_t::LOST);
  EXPECT_EQ(loop.outcome(1)->detail, "lost from view, not re-acquired");
  expect_published(loop, 1, fruit_outcome_t::LOST, "lost from view, not re-acquired");
  expect_motion_stopped(loop);
}

TEST(ClosedLoop, FruitBrieflyHiddenIsReacquiredAndPicked) {
  WorldSpec spec = experiment_one();
  Loop probe(spec, long_visual_approach());
  probe.start();
  ASSERT_TRUE(probe.run_until_state(State::kApproach, 20.0));
  spec.hide_hand_after_s = probe.t() + 0.2;
  spec.hide_hand_for_s = 0.8;
  Loop loop(spec, long_visual_approach());
  loop.start();
  ASSERT_TRUE(loop.run_until_state(State::kDone, 60.0));
  EXPECT_EQ(loop.outcome(1)->outcome, +fruit_outcome_t::PICKED);
  bool reacquired = false;
  for (const auto& [time, s] : loop.bus.messages<harvest_status_t>(ch::kHarvestStatus))
    reacquired |= s.state == "REACQUIRE";
  EXPECT_TRUE(reacquired);
  expect_within_limits(loop);
}

TEST(ClosedLoop, ApproachTimeoutGivesTheFruitUpAndRetreats) {
  WorldSpec spec = experiment_one();
  ServoConfig cfg = test_config();
  cfg.timeouts.approach = 0.5;  // far shorter than the approach needs
  Loop loop(spec, cfg);
  loop.start();
  ASSERT_TRUE(loop.run_until_state(State::kDone, 60.0)) << loop.ctrl.machine().summary();
  expect_published(loop, 1, fruit_outcome_t::LOST, "approach timed out");
  const auto states = published_states(loop);
  const auto approach = std::find(states.begin(), states.end(), "APPROACH");
  ASSERT_NE(approach, states.end());
  const std::vector<std::string> expected{"APPROACH", "RETREAT", "RETURN", "SELECT", "DONE"};
  ASSERT_EQ(std::vector<std::string>(approach, states.end()), expected);
  EXPECT_FALSE(loop.world.close_position().has_value());
  expect_motion_stopped(loop);
}

// Near the fruit it fills the hand image and its depth from size is 20 cm
// off: that is not taken as the estimate, so the real IR trigger is not
// mistaken for a leaf (the reference recording failed its grasp so).
TEST(ClosedLoop, HandDepthOfAFruitFillingTheImageIsNotUsed) {
  WorldSpec spec = experiment_one();
  spec.hand_depth_error_when_filling = 0.2;
  ServoConfig cfg = test_config();
  cfg.ir_grasp_range = 0.035;  // as in the simulator sets: the fruit fills the image before the IR triggers
  Loop loop(spec, cfg);
  loop.start();
  ASSERT_TRUE(loop.run_until_state(State::kDone, 60.0)) << loop.ctrl.machine().summary();
  EXPECT_EQ(loop.outcome(1)->outcome, +fruit_outcome_t::PICKED) << loop.outcome(1)->detail;
}

// A leaf hides most of the fruit from the camera-in-hand: its apparent size
// puts it 2.5 times too far, beyond the workspace. Its ray crossed with the
// fixed camera's gives the position without the size, and it is picked: with
// the crossing replacing the size at any range, the grasp is made on the
// crossing; by default (crossing_beyond 0.7 m) only while the size puts the
// fruit that far, and nearer (the size's 2.5 times then inside the
// workspace) on the size, the IR finding the fruit. Without the crossing, the
// fixed camera's estimate along the hand's ray (fixed_depth_gap) places it and
// it is picked; with the size alone (both off) it is measured out of reach.
TEST(ClosedLoop, FruitCutByALeafIsPlacedWhereTheTwoCamerasRaysCross) {
  WorldSpec spec = experiment_one();
  spec.fixed_error.setZero();
  spec.hand_depth_scale = 2.5;
  ServoConfig any_range = test_config();
  any_range.crossing_beyond = 0.0;
  {
    Loop loop(spec, any_range);
    loop.start();
    ASSERT_TRUE(loop.run_until_state(State::kDone, 60.0)) << loop.ctrl.machine().summary();
    expect_published(loop, 1, fruit_outcome_t::PICKED, "");
    // The estimate the grasp was made with: the true centre within a few cm
    // (the size-based one is a metre off).
    EXPECT_LT((estimate_of(*loop.outcome(1)) - spec.fruits[0].position).norm(), 0.03);
    expect_within_limits(loop);
  }
  {
    Loop loop(spec);
    loop.start();
    ASSERT_TRUE(loop.run_until_state(State::kDone, 60.0)) << loop.ctrl.machine().summary();
    expect_published(loop, 1, fruit_outcome_t::PICKED, "");
    EXPECT_TRUE(ever_noted(loop, "depth from the rays' crossing"));  // while far
    expect_within_limits(loop);
  }
  ServoConfig no_crossing = test_config();
  no_crossing.triangulation_gap = 0.0;
  no_crossing.fixed_depth_gap = 0.06;  // off by default
  {
    Loop loop(spec, no_crossing);
    loop.start();
    ASSERT_TRUE(loop.run_until_state(State::kDone, 60.0)) << loop.ctrl.machine().summary();
    // Picked; nearer, the 2.5-times size comes inside the workspace and is taken again: the IR finds the fruit.
    expect_published(loop, 1, fruit_outcome_t::PICKED, "");
    expect_within_limits(loop);
  }
  ServoConfig size_only = no_crossing;
  size_only.fixed_depth_gap = 0.0;
  Loop loop(spec, size_only);
  loop.start();
  ASSERT_TRUE(loop.run_until_state(State::kDone, 60.0)) << loop.ctrl.machine().summary();
  expect_published(loop, 1, fruit_outcome_t::UNREACHABLE, "the camera-in-hand measures it outside the workspace");
}

// The fixed camera's line of sight is 3 cm off (within the gap): the
// crossing is centimetres off too, while the size-based depth (exact here)
// agrees with it. The size is kept: near the fruit it is the better depth.
TEST(ClosedLoop, ASizeDepthConfirmedByTheCrossingIsKept) {
  WorldSpec spec = experiment_one();
  spec.fixed_error = Eigen::Vector3d(0.0, 0.0, 0.03);
  spec.hand_depth_scale = 1.0;
  Loop loop(spec);
  loop.start();
  ASSERT_TRUE(loop.run_until_state(State::kDone, 60.0)) << loop.ctrl.machine().summary();
  expect_published(loop, 1, fruit_outcome_t::PICKED, "");
  EXPECT_LT((estimate_of(*loop.outcome(1)) - spec.fruits[0].position).norm(), 0.01);
  EXPECT_TRUE(ever_noted(loop, "confirmed by the rays' crossing"));
}

// Another fruit's ray does not cross the fixed camera's line of sight: a
// hand detection whose ray passes more than triangulation_gap from it keeps
// its size-based depth (here exact), whatever the crossing says.
TEST(ClosedLoop, RaysThatDoNotMeetGiveNoPosition) {
  WorldSpec spec = experiment_one();  // the fixed camera's estimate is 145 mm off, across its line of sight
  spec.hand_depth_scale = 1.0;
  Loop loop(spec);
  loop.start();
  ASSERT_TRUE(loop.run_until_state(State::kDone, 60.0)) << loop.ctrl.machine().summary();
  expect_published(loop, 1, fruit_outcome_t::PICKED, "");
  EXPECT_LT((estimate_of(*loop.outcome(1)) - spec.fruits[0].position).norm(), 0.01);
}

// Hand images that reach the controller 0.3 s after they were taken (a USB
// camera behind a loaded detector): seen from where the camera was then
// (image_pose_gap), the approach is as quick and as centred as without the
// delay. Seen from the newest pose (image_pose_gap 0) the same run closes
// 9 mm beside the fruit's centre and takes 1.2 s longer.
TEST(ClosedLoop, ALateImageIsSeenFromWhereTheCameraTookIt) {
  ServoConfig cfg = test_config();
  cfg.image_pose_gap = 0.1;    // off by default (docs/servo-controller.md)
  cfg.sway.hold_standoff = 0;  // the delay's sideways error can look like a sway: no holds, times compared
  Loop prompt(experiment_one(), cfg);
  prompt.start();
  ASSERT_TRUE(prompt.run_until_state(State::kDone, 60.0));
  WorldSpec spec = experiment_one();
  spec.hand_latency_s = 0.3;
  Loop late(spec, cfg);
  late.start();
  ASSERT_TRUE(late.run_until_state(State::kDone, 60.0)) << late.ctrl.machine().summary();
  EXPECT_EQ(late.outcome(1)->outcome, +fruit_outcome_t::PICKED);
  ASSERT_TRUE(late.world.closed_offset());
  const Eigen::Vector3d off = *late.world.closed_offset();
  EXPECT_LT(off.head<2>().norm(), 0.004) << "closed " << off.transpose() * 1e3 << " mm off the fruit";
  EXPECT_LT(late.t(), prompt.t() + 1.0);
}

}  // namespace
}  // namespace harvest::servo::testing

namespace harvest::servo::testing {
namespace {

// A FRUIT_HAND the detector calls OK with no image size (a fruit over the image centre would then cover any share
// of it) or a NaN pixel position is refused whole and counted; the fruit is still picked from the good images.
TEST(ClosedLoop, MalformedHandDetectionsAreRefusedAsInvalidInput) {
  Loop loop(experiment_one());
  loop.start();
  ASSERT_TRUE(loop.run_until_state(State::kIrApproach, 30.0));
  fruit_detections_t bad{};
  bad.camera = "hand";
  bad.status = fruit_detections_t::STATUS_OK;
  fruit_t f{};
  f.u_px = 320.0f;
  f.v_px = 240.0f;
  f.diameter_px = 900.0f;
  f.area_px = 1e9f;
  f.bbox_px[2] = 640;
  f.bbox_px[3] = 480;
  bad.fruits = {f};
  bad.num_fruits = 1;
  loop.send(loop.t() + 0.001, ch::kFruitHand, bad);  // image size 0 x 0
  bad.image_width = 640;
  bad.image_height = 480;
  bad.fruits[0].v_px = std::numeric_limits<float>::quiet_NaN();
  loop.send(loop.t() + 0.001, ch::kFruitHand, bad);
  ASSERT_TRUE(loop.run_until_state(State::kDone, 60.0));
  EXPECT_EQ(loop.ctrl.stats().counters.at("invalid_input"), 2);
  ASSERT_NE(loop.outcome(1), nullptr);
  EXPECT_EQ(loop.outcome(1)->outcome, +fruit_outcome_t::PICKED) << loop.outcome(1)->detail;
}

}  // namespace
}  // namespace harvest::servo::testing
