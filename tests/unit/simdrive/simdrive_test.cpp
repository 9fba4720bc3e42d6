// The CANopen master against simulated CiA 402 drives on an in-memory bus:
// configuration by SDO, enabling, velocity following, and each failure the
// master must report.
#include <gtest/gtest.h>

#include <cmath>

#include "can/memory_bus.hpp"
#include "canopen/master.hpp"
#include "simdrive/sim_drive.hpp"

namespace harvest::simdrive {
namespace {

using canopen::DriveGoal;
using canopen::MasterPhase;

class MasterWithDrives : public ::testing::Test {
 protected:
  explicit MasterWithDrives(std::vector<uint8_t> master_nodes = {1, 2}) {
    canopen::MasterConfig mc;
    for (uint8_t n : master_nodes) mc.drives.push_back({n, 417'000.0, 1000 * n});
    master_ = std::make_unique<canopen::Master>(master_bus_, mc);
    std::vector<SimDriveConfig> dc;
    for (uint8_t n : {1, 2}) {
      SimDriveConfig c;
      c.node_id = n;
      c.zero_offset_counts = 1000 * n;
      c.initial_position = 0.1 * n;
      dc.push_back(c);
    }
    drives_ = std::make_unique<SimDriveSet>(drive_bus_, dc);
  }

  // Runs the bus for `seconds`: drives advance every 1 ms, SYNC every 10 ms.
  void run(double seconds) {
    const canopen::Micros end = now_ + static_cast<canopen::Micros>(seconds * 1e6);
    while (now_ < end) {
      now_ += 1000;
      drives_->advance(now_);
      drives_->drain(now_);
      master_->drain(now_);
      if (now_ % 10'000 == 0) {
        master_->sync(now_);
        drives_->drain(now_);
        master_->drain(now_);
      }
    }
  }

  void start_and_enable() {
    master_->start(now_);
    run(0.5);
    ASSERT_EQ(master_->phase(), MasterPhase::kRunning) << master_->error();
    master_->set_goal(DriveGoal::kEnabled);
    run(0.1);
    ASSERT_TRUE(master_->all_in(canopen::Cia402State::kOperationEnabled));
  }

  can::MemoryWire wire_;
  can::MemoryBus& master_bus_ = wire_.attach();
  can::MemoryBus& drive_bus_ = wire_.attach();
  std::unique_ptr<canopen::Master> master_;
  std::unique_ptr<SimDriveSet> drives_;
  canopen::Micros now_ = 1'000'000'000;
};

TEST_F(MasterWithDrives, ConfiguresPdosAndEnablesDrives) {
  start_and_enable();
  // The drives hold the mapping the master wrote.
  const auto& od = drives_->drive(1).dictionary();
  EXPECT_EQ(od.get(0x1600, 1), 0x60400010u);
  EXPECT_EQ(od.get(0x1600, 2), 0x60FF0020u);
  EXPECT_EQ(od.get(0x1A00, 2), 0x60640020u);
  EXPECT_EQ(od.get(0x1A01, 1), 0x606C0020u);
  EXPECT_EQ(od.get(0x1400, 1), 0x202u);
  EXPECT_EQ(od.get(0x6060, 0), 9u);
  EXPECT_EQ(drives_->drive(0).nmt_state(), canopen::NmtState::kOperational);
  // Positions read back through TPDO1 with offsets and scaling.
  EXPECT_NEAR(master_->drives()[0].position, 0.1, 1.0 / 417'000.0);
  EXPECT_NEAR(master_->drives()[1].position, 0.2, 1.0 / 417'000.0);
  EXPECT_FALSE(master_->any_fault());
}

TEST_F(MasterWithDrives, DrivesFollowVelocityWithAccelerationLimit) {
  start_and_enable();
  master_->set_velocities({0.5, -0.25});
  run(0.05);
  // Acceleration limit 3 rad/s^2: after ~50 ms at most 0.15 rad/s.
  EXPECT_LE(drives_->drive(0).velocity(), 0.16);
  run(1.0);
  EXPECT_NEAR(drives_->drive(0).velocity(), 0.5, 1e-9);
  EXPECT_NEAR(drives_->drive(1).velocity(), -0.25, 1e-9);
  EXPECT_NEAR(master_->drives()[0].velocity, 0.5, 1e-5);
  const double p0 = drives_->drive(0).position();
  run(1.0);
  EXPECT_NEAR(drives_->drive(0).position() - p0, 0.5, 0.011);  // one SYNC of latency at most
  EXPECT_NEAR(master_->drives()[0].position, drives_->drive(0).position(), 0.5 * 0.011);
}

TEST_F(MasterWithDrives, FaultIsLatchedWithEmcyAndNeedsAReset) {
  start_and_enable();
  master_->set_velocities({0.3, 0.3});
  run(0.5);
  drives_->drive(1).inject_fault(0x2310);
  run(0.2);
  EXPECT_TRUE(master_->any_fault());
  EXPECT_TRUE(master_->drives()[1].emcy);
  EXPECT_TRUE(master_->drives()[1].fault);
  EXPECT_NE(master_->drives()[1].fault_text.find("EMCY 0x2310 current"), std::string::npos)
      << master_->drives()[1].fault_text;
  EXPECT_EQ(drives_->drive(1).state(), canopen::Cia402State::kFault);
  EXPECT_DOUBLE_EQ(drives_->drive(1).velocity(), 0.0);
  const auto events = master_->take_events();
  EXPECT_FALSE(events.empty());
  // Without a reset the drive stays faulted even though the goal is "enabled".
  run(0.2);
  EXPECT_EQ(drives_->drive(1).state(), canopen::Cia402State::kFault);
  master_->clear_faults();
  run(0.2);
  EXPECT_EQ(drives_->drive(1).state(), canopen::Cia402State::kOperationEnabled);
  EXPECT_FALSE(master_->any_fault());
}

TEST_F(MasterWithDrives, LostHeartbeatIsDetected) {
  start_and_enable();
  drives_->drive(0).set_heartbeat_enabled(false);
  run(0.15);
  EXPECT_FALSE(master_->drives()[0].heartbeat_lost);  // within the 200 ms timeout
  run(0.2);
  EXPECT_TRUE(master_->drives()[0].heartbeat_lost);
  EXPECT_FALSE(master_->drives()[1].heartbeat_lost);
}

TEST_F(MasterWithDrives, SilentDriveLosesPdosAndHeartbeat) {
  start_and_enable();
  drives_->drive(0).set_silent(true);
  run(0.5);
  EXPECT_TRUE(master_->drives()[0].pdo_lost);
  EXPECT_TRUE(master_->drives()[0].heartbeat_lost);
  master_->clear_faults();
  run(0.3);
  EXPECT_TRUE(master_->drives()[0].faulted()) << "a lost drive cannot be reset";
}

TEST_F(MasterWithDrives, QuickStopRampsDown) {
  start_and_enable();
  master_->set_velocities({0.6, 0.6});
  run(0.5);
  master_->set_goal(DriveGoal::kQuickStop);
  run(0.03);
  EXPECT_EQ(drives_->drive(0).state(), canopen::Cia402State::kQuickStopActive);
  run(0.2);  // 6 rad/s^2 from 0.6 rad/s: 0.1 s
  EXPECT_DOUBLE_EQ(drives_->drive(0).velocity(), 0.0);
}

TEST_F(MasterWithDrives, WaitsForADriveThatComesUpLate) {
  drives_->drive(1).set_silent(true);  // powered up after the master
  master_->start(now_);
  run(1.0);
  EXPECT_EQ(master_->phase(), MasterPhase::kConfiguring);
  drives_->drive(1).set_silent(false);
  run(0.5);
  ASSERT_EQ(master_->phase(), MasterPhase::kRunning) << master_->error();
  master_->set_goal(DriveGoal::kEnabled);
  run(0.1);
  EXPECT_TRUE(master_->all_in(canopen::Cia402State::kOperationEnabled));
  EXPECT_FALSE(master_->any_fault());
}

class MissingDrive : public MasterWithDrives {
 protected:
  MissingDrive() : MasterWithDrives({1, 9}) {}
};

TEST_F(MissingDrive, ConfigurationFailsWithAClearError) {
  master_->start(now_);
  run(1.9);
  EXPECT_EQ(master_->phase(), MasterPhase::kConfiguring) << "still asking within boot_timeout (2 s)";
  run(0.6);
  EXPECT_EQ(master_->phase(), MasterPhase::kFailed);
  EXPECT_NE(master_->error().find("joint 2"), std::string::npos) << master_->error();
  EXPECT_NE(master_->error().find("SDO protocol timed out"), std::string::npos) << master_->error();
}

TEST(SimDrive, RefusesUnsupportedModeOfOperation) {
  can::MemoryWire wire;
  auto& a = wire.attach();
  auto& b = wire.attach();
  SimDrive drive({}, [&](const can::CanFrame& f) { b.send(f); });
  drive.advance(0);
  drive.handle_frame(canopen::sdo::initiate_download_expedited(1, 0x6060, 0, 3, 1), 0);  // profile position
  std::optional<can::CanFrame> reply;
  while (auto f = a.receive()) reply = f;
  ASSERT_TRUE(reply);
  EXPECT_EQ(canopen::sdo::specifier(*reply), canopen::sdo::kAbort);
  EXPECT_EQ(canopen::sdo::abort_code_of(*reply), canopen::sdo::kAbortValueRange);
}

}  // namespace
}  // namespace harvest::simdrive
