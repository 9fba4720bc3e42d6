#include "sim/hand.hpp"

#include <gtest/gtest.h>

#include "test_scenes.hpp"

namespace harvest::sim {
namespace {

// Tool looking along base +y from `y`, TCP on the fruit axis offset by `lateral` in base x.
Placement tool_at(double y, double lateral = 0.0) { return {look_at_rotation(Vec3(lateral, y, 0), Vec3(lateral, 2, 0)), Vec3(lateral, y, 0)}; }

TEST(IrRayCast, MeasuresTheDistanceToTheFirstSurface) {
  Scene scene(test::one_fruit(Vec3(0, 1, 0), 0.07));
  const auto r = ray_cast(scene, Vec3(0, 0.5, 0), Vec3::UnitY(), 1.0);
  ASSERT_TRUE(r);
  EXPECT_NEAR(*r, 0.5 - 0.035, 1e-9);
  EXPECT_FALSE(ray_cast(scene, Vec3(0, 0.5, 0), Vec3::UnitY(), 0.4));  // beyond the sensor's range
  EXPECT_FALSE(ray_cast(scene, Vec3(0.05, 0.5, 0), Vec3::UnitY(), 1.0));  // misses beside the fruit
  Leaf leaf;
  leaf.centre = Vec3(0, 0.8, 0);
  leaf.normal = Vec3::UnitY();
  leaf.u = Vec3::UnitX();
  leaf.v = Vec3::UnitZ();
  leaf.half_length = leaf.half_width = 0.03;
  scene.add_leaf(leaf);
  EXPECT_NEAR(*ray_cast(scene, Vec3(0, 0.5, 0), Vec3::UnitY(), 1.0), 0.3, 1e-9);
  scene.fruit()[0].state = FruitState::kPicked;
  EXPECT_NEAR(*ray_cast(scene, Vec3(0, 0.85, 0), Vec3::UnitY(), 1.0), 0.0, 1e-9) << "picked fruit is gone";
}

TEST(IrSensor, ResponseFallsWithRangeAndFoldsBackBelowThePeak) {
  IrSetup setup;
  setup.noise_std = 0.0;
  IrSensor ir(setup, 1);
  int previous = 1024;
  for (double r = setup.peak_range; r <= setup.max_range; r += 0.01) {
    const int raw = ir.ideal_raw(r);
    EXPECT_LT(raw, previous) << r;
    previous = raw;
  }
  EXPECT_NEAR(ir.ideal_raw(0.1), setup.gain / (100.0 + setup.offset_mm), 1.0);
  EXPECT_LT(ir.ideal_raw(0.01), ir.ideal_raw(setup.peak_range));  // fold-back
  EXPECT_LT(ir.ideal_raw(std::nullopt), ir.ideal_raw(setup.max_range));
  EXPECT_EQ(ir.sample(0.1), ir.ideal_raw(0.1));
}

TEST(IrSensor, NoiseIsSeededWithTheConfiguredSpread) {
  IrSetup setup;
  setup.noise_std = 5.0;
  IrSensor a(setup, 9), b(setup, 9);
  double sum = 0, sum2 = 0;
  const int n = 4000, ideal = a.ideal_raw(0.1);
  for (int i = 0; i < n; ++i) {
    const int x = a.sample(0.1);
    EXPECT_EQ(x, b.sample(0.1));
    sum += x - ideal;
    sum2 += (x - ideal) * (x - ideal);
  }
  EXPECT_NEAR(sum / n, 0.0, 0.5);
  EXPECT_NEAR(std::sqrt(sum2 / n), 5.0, 0.4);
}

struct GripperFixture : ::testing::Test {
  Scenario sc = test::one_fruit(Vec3(0, 1, 0), 0.07);
  Scene scene{sc};
  Gripper gripper{sc.gripper};
  void run(double from, double to, const Placement& tool) {
    for (double t = from; t <= to + 1e-9; t += 0.01) gripper.step(t, static_cast<int64_t>(t * 1e6), scene, tool);
  }
};

TEST_F(GripperFixture, CentredFruitIsHeldThenPickedByThePull) {
  const Placement at_fruit = tool_at(1.0 - 0.005);
  gripper.close(0.0);
  run(0.0, sc.gripper.close_time_s / 2, at_fruit);
  EXPECT_EQ(gripper.phase(), GripperPhase::kClosing);
  EXPECT_EQ(scene.fruit()[0].state, FruitState::kOnTree);
  run(sc.gripper.close_time_s / 2, sc.gripper.close_time_s + 0.02, at_fruit);
  EXPECT_EQ(gripper.phase(), GripperPhase::kHolding);
  EXPECT_EQ(scene.fruit()[0].state, FruitState::kHeld);
  EXPECT_NEAR(scene.fruit()[0].grasp_offset.norm(), 0.005, 1e-9);
  // Pull back along the approach axis: the fruit follows, then comes off.
  run(1.0, 1.1, tool_at(1.0 - 0.005 - sc.gripper.detach_distance / 2));
  EXPECT_EQ(scene.fruit()[0].state, FruitState::kHeld);
  run(1.1, 1.2, tool_at(1.0 - 0.005 - 2 * sc.gripper.detach_distance));
  EXPECT_EQ(scene.fruit()[0].state, FruitState::kPicked);
  EXPECT_EQ(scene.fruit()[0].outcome_utime, 1'110'000);
}

TEST_F(GripperFixture, OffCentreFruitIsKnockedOffAndFarFruitIsUntouched) {
  gripper.close(0.0);
  run(0.0, 1.0, tool_at(1.0, sc.gripper.capture_radius + 0.01));
  EXPECT_EQ(gripper.phase(), GripperPhase::kClosed);
  EXPECT_EQ(scene.fruit()[0].state, FruitState::kKnocked);
  EXPECT_EQ(scene.fruit()[0].grasp_attempts, 1);

  Scene fresh(sc);
  Gripper g(sc.gripper);
  g.close(0.0);
  for (double t = 0; t < 1.0; t += 0.01) g.step(t, 0, fresh, tool_at(0.7));
  EXPECT_EQ(g.phase(), GripperPhase::kClosed);
  EXPECT_EQ(fresh.fruit()[0].state, FruitState::kOnTree);
  EXPECT_EQ(fresh.fruit()[0].grasp_attempts, 0);
}

TEST_F(GripperFixture, OpeningReleasesAnAttachedFruitAndThePalmKnocksFruitOff) {
  gripper.close(0.0);
  run(0.0, 1.0, tool_at(1.0));
  ASSERT_EQ(scene.fruit()[0].state, FruitState::kHeld);
  gripper.open(1.0);
  run(1.0, 2.0, tool_at(1.0));
  EXPECT_EQ(gripper.phase(), GripperPhase::kOpen);
  EXPECT_EQ(scene.fruit()[0].state, FruitState::kOnTree);
  // Driving on with the gripper open: the palm runs into the fruit.
  run(2.0, 2.1, tool_at(1.0 + sc.gripper.palm_offset));
  EXPECT_EQ(scene.fruit()[0].state, FruitState::kKnocked);
}

}  // namespace
}  // namespace harvest::sim
