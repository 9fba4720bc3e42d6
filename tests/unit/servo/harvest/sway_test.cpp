#include "servo/harvest/sway.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <random>
#include <vector>

namespace harvest::servo {
namespace {

constexpr double kPi = std::numbers::pi;
const Eigen::Vector3d kStem(0.1, 0.9, -0.4);

// Deterministic noise in [-1, 1]: the i-th output of a fixed-seed std::mt19937 (its sequence is the standard's).
double noise(int i) {
  static const std::vector<double> table = [] {
    std::mt19937 rng(20261204);
    std::vector<double> t(4096);
    for (double& x : t) x = static_cast<double>(rng() % 2001) / 1000.0 - 1.0;
    return t;
  }();
  return table[static_cast<std::size_t>(i) % table.size()];
}

// The fruit of tree_wind: 15 mm at 0.4 Hz along x, phase 0.3 rad at t = 0,
// seen at 30 Hz from t0 to t1 with +-0.5 mm of noise on every axis.
void see_swaying(SwayEstimator& e, double t0, double t1, double amplitude = 0.015, double hz = 0.4, double phase = 0.3,
                 Eigen::Vector3d direction = Eigen::Vector3d::UnitX()) {
  int i = 0;
  for (double t = t0; t <= t1 + 1e-9; t += 1.0 / 30.0, ++i) {
    const Eigen::Vector3d n(noise(i), noise(i + 1000), noise(i + 2000));
    e.add(t, kStem + amplitude * std::sin(2 * kPi * hz * t + phase) * direction + 0.0005 * n);
  }
}

TEST(SwayEstimator, FitsAmplitudeFrequencyAndPhaseOfASway) {
  SwayEstimator e{ServoConfig::Sway{}};
  see_swaying(e, 0.0, 2.5);  // one period
  const SwayFit f = e.fit();
  ASSERT_TRUE(f.swaying);
  EXPECT_EQ(f.samples, 76);
  EXPECT_NEAR(f.span_s, 2.5, 1e-9);
  EXPECT_NEAR(f.frequency_hz, 0.4, 0.021);
  EXPECT_NEAR(f.amplitude, 0.015, 0.001);
  EXPECT_GT(f.confidence, 0.95);
  EXPECT_FALSE(f.learned_frequency);
  // At t_ref = 2.5 s the sway is one period on: phase 0.3 again.
  EXPECT_NEAR(f.t_ref, 2.5, 1e-9);
  EXPECT_NEAR(f.phase, 0.3, 0.1);
  EXPECT_NEAR((f.centre - kStem).norm(), 0.0, 0.001);
  // A quarter period on (0.625 s): x = 0.1 + 0.015 sin(0.3 + pi/2) = 0.1 + 0.015 cos(0.3) = 0.11433.
  const Eigen::Vector3d p = f.at(2.5 + 0.625);
  EXPECT_NEAR(p.x(), 0.11433, 0.0015);
  EXPECT_NEAR(p.y(), 0.9, 0.001);
  EXPECT_NEAR(p.z(), -0.4, 0.001);
}

TEST(SwayEstimator, FitsASwayAlongAnyDirection) {
  SwayEstimator e{ServoConfig::Sway{}};
  const Eigen::Vector3d dir = Eigen::Vector3d(1, -2, 2).normalized();  // (1/3, -2/3, 2/3)
  see_swaying(e, 0.0, 2.0, 0.03, 0.8, 1.0, dir);                       // tree_wind_strong: 30 mm at 0.8 Hz, 1.6 periods
  const SwayFit f = e.fit();
  ASSERT_TRUE(f.swaying);
  EXPECT_NEAR(f.frequency_hz, 0.8, 0.021);
  EXPECT_NEAR(f.amplitude, 0.03, 0.0015);
  // 0.3 s on: phase 2 pi 0.8 2.3 + 1 = 12.560 rad; sin = -0.0076: 0.2 mm from the stem along dir.
  const Eigen::Vector3d expected = kStem + 0.03 * std::sin(2 * kPi * 0.8 * 2.3 + 1.0) * dir;
  EXPECT_NEAR((f.at(2.3) - expected).norm(), 0.0, 0.002);
}

TEST(SwayEstimator, AStillFruitIsStill) {
  SwayEstimator e{ServoConfig::Sway{}};
  for (int i = 0; i < 90; ++i) e.add(i / 30.0, kStem + 0.0005 * Eigen::Vector3d(noise(i), noise(i + 7), noise(i + 9)));
  const SwayFit f = e.fit();
  EXPECT_FALSE(f.swaying);
  EXPECT_LT(f.amplitude, 0.002);
}

TEST(SwayEstimator, AJitteryStillFruitIsStillByTheConfidenceAlone) {
  // +-10 mm of jitter on x: the best sinusoid among the frequencies tried explains little of it.
  ServoConfig::Sway p;
  p.min_amplitude = 0.0;
  SwayEstimator e{p};
  for (int i = 0; i < 90; ++i) e.add(i / 30.0, kStem + 0.01 * Eigen::Vector3d(noise(i), 0, 0));
  const SwayFit f = e.fit();
  EXPECT_LT(f.confidence, 0.6);
  EXPECT_FALSE(f.swaying);
}

TEST(SwayEstimator, ACameraDriftIsNotASway) {
  // The depth error of an approaching camera moves a still fruit steadily: 20 mm/s along x.
  SwayEstimator e{ServoConfig::Sway{}};
  for (int i = 0; i < 60; ++i)
    e.add(i / 30.0, kStem + Eigen::Vector3d(0.02 * i / 30.0, 0, 0) + 0.0005 * Eigen::Vector3d(noise(i), 0, 0));
  EXPECT_FALSE(e.fit().swaying);
}

// min_periods_seen 0.4: views over 0.9 s try frequencies from 0.4 / 0.9 = 0.44 Hz up, so tree_wind's 0.4 Hz is not
// among them; 0.2 lets it be (from 0.22 Hz).
TEST(SwayEstimator, AFrequencyIsTriedOnlyOverEnoughOfItsPeriod) {
  for (const double periods : {0.4, 0.2}) {
    ServoConfig::Sway p;
    p.min_periods_seen = periods;
    SwayEstimator e{p};
    see_swaying(e, 0.0, 0.9);
    const SwayFit f = e.fit();
    if (periods == 0.4)
      EXPECT_GE(f.frequency_hz, 0.4 / 0.9 - 1e-9);
    else
      EXPECT_LT(f.frequency_hz, 0.4 / 0.9 - 1e-9);
  }
}

TEST(SwayEstimator, TooLittleSeenIsStill) {
  ServoConfig::Sway p;  // min_samples 12, min_span 0.8 s
  SwayEstimator few{p};
  see_swaying(few, 0.0, 10.0 / 30.0);  // 11 samples
  EXPECT_FALSE(few.fit().swaying);
  EXPECT_EQ(few.fit().samples, 11);
  SwayEstimator brief{p};
  for (int i = 0; i < 40; ++i)
    brief.add(i * 0.015, kStem + 0.015 * std::sin(10.0 * i * 0.015) * Eigen::Vector3d::UnitX());
  EXPECT_FALSE(brief.fit().swaying);  // 40 samples over 0.585 s
}

// Hand-worked: positions 3 mm either side of the stem along x, half each:
// 3 mm rms about their mean; with fewer than min_samples (12) nothing is told.
TEST(SwayEstimator, SpreadIsTheRmsAboutTheMeanOnceEnoughIsSeen) {
  SwayEstimator e{ServoConfig::Sway{}};
  const Eigen::Vector3d x = Eigen::Vector3d::UnitX();
  for (int i = 0; i < 11; ++i) e.add(i / 30.0, kStem + (i % 2 == 1 ? 0.003 : -0.003) * x);
  EXPECT_EQ(e.spread(), 0.0);
  e.add(11 / 30.0, kStem + 0.003 * x);
  EXPECT_NEAR(e.spread(), 0.003, 1e-12);
  // A still fruit seen with +-0.5 mm of noise spreads far less than a sway of 15 mm seen for 2 s.
  SwayEstimator still{ServoConfig::Sway{}};
  for (int i = 0; i < 30; ++i)
    still.add(i / 30.0, kStem + 0.0005 * Eigen::Vector3d(noise(i), noise(i + 7), noise(i + 9)));
  SwayEstimator swaying{ServoConfig::Sway{}};
  see_swaying(swaying, 0.0, 2.0);
  EXPECT_LT(still.spread(), 0.001);
  EXPECT_GT(swaying.spread(), 0.004);
}

// Seen moving (the arm turning in: the depth error's sideways share), then
// still from t = 1: the whole spread says "swaying", the spread since t = 1
// says still; with fewer than min_samples since a moment, nothing.
TEST(SwayEstimator, TheSpreadSinceAMoment) {
  SwayEstimator e{ServoConfig::Sway{}};
  const Eigen::Vector3d x = Eigen::Vector3d::UnitX();
  for (int i = 0; i < 30; ++i) e.add(i / 30.0, kStem + 0.01 * (i / 30.0) * x);  // 10 mm over the first second
  for (int i = 30; i < 60; ++i) e.add(i / 30.0, kStem + 0.01 * x + (i % 2 == 1 ? 0.0005 : -0.0005) * x);
  EXPECT_GT(e.spread(), 0.0025);
  ASSERT_TRUE(e.spread_since(1.0));
  EXPECT_NEAR(*e.spread_since(1.0), 0.0005, 1e-12);  // 30 samples, +-0.5 mm about 10 mm
  EXPECT_NEAR(*e.spread_since(0.0), e.spread(), 1e-15);
  EXPECT_FALSE(e.spread_since(59.5 / 30.0 - 11.0 / 30.0));  // the newest 11 samples: fewer than min_samples (12)
  ASSERT_TRUE(e.spread_since(59.5 / 30.0 - 12.0 / 30.0));   // the newest 12
  EXPECT_NEAR(*e.spread_since(59.5 / 30.0 - 12.0 / 30.0), 0.0005, 1e-12);
  EXPECT_FALSE(e.spread_since(3.0));  // after the newest
}

TEST(SwayEstimator, KeepsTheWindowAndIgnoresRepeatedImages) {
  ServoConfig::Sway p;
  p.window = 1.0;
  SwayEstimator e{p};
  for (int i = 0; i <= 60; ++i) e.add(i / 30.0, kStem);
  EXPECT_EQ(e.size(), 31);  // t = 1.0 .. 2.0
  e.add(2.0, kStem);        // the same image again
  e.add(1.5, kStem);        // out of order
  EXPECT_EQ(e.size(), 31);
}

TEST(SwayEstimator, ALaterFruitSeenBrieflyTakesTheFrequencyLearnedOnEarlierOnes) {
  SwayEstimator e{ServoConfig::Sway{}};  // learn_fruit 3
  // Three fruit, 1.5 s each (0.6 of a period: each alone fits other frequencies about as well), other phases and
  // directions, the same wind; a fourth seen for 0.6 s only (a quarter period) does not count.
  const Eigen::Vector3d dirs[] = {Eigen::Vector3d::UnitX(), Eigen::Vector3d(1, 1, 0).normalized(),
                                  Eigen::Vector3d::UnitY()};
  for (int k = 0; k < 3; ++k) {
    EXPECT_FALSE(e.learned_hz().has_value());
    see_swaying(e, 10.0 * k, 10.0 * k + 1.5, 0.015, 0.4, 1.0 + 2.0 * k, dirs[k]);
    e.reset();
    EXPECT_EQ(e.size(), 0);
  }
  see_swaying(e, 35.0, 35.8, 0.015, 0.4, 0.0, Eigen::Vector3d::UnitZ());
  e.reset();
  ASSERT_TRUE(e.learned_hz().has_value());
  EXPECT_NEAR(*e.learned_hz(), 0.4, 0.041);
  // The next fruit, seen for 1 s (0.4 periods), another phase: fitted at the learned frequency.
  see_swaying(e, 40.0, 41.0, 0.015, 0.4, 2.0, Eigen::Vector3d::UnitY());
  const SwayFit f = e.fit();
  ASSERT_TRUE(f.swaying);
  EXPECT_TRUE(f.learned_frequency);
  EXPECT_EQ(f.frequency_hz, *e.learned_hz());
  const double t = 41.6;  // the jaws meet 0.6 s after the last view
  EXPECT_NEAR(f.at(t).y(), 0.9 + 0.015 * std::sin(2 * kPi * 0.4 * t + 2.0), 0.003);
  // Still fruit teach nothing.
  SwayEstimator still{ServoConfig::Sway{}};
  for (int k = 0; k < 5; ++k) {
    for (int i = 0; i < 90; ++i) still.add(10.0 * k + i / 30.0, kStem + 0.0005 * Eigen::Vector3d(noise(i), 0, 0));
    still.reset();
  }
  EXPECT_FALSE(still.learned_hz().has_value());
}

// close_decision: the tool at the origin, its axis along +z; the fruit 20 mm
// ahead, swaying 15 mm along x at 0.5 Hz: x(t) = 0.015 sin(pi t). The jaws
// meet close_delay 0.5 s after the command; default tolerance 6 mm, max wait 1.5 s.
SwayFit sway_along_x() {
  SwayFit f;
  f.swaying = true;
  f.centre = Eigen::Vector3d(0, 0, 0.02);
  f.sin_part = Eigen::Vector3d(0.015, 0, 0);
  f.frequency_hz = 0.5;
  f.amplitude = 0.015;
  return f;
}

// The timed close on (max_wait is 0 by default: the hold centres on the sway's middle instead).
ServoConfig::Sway timing() {
  ServoConfig::Sway p;
  p.close_delay = 0.5;
  p.max_wait = 1.5;
  return p;
}

constexpr double kStep = 0.02;  // the control period

TEST(CloseDecision, WaitsForTheFruitToComeOntoTheAxis) {
  const Eigen::Isometry3d tool = Eigen::Isometry3d::Identity();
  // Closing at 0 the jaws meet at 0.5 s, the fruit at the end of its sway (15 mm off); it crosses the axis at 1 s.
  const CloseDecision now0 = close_decision(sway_along_x(), tool, 0.0, 0.0, kStep, timing());
  EXPECT_FALSE(now0.close);
  EXPECT_NEAR(now0.offset, 0.015, 1e-6);
  EXPECT_NEAR(now0.best_wait, 0.5, 0.011);
  EXPECT_NEAR(now0.best_offset, 0.0, 0.0005);
  // At 0.35 s: 0.015 sin(0.85 pi) = 6.81 mm, just outside 6 mm: wait on.
  const CloseDecision now35 = close_decision(sway_along_x(), tool, 0.35, 0.35, kStep, timing());
  EXPECT_FALSE(now35.close);
  EXPECT_NEAR(now35.offset, 0.00681, 0.0001);
  // At 0.45 s: 0.015 sin(0.95 pi) = 2.35 mm: close.
  const CloseDecision now45 = close_decision(sway_along_x(), tool, 0.45, 0.45, kStep, timing());
  EXPECT_TRUE(now45.close);
  EXPECT_NEAR(now45.offset, 0.00235, 0.0001);
}

TEST(CloseDecision, AStillFruitIsClosedOnAtOnce) {
  SwayFit still = sway_along_x();
  still.swaying = false;
  EXPECT_TRUE(close_decision(still, Eigen::Isometry3d::Identity(), 0.0, 0.0, kStep, timing()).close);
}

TEST(CloseDecision, ClosesAtOnceWhenTheWaitIsOverOrOff) {
  const Eigen::Isometry3d tool = Eigen::Isometry3d::Identity();
  EXPECT_TRUE(close_decision(sway_along_x(), tool, 0.0, 1.5, kStep, timing()).close);
  ServoConfig::Sway off = timing();
  off.max_wait = 0.0;
  EXPECT_TRUE(close_decision(sway_along_x(), tool, 0.0, 0.0, kStep, off).close);
}

TEST(CloseDecision, AFitCentredFarOffTheAxisIsNotTrusted) {
  // Centred 31 mm off the axis (max_centre_offset 30 mm): closed on at once, although the fruit is predicted
  // 46 mm off at the end of the close.
  Eigen::Isometry3d tool = Eigen::Isometry3d::Identity();
  tool.translation().x() = -0.031;
  EXPECT_TRUE(close_decision(sway_along_x(), tool, 0.0, 0.0, kStep, timing()).close);
  tool.translation().x() = -0.029;  // 29 mm: trusted, 44 mm off at the end of a close now: wait
  EXPECT_FALSE(close_decision(sway_along_x(), tool, 0.0, 0.0, kStep, timing()).close);
}

TEST(CloseDecision, AnAxisBesideTheSwayClosesWhereTheFruitComesNearest) {
  // The axis 25 mm along x: the fruit never comes within 6 mm; nearest (10 mm) at the top of its sway, x = 15 mm
  // at t = 0.5 (and every 2 s on).
  Eigen::Isometry3d tool = Eigen::Isometry3d::Identity();
  tool.translation().x() = 0.025;
  const CloseDecision top = close_decision(sway_along_x(), tool, 0.0, 0.0, kStep, timing());
  EXPECT_TRUE(top.close);
  EXPECT_NEAR(top.offset, 0.010, 1e-6);
  // From t = 1 (the jaws would meet at 1.5 s, x = -15 mm: 40 mm off) the next top is 1 s away.
  const CloseDecision bottom = close_decision(sway_along_x(), tool, 1.0, 0.0, kStep, timing());
  EXPECT_FALSE(bottom.close);
  EXPECT_NEAR(bottom.offset, 0.040, 1e-6);
  EXPECT_NEAR(bottom.best_wait, 1.0, 0.011);
  EXPECT_NEAR(bottom.best_offset, 0.010, 0.0001);
}

}  // namespace
}  // namespace harvest::servo
