#include "servo/harvest/going_in.hpp"

#include <gtest/gtest.h>

#include <cmath>

#include "arm/fault_flags.hpp"

namespace harvest::servo {
namespace {

// The tool and the camera-in-hand at (0, 0.4, 0), both looking along base +y (no hand-eye offset, no
// distortion), home there too; the fruit `ahead` metres along that axis, inside the workspace up to 0.9 m
// (its box ends at y = 1.3). Defaults otherwise: IR guidance from 0.4572 m, grasp range 15 mm, two IR attempts,
// retreat_distance 0.15 m.
ServoConfig config() {
  ServoConfig c;
  c.hand_camera.dist = {};
  c.home_pose = Eigen::Isometry3d::Identity();
  c.home_pose.linear() = Eigen::AngleAxisd(-M_PI / 2, Eigen::Vector3d::UnitX()).toRotationMatrix();
  c.home_pose.translation() = Eigen::Vector3d(0.0, 0.4, 0.0);
  return c;
}
constexpr rt::Micros kT = 10'000'000;

Eigen::Isometry3d tool_ahead(const ServoConfig& c, double along) {
  Eigen::Isometry3d t = c.home_pose;
  t.translation() += along * t.rotation().col(2);
  return t;
}

Fruit fruit(const ServoConfig& c, double ahead, Fruit::Depth depth = Fruit::Depth::kSize) {
  Fruit f;
  f.id = 7;
  f.estimate = tool_ahead(c, ahead).translation();
  f.depth = depth;
  return f;
}

// The fruit whole in the hand image, 80 px across, `across` metres beside the axis at `depth` (0: at the image
// centre).
fruit_detections_t seen_on_axis(const ServoConfig& c, int64_t utime, double across = 0.0, double depth = 1.0) {
  fruit_t f{};
  f.u_px = static_cast<float>(c.hand_camera.cx + c.hand_camera.fx * across / depth);
  f.v_px = static_cast<float>(c.hand_camera.cy);
  f.diameter_px = 80.0f;
  f.bbox_px[0] = static_cast<int>(f.u_px) - 40;
  f.bbox_px[1] = static_cast<int>(f.v_px) - 40;
  f.bbox_px[2] = f.bbox_px[3] = 80;
  fruit_detections_t m{};
  m.header.utime = utime;
  m.image_width = 640;
  m.image_height = 480;
  m.status = fruit_detections_t::STATUS_OK;
  m.fruits = {f};
  m.num_fruits = 1;
  return m;
}

ir_range_t reading(double range) {
  ir_range_t m{};
  m.validity = ir_range_t::VALID;
  m.range_m = static_cast<float>(range);
  return m;
}

struct Fixture {
  Fixture() = default;
  explicit Fixture(const ServoConfig& c) : cfg(c) {}
  ServoConfig cfg = config();
  GoingIn in{cfg, make_approach(cfg)};
  // The fruit `ahead` of the tool at `along` from home, followed in a hand image taken in at `now`.
  GoingIn::Step approach(double along, double ahead, rt::Micros now = kT, Fruit::Depth depth = Fruit::Depth::kSize) {
    const Eigen::Isometry3d tool = tool_ahead(cfg, along);
    Fruit f = fruit(cfg, along + ahead, depth);
    in.on_hand_detections(seen_on_axis(cfg, now), f, tool, now);
    return in.approach(now, tool, tool, f);
  }
};

TEST(GoingIn, TheFruitNotInTheHandImageIsLost) {
  Fixture x;
  const Fruit f = fruit(x.cfg, 0.6);
  x.in.new_fruit();
  EXPECT_EQ(x.in.approach(kT, x.cfg.home_pose, x.cfg.home_pose, f).action, GoingIn::Step::Action::kLost);
  EXPECT_FALSE(x.in.seen_since(kT, 0));
  // Seen, then not within timeouts.lost (0.3 s): lost again.
  x.in.on_hand_detections(seen_on_axis(x.cfg, 1), f, x.cfg.home_pose, kT);
  EXPECT_TRUE(x.in.seen_since(kT, kT - 1));
  EXPECT_FALSE(x.in.seen_since(kT, kT));  // taken in before `since`
  EXPECT_EQ(x.in.approach(kT + rt::from_seconds(0.31), x.cfg.home_pose, x.cfg.home_pose, f).action,
            GoingIn::Step::Action::kLost);
}

// 0.95 m ahead of home is y = 1.35, beyond the workspace box: out of reach, backed out of the canopy only if the
// tool has gone in more than gone_in_distance (0.075 m) from home. A doubtful depth is not a measurement.
TEST(GoingIn, AFruitMeasuredOutsideTheWorkspaceIsOutOfReachBackingOutOnlyIfTheToolWentIn) {
  Fixture x;
  GoingIn::Step s = x.approach(0.0, 0.95);
  EXPECT_EQ(s.action, GoingIn::Step::Action::kOutOfReach);
  EXPECT_EQ(s.detail, "the camera-in-hand measures it outside the workspace");
  EXPECT_FALSE(s.retreat);
  s = x.approach(0.07, 0.88);
  EXPECT_EQ(s.action, GoingIn::Step::Action::kOutOfReach);
  EXPECT_FALSE(s.retreat);
  s = x.approach(0.08, 0.87);
  EXPECT_EQ(s.action, GoingIn::Step::Action::kOutOfReach);
  EXPECT_TRUE(s.retreat);
  Fixture deeper;  // gone_in_distance 0.1 m instead of 0.075
  deeper.cfg.gone_in_distance = 0.1;
  GoingIn in(deeper.cfg, make_approach(deeper.cfg));
  const Eigen::Isometry3d at = tool_ahead(deeper.cfg, 0.08);
  const Fruit far = fruit(deeper.cfg, 0.95);
  in.on_hand_detections(seen_on_axis(deeper.cfg, 1), far, at, kT);
  EXPECT_FALSE(in.approach(kT, at, at, far).retreat);
  Fixture doubtful;
  const Eigen::Isometry3d home = doubtful.cfg.home_pose;
  Fruit f = fruit(doubtful.cfg, 0.95);
  f.depth_doubtful = true;
  doubtful.in.on_hand_detections(seen_on_axis(doubtful.cfg, 1), f, home, kT);
  EXPECT_EQ(doubtful.in.approach(kT, home, home, f).action, GoingIn::Step::Action::kMove);
}

// Beyond ir_switch_distance (0.4572 m) the strategy servoes forward along the axis; within it IR guidance begins
// from there, named with its distance and depth source, and never advances without a fresh IR reading.
TEST(GoingIn, ServoesToTheSwitchDistanceThenBeginsIrGuidanceThere) {
  Fixture x;
  GoingIn::Step s = x.approach(0.0, 0.6);
  EXPECT_EQ(s.action, GoingIn::Step::Action::kMove);
  EXPECT_GT(s.twist.linear.y(), 0.0);
  EXPECT_NEAR(s.twist.linear.x(), 0.0, 1e-9);
  EXPECT_FALSE(s.note.has_value());
  s = x.approach(0.2, 0.3, kT + 33'000, Fruit::Depth::kConfirmed);
  EXPECT_EQ(s.action, GoingIn::Step::Action::kIrBegins);
  EXPECT_EQ(s.note, "IR guidance from 300 mm (depth from size, confirmed by the rays' crossing)");
  EXPECT_EQ(x.in.ir_start(), tool_ahead(x.cfg, 0.2).translation());
  const Eigen::Isometry3d tool = tool_ahead(x.cfg, 0.2);
  s = x.in.ir(kT + 33'000, tool, tool, fruit(x.cfg, 0.5, Fruit::Depth::kConfirmed));
  EXPECT_EQ(s.action, GoingIn::Step::Action::kMove);
  EXPECT_EQ(s.twist.linear, Eigen::Vector3d::Zero());  // no IR reading yet: never blind
  x.in.on_ir(reading(0.25), kT + 40'000, true);
  s = x.in.ir(kT + 66'000, tool, tool, fruit(x.cfg, 0.5, Fruit::Depth::kConfirmed));
  EXPECT_EQ(s.action, GoingIn::Step::Action::kMove);
  EXPECT_GT(s.twist.linear.y(), 0.0);  // on toward the fruit
}

// The IR reads the fruit at the grasp range (15 mm): close; the grasp then goes on along the axis from where the
// close was told (grasp_advance) at ir_min_speed.
TEST(GoingIn, ClosesWhenTheIrReadsTheFruitInsideThenGraspsOnAlongTheAxis) {
  Fixture x;
  ASSERT_EQ(x.approach(0.4, 0.05).action, GoingIn::Step::Action::kIrBegins);
  const Eigen::Isometry3d tool = tool_ahead(x.cfg, 0.4);
  x.in.on_ir(reading(0.015), kT + 10'000, true);
  const GoingIn::Step s = x.in.ir(kT + 20'000, tool, tool, fruit(x.cfg, 0.45));
  ASSERT_EQ(s.action, GoingIn::Step::Action::kClose);
  const auto forward = x.in.grasp_twist(tool);
  ASSERT_TRUE(forward.has_value());
  EXPECT_NEAR(forward->linear.y(), x.cfg.ir_min_speed, 1e-12);
  EXPECT_FALSE(x.in.grasp_twist(tool_ahead(x.cfg, 0.4 + x.cfg.grasp_advance + 1e-3)).has_value());
}

// grasp_stop_at_joint_limit: a ROBOT_STATE with a joint at its limit, at the close or during it, stops the advance
// (IrGuidance, AJointAtItsLimitStopsTheAdvanceWhileItCloses); one without does not.
TEST(GoingIn, ARobotStateWithAJointAtItsLimitStopsTheGraspsAdvance) {
  for (const bool at_limit_before : {false, true}) {
    ServoConfig cfg = config();
    cfg.grasp_stop_at_joint_limit = true;
    Fixture x(cfg);
    ASSERT_EQ(x.approach(0.4, 0.05).action, GoingIn::Step::Action::kIrBegins);
    const Eigen::Isometry3d tool = tool_ahead(x.cfg, 0.4);
    robot_state_t st{};
    x.in.on_robot_state(st);
    if (at_limit_before) {
      st.fault_flags = arm::kFlagJointLimit;
      x.in.on_robot_state(st);
    }
    x.in.on_ir(reading(0.015), kT + 10'000, true);
    ASSERT_EQ(x.in.ir(kT + 20'000, tool, tool, fruit(x.cfg, 0.45)).action, GoingIn::Step::Action::kClose);
    EXPECT_EQ(x.in.grasp_twist(tool).has_value(), !at_limit_before);
    st.fault_flags = arm::kFlagJointLimit;
    x.in.on_robot_state(st);
    EXPECT_FALSE(x.in.grasp_twist(tool).has_value());
  }
}

// A back-off retraces the axis to abreast of where the first attempt began; the second attempt is the last.
TEST(GoingIn, TheIrAttemptsBeginOnceAndRetryUntilUsed) {
  Fixture x;
  ASSERT_EQ(x.approach(0.1, 0.3).action, GoingIn::Step::Action::kIrBegins);
  EXPECT_TRUE(x.in.attempts_left());
  x.in.retry(tool_ahead(x.cfg, 0.15).translation(), kT + rt::from_seconds(3));
  EXPECT_FALSE(x.in.attempts_left());
  EXPECT_EQ(x.in.ir_start(), tool_ahead(x.cfg, 0.1).translation());
}

// The hand camera's views go to the sway estimator (watch_sway), and a fruit seen to sway 15 mm at 0.4 Hz is
// stood off at hold_standoff (0.2 m): 0.23 m ahead with the IR reading 0.3 m, the still fruit is gone on to at
// the speed cap (0.381 m/s), the swaying one braked to rest 0.03 m on: sqrt(2 x 0.8 x 0.03) = 0.219 m/s.
TEST(GoingIn, AFruitSeenToSwayIsStoodOffFromTheHandCamerasViews) {
  for (const bool sways : {false, true}) {
    Fixture x;
    ASSERT_EQ(x.approach(0.2, 0.3).action, GoingIn::Step::Action::kIrBegins);
    const Eigen::Isometry3d tool = tool_ahead(x.cfg, 0.2);
    const Fruit f = fruit(x.cfg, 0.43);
    GoingIn::Step s;
    for (int k = 1; k <= 60; ++k) {  // 2 s at 30 Hz
      const rt::Micros t = kT + k * 33'333;
      const double across = sways ? 0.015 * std::sin(2 * M_PI * 0.4 * rt::to_seconds(t - kT)) : 0.0;
      x.in.on_hand_detections(seen_on_axis(x.cfg, t, across, 0.23), f, tool, t);
      x.in.watch_sway(t, tool, tool, f);
      x.in.on_ir(reading(0.3), t, true);
      s = x.in.ir(t, tool, tool, f);
    }
    ASSERT_EQ(s.action, GoingIn::Step::Action::kMove);
    if (sways)
      EXPECT_NEAR(s.twist.linear.y(), std::sqrt(2 * 0.8 * 0.03), 1e-3);
    else
      EXPECT_NEAR(s.twist.linear.y(), 0.381, 1e-3);
  }
}

// The IR's fold-back (30 mm, then 300 mm: the fruit inside, nearer than the sensor's peak) closes while guiding,
// not from readings taken before IR_APPROACH, and not on a fruit seen to sway (it swings out of the beam too: the
// far reading is then taken as it is, and the arm goes on, slowly; no hold here, hold_standoff 0).
TEST(GoingIn, TheIrFoldBackClosesWhileGuidingAndNotOnASwayingFruit) {
  const auto on_fold_back = [](bool guiding, bool sways) {
    Fixture x;
    x.cfg.sway.hold_standoff = 0.0;
    GoingIn in(x.cfg, make_approach(x.cfg));
    const Eigen::Isometry3d tool = tool_ahead(x.cfg, 0.4);
    const Eigen::Isometry3d camera = tool_ahead(x.cfg, 0.2);  // this near, the camera sits 0.2 m behind the palm
    const Fruit f = fruit(x.cfg, 0.42);
    in.on_hand_detections(seen_on_axis(x.cfg, kT, 0.0, 0.22), f, camera, kT);
    EXPECT_EQ(in.approach(kT, tool, camera, f).action, GoingIn::Step::Action::kIrBegins);
    rt::Micros t = kT;
    for (int k = 1; sways && k <= 60; ++k) {
      t = kT + k * 33'333;
      const double across = 0.015 * std::sin(2 * M_PI * 0.4 * rt::to_seconds(t - kT));
      in.on_hand_detections(seen_on_axis(x.cfg, t, across, 0.22), f, camera, t);
      in.watch_sway(t, tool, camera, f);
    }
    in.on_ir(reading(0.030), t + 1, guiding);
    in.on_ir(reading(0.300), t + 2, true);
    return in.ir(t + 3, tool, camera, f);
  };
  EXPECT_EQ(on_fold_back(true, false).action, GoingIn::Step::Action::kClose);
  for (const GoingIn::Step& s : {on_fold_back(false, false), on_fold_back(true, true)}) {
    EXPECT_EQ(s.action, GoingIn::Step::Action::kMove);
    EXPECT_GT(s.twist.linear.y(), 0.03);  // on (not waiting at rest for the fruit to come onto the axis)
  }
}

}  // namespace
}  // namespace harvest::servo
