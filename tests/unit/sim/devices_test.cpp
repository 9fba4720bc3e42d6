// Hardware mode "devices" without a network: the start pose becomes a joint
// configuration, the simulated drives move the true tool by forward
// kinematics at the true mounting, and board commands drive the simulated
// gripper.
#include "sim/devices.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <numbers>

#include "can/memory_bus.hpp"
#include "canopen/master.hpp"
#include "kinematics/chain.hpp"
#include "sim/scene.hpp"
#include "test_scenes.hpp"

namespace harvest::sim {
namespace {

constexpr double kPi = 3.14159265358979323846;

DevicesConfig shipped_devices() {
  const auto doc = config::Document::load_string("drives_config: config/arm/sim_drives.yaml\n");
  return DevicesConfig::from_config(doc.root());
}

Placement scenario_start(const std::string& name) {
  const Scenario s = load_scenario("config/scenarios/" + name + ".yaml");
  return {look_at_rotation(s.arm.start_tool_position, s.arm.start_look_at), s.arm.start_tool_position};
}

double angle_between(const Mat3& a, const Mat3& b) { return Eigen::AngleAxisd(a * b.transpose()).angle(); }

Eigen::Isometry3d mounting_error() {
  Eigen::Isometry3d m = Eigen::Isometry3d::Identity();
  m.translation() = Vec3(0.012, -0.008, 0.005);
  m.linear() = Eigen::AngleAxisd(1.5 * kPi / 180.0, Vec3(0.3, 1.0, -0.2).normalized()).toRotationMatrix();
  return m;
}

TEST(Devices, ReadsTheDrivesConfigurationHarvestSimDrivesReads) {
  const DevicesConfig c = shipped_devices();
  EXPECT_EQ(c.model.name, "k1207i");
  ASSERT_EQ(static_cast<int>(c.drives.size()), c.model.dof());
  EXPECT_EQ(c.drives[6].node_id, 7);
  EXPECT_NEAR(c.drives[0].counts_per_radian, 417222.0, 1e-9);
  EXPECT_EQ(c.bus.rfind("udp_multicast:", 0), 0u);
  EXPECT_EQ(c.board_port, 4001);
}

TEST(Devices, StartPoseBecomesAJointConfigurationAtTheTrueMounting) {
  const DevicesConfig c = shipped_devices();
  const Placement start = scenario_start("tree");
  for (const Eigen::Isometry3d& mounting : {Eigen::Isometry3d(Eigen::Isometry3d::Identity()), mounting_error()}) {
    const StartConfiguration sc = start_joints(c.model, mounting, start);
    EXPECT_TRUE(c.model.within_limits(sc.q));
    EXPECT_EQ(sc.tilt_rad, 0.0);
    const Eigen::Isometry3d tool = mounting * kinematics::tool_pose(c.model, sc.q);
    EXPECT_LT((tool.translation() - start.position).norm(), 1e-4);
    EXPECT_LT(angle_between(tool.linear(), start.rotation), 1e-3);
  }
  // A start looking back at the shoulder from 0.95 m: the wrist centre would
  // lie beyond the arm's reach, so the position is kept and the orientation
  // gives way as little as needed.
  const Vec3 shoulder = c.model.base.translation();
  const Vec3 out = (kinematics::tool_pose(c.model, c.model.home).translation() - shoulder).normalized();
  const Vec3 p = shoulder + 0.95 * out;
  const Placement back{look_at_rotation(p, shoulder), p};
  const StartConfiguration sc = start_joints(c.model, Eigen::Isometry3d::Identity(), back);
  const Eigen::Isometry3d tool = kinematics::tool_pose(c.model, sc.q);
  EXPECT_LT((tool.translation() - back.position).norm(), 1e-4);
  EXPECT_GT(sc.tilt_rad, 0.5);
  EXPECT_NEAR(angle_between(tool.linear(), back.rotation), sc.tilt_rad, 0.05);
  // Out of reach: a clear error, not a pose somewhere else.
  Placement far = start;
  far.position = Vec3(0, 3.0, 0);
  EXPECT_THROW(start_joints(c.model, Eigen::Isometry3d::Identity(), far), std::runtime_error);
}

TEST(Devices, EveryShippedScenarioStartsWhereTheArmCanBe) {
  const DevicesConfig c = shipped_devices();
  int starts = 0;
  for (const auto& e : std::filesystem::directory_iterator("config/scenarios")) {
    if (e.path().extension() != ".yaml") continue;
    const Scenario base = load_scenario(e.path().string());
    const int runs = std::max<int>(1, static_cast<int>(base.variants.size()));
    for (int run = 0; run < runs; ++run) {
      SCOPED_TRACE(e.path().string() + " run " + std::to_string(run));
      const Scenario s = base.for_run(run);
      const Placement start{look_at_rotation(s.arm.start_tool_position, s.arm.start_look_at),
                            s.arm.start_tool_position};
      StartConfiguration sc;
      ASSERT_NO_THROW(sc = start_joints(c.model, to_isometry(s.arm.mounting), start));
      const Eigen::Isometry3d tool = to_isometry(s.arm.mounting) * kinematics::tool_pose(c.model, sc.q);
      EXPECT_LT((tool.translation() - start.position).norm(), 1e-4);
      std::printf("%s run %d: start orientation tilted %.1f deg\n", e.path().filename().c_str(), run,
                  sc.tilt_rad * 180.0 / kPi);
      ++starts;
    }
  }
  EXPECT_GE(starts, 5);
}

Placement hand_eye() {
  Placement p;
  p.rotation = Eigen::AngleAxisd(std::numbers::pi / 2, Vec3::UnitZ()).toRotationMatrix();
  p.position = Vec3(0.0, 0.01, -0.04);
  return p;
}

// The arm's drives against the robot link's CANopen master on an in-memory bus.
class DeviceArmOnBus : public ::testing::Test {
 protected:
  DeviceArmOnBus() : config_(shipped_devices()) {
    canopen::MasterConfig mc;
    for (const auto& d : config_.drives) mc.drives.push_back({d.node_id, d.counts_per_radian, d.zero_offset_counts});
    master_ = std::make_unique<canopen::Master>(master_bus_, mc);
    q0_ = start_joints(config_.model, mounting_error(), scenario_start("tree")).q;
    arm_ = std::make_unique<DeviceArm>(arm_bus_, config_.model, config_.drives, q0_, mounting_error(), hand_eye());
  }

  void run(double seconds) {
    const canopen::Micros end = now_ + static_cast<canopen::Micros>(seconds * 1e6);
    while (now_ < end) {
      now_ += 1000;
      arm_->advance(now_);
      arm_->drain(now_);
      master_->drain(now_);
      if (now_ % 10'000 == 0) {
        master_->sync(now_);
        arm_->drain(now_);
        master_->drain(now_);
      }
    }
  }

  DevicesConfig config_;
  can::MemoryWire wire_;
  can::MemoryBus& master_bus_ = wire_.attach();
  can::MemoryBus& arm_bus_ = wire_.attach();
  std::unique_ptr<canopen::Master> master_;
  Eigen::VectorXd q0_;
  std::unique_ptr<DeviceArm> arm_;
  canopen::Micros now_ = 1'000'000'000;
};

TEST_F(DeviceArmOnBus, ToolIsTheForwardKinematicsOfTheDrivesAtTheTrueMounting) {
  const Placement start = scenario_start("tree");
  EXPECT_LT((arm_->tool().position - start.position).norm(), 1e-4);
  master_->start(now_);
  run(0.5);
  ASSERT_EQ(master_->phase(), canopen::MasterPhase::kRunning) << master_->error();
  master_->set_goal(canopen::DriveGoal::kEnabled);
  run(0.1);
  ASSERT_TRUE(master_->all_in(canopen::Cia402State::kOperationEnabled));
  // The master reads the start configuration through the PDOs.
  for (int i = 0; i < config_.model.dof(); ++i)
    EXPECT_NEAR(master_->drives()[static_cast<std::size_t>(i)].position, q0_[i], 2.0 / 417222.0);

  std::vector<double> v(static_cast<std::size_t>(config_.model.dof()), 0.0);
  v[0] = 0.1;  // shoulder roll
  master_->set_velocities(v);
  run(1.0);
  master_->set_velocities(std::vector<double>(v.size(), 0.0));
  run(0.3);
  const Eigen::VectorXd q = arm_->joints();
  EXPECT_GT(q[0] - q0_[0], 0.05);
  EXPECT_NEAR(q[1], q0_[1], 1e-9);
  const Eigen::Isometry3d expected = mounting_error() * kinematics::tool_pose(config_.model, q);
  EXPECT_LT((arm_->tool().position - expected.translation()).norm(), 1e-9);
  EXPECT_GT((arm_->tool().position - start.position).norm(), 0.02);
  // The true hand camera rides on the tool with the scenario's hand-eye
  // (10 mm along tool y, 40 mm behind the tool point, turned 90 deg about the
  // tool axis), whatever the arm model's (the software's) camera says.
  const Placement& tool = arm_->tool();
  EXPECT_LT((arm_->hand_camera().position - (tool.position + tool.rotation * Vec3(0.0, 0.01, -0.04))).norm(), 1e-9);
  EXPECT_LT((arm_->hand_camera().rotation.col(0) - tool.rotation.col(1)).norm(), 1e-9);
  EXPECT_LT((arm_->hand_camera().rotation.col(2) - tool.rotation.col(2)).norm(), 1e-9);
  EXPECT_GT(
      (arm_->hand_camera().position - (mounting_error() * kinematics::camera_pose(config_.model, q)).translation())
          .norm(),
      0.005);
}

TEST(BoardGripper, BoardCommandsDriveTheSimulatedGripper) {
  Scenario sc = test::one_fruit(Vec3(0, 1, 0), 0.07);
  Scene scene(sc);
  Gripper gripper(sc.gripper);
  BoardGripper board(
      gripper, [](rt::Micros t) { return t * 1e-6; }, 10.0);
  const Placement at_fruit{look_at_rotation(Vec3(0, 0.995, 0), Vec3(0, 2, 0)), Vec3(0, 0.995, 0)};
  EXPECT_EQ(board.read(0).state, endeffector::GripState::kOpen);
  board.command({endeffector::GripperGoal::Kind::kClose, 0.0, 15.0}, 0);
  for (int i = 1; i <= 30; ++i) gripper.step(i * 0.01, i * 10'000, scene, at_fruit);
  EXPECT_EQ(board.read(300'000).state, endeffector::GripState::kClosing);
  EXPECT_NEAR(board.read(300'000).position, 0.5, 0.02);
  for (int i = 31; i <= 100; ++i) gripper.step(i * 0.01, i * 10'000, scene, at_fruit);
  const auto held = board.read(1'000'000);
  EXPECT_EQ(held.state, endeffector::GripState::kHolding);
  EXPECT_NEAR(held.force_n, 15.0, 1e-9);
  EXPECT_EQ(scene.fruit()[0].state, FruitState::kHeld);
  board.command({endeffector::GripperGoal::Kind::kOpen, 1.0, 0.0}, 1'000'000);
  gripper.step(1.01, 1'010'000, scene, at_fruit);
  EXPECT_EQ(board.read(1'010'000).state, endeffector::GripState::kOpening);
}

TEST(Scenario, ReadsTheTrueMountingAndDeviceFaults) {
  const auto doc = config::Document::load_string(
      "name: t\nfruit:\n  - {position_mm: [0, 1000, 0]}\n"
      "arm: {mounting_truth: {translation_mm: [10, 0, -5], rpy_deg: [0, 0, 90]}}\n"
      "faults: {drive_fault_start_s: 3, drive_fault_joint: 2, drive_silent_start_s: 4, board_silent_start_s: 5, "
      "board_silent_duration_s: 1}\n");
  const Scenario s = Scenario::from_config(doc.root());
  doc.check_unused();
  EXPECT_NEAR((s.arm.mounting.position - Vec3(0.010, 0, -0.005)).norm(), 0.0, 1e-12);
  EXPECT_TRUE((s.arm.mounting.rotation * Vec3::UnitX()).isApprox(Vec3::UnitY(), 1e-12));
  EXPECT_EQ(s.faults.drive_fault_joint, 2);
  EXPECT_DOUBLE_EQ(s.faults.drive_fault_start_s, 3.0);
  EXPECT_DOUBLE_EQ(s.faults.board_silent_duration_s, 1.0);
}

}  // namespace
}  // namespace harvest::sim
