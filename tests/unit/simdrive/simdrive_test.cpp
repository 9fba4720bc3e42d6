// The CANopen master against simulated CiA 402 drives on an in-memory bus:
// configuration by SDO, enabling, velocity following, and each failure the
// master must report.
#include <gtest/gtest.h>

#include <cmath>
#include <functional>

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
    for (uint8_t n : master_nodes) config_.drives.push_back({n, 417'000.0, 1000 * n});
    master_ = std::make_unique<canopen::Master>(master_bus_, config_);
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

  // The drives alone: the master has fallen silent (its process killed).
  void run_drives(double seconds) {
    const canopen::Micros end = now_ + static_cast<canopen::Micros>(seconds * 1e6);
    while (now_ < end) {
      now_ += 1000;
      drives_->advance(now_);
      drives_->drain(now_);
    }
  }
  // The whole host freezes (a virtual machine's CPU quota; up to ~130 ms seen on the test machine): neither the
  // master nor the drives run for `seconds`, and no frame crosses the bus.
  void freeze(double seconds) { now_ += static_cast<canopen::Micros>(seconds * 1e6); }
  // Drives with these settings in place of the fixture's.
  void remake_drives(const std::function<void(SimDriveConfig&)>& tweak) {
    std::vector<SimDriveConfig> dc;
    for (std::size_t i = 0; i < drives_->size(); ++i) dc.push_back(drives_->drive(i).config());
    for (auto& c : dc) tweak(c);
    drives_ = std::make_unique<SimDriveSet>(drive_bus_, dc);
  }
  // A master with these settings in place of the default one.
  void remake_master(const std::function<void(canopen::MasterConfig&)>& tweak) {
    tweak(config_);
    master_ = std::make_unique<canopen::Master>(master_bus_, config_);
  }
  // Another device on the bus (another master, an attacker): sends raw frames.
  void forge(uint32_t id, std::vector<uint8_t> data) {
    can::CanFrame f;
    f.id = id;
    f.dlc = static_cast<uint8_t>(data.size());
    std::copy(data.begin(), data.end(), f.data.begin());
    intruder_.send(f);
  }
  // EMCY codes from node `node` heard on the bus since the last call.
  std::vector<uint16_t> emcy_heard(uint8_t node) {
    std::vector<uint16_t> out;
    while (auto f = intruder_.receive())
      if (f->id == canopen::cob::kEmcy + node && f->dlc == 8) out.push_back(canopen::get_u16(f->data.data()));
    return out;
  }

  void start_and_enable() {
    master_->start(now_);
    run(0.5);
    ASSERT_EQ(master_->phase(), MasterPhase::kRunning) << master_->error();
    master_->set_goal(DriveGoal::kEnabled);
    run(0.1);
    ASSERT_TRUE(master_->all_in(canopen::Cia402State::kOperationEnabled));
  }
  // Moving, the arm is stopped (an e-stop: quick stop, zero velocity); 20 ms
  // into the ramp the master stalls 30 ms (past the 25 ms RPDO deadline),
  // then both run 0.5 s.
  void stop_and_stall() {
    master_->set_velocities({0.5, -0.5});
    run(0.5);
    master_->set_goal(DriveGoal::kQuickStop);
    master_->set_velocities({0.0, 0.0});
    run(0.02);
    ASSERT_GT(std::abs(master_->drives()[0].velocity), 0.2) << "still ramping down";
    emcy_heard(1);
    run_drives(0.03);
    EXPECT_EQ(emcy_heard(1), std::vector<uint16_t>{0x8250});
    run(0.5);
  }

  can::MemoryWire wire_;
  can::MemoryBus& master_bus_ = wire_.attach();
  can::MemoryBus& drive_bus_ = wire_.attach();
  can::MemoryBus& intruder_ = wire_.attach();
  canopen::MasterConfig config_;
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

TEST_F(MasterWithDrives, DrivesIgnoreFramesUntilTheirBootUpMessage) {
  // The master starts while the drives' process only drains its socket (its first step not yet due).
  master_->start(now_);
  for (int i = 0; i < 50; ++i) {
    now_ += 1000;
    master_->drain(now_);
    drives_->drain(now_);
  }
  run(0.5);
  ASSERT_EQ(master_->phase(), MasterPhase::kRunning) << master_->error();
  EXPECT_FALSE(master_->any_fault()) << master_->error();
  master_->set_goal(DriveGoal::kEnabled);
  run(0.1);
  EXPECT_TRUE(master_->all_in(canopen::Cia402State::kOperationEnabled));
}

// ---- Drive-side protection (CiA 301 0x1016, 0x1400:05; CiA 402 0x6007, 0x6085).

TEST_F(MasterWithDrives, ConfiguresEachDrivesOwnProtection) {
  remake_master([](canopen::MasterConfig& c) {
    for (auto& d : c.drives) d.quick_stop_deceleration = 9.0;
  });
  start_and_enable();
  const auto& od = drives_->drive(1).dictionary();
  EXPECT_EQ(od.get(0x1016, 1), (127u << 16) | 50u) << "consumes the master's heartbeat (node 127, 50 ms)";
  EXPECT_EQ(od.get(0x1400, 5), 25u) << "RPDO1 deadline 25 ms";
  EXPECT_EQ(od.get(0x6007, 0), 3u) << "abort connection: quick stop";
  EXPECT_EQ(od.get(0x6085, 0), 3'753'000u) << "9 rad/s^2 at 417000 counts/rad";
}

// The master's process is killed while the joints turn: no RPDO, no SYNC, no
// heartbeat. Each drive sees its RPDO1 deadline pass, sends EMCY 0x8250 and
// quick-stops itself at its 0x6085 ramp.
TEST_F(MasterWithDrives, DrivesQuickStopThemselvesWhenTheMasterFallsSilent) {
  remake_master([](canopen::MasterConfig& c) {
    for (auto& d : c.drives) d.quick_stop_deceleration = 9.0;
  });
  start_and_enable();
  master_->set_velocities({0.5, -0.5});
  run(0.5);
  emcy_heard(1);
  ASSERT_NEAR(drives_->drive(0).velocity(), 0.5, 1e-9);
  run_drives(0.024);  // run() ended on a SYNC: the last RPDO came with it
  EXPECT_EQ(drives_->drive(0).state(), canopen::Cia402State::kOperationEnabled) << "not before the 25 ms deadline";
  run_drives(0.003);
  EXPECT_EQ(drives_->drive(0).state(), canopen::Cia402State::kQuickStopActive);
  EXPECT_EQ(drives_->drive(1).state(), canopen::Cia402State::kQuickStopActive);
  EXPECT_EQ(emcy_heard(1), std::vector<uint16_t>{0x8250});
  run_drives(0.5 / 9.0 + 0.002);
  EXPECT_EQ(drives_->drive(0).velocity(), 0.0) << "stopped at 9 rad/s^2";
  EXPECT_EQ(drives_->drive(1).velocity(), 0.0);
  EXPECT_EQ(drives_->drive(0).nmt_state(), canopen::NmtState::kOperational) << "0x1029:01 = 1: no NMT change";
}

// The link's loop stalls past the RPDO deadline while the arm ramps down from
// an e-stop (a loaded computer), then goes on. The drives stop themselves and,
// left operational (0x1029:01 = 1), keep sending their TPDOs: the master sees
// the joints come to rest. At the CiA 301 default (pre-operational) the TPDOs
// end and the master's reading freezes mid-ramp: the arm looks as if it moved.
TEST_F(MasterWithDrives, AfterAStallTheMasterStillSeesTheDrivesStop) {
  remake_master([](canopen::MasterConfig& c) {
    for (auto& d : c.drives) d.quick_stop_deceleration = 9.0;
  });
  start_and_enable();
  EXPECT_EQ(drives_->drive(0).dictionary().get(0x1029, 1), 1u) << "0x1029:01 written: no NMT change";
  stop_and_stall();
  EXPECT_EQ(drives_->drive(0).velocity(), 0.0);
  EXPECT_EQ(drives_->drive(0).nmt_state(), canopen::NmtState::kOperational);
  EXPECT_EQ(master_->drives()[0].velocity, 0.0) << "the master saw the joint stop";
  EXPECT_EQ(master_->drives()[1].velocity, 0.0);
  EXPECT_FALSE(master_->drives()[0].pdo_lost);
}

TEST_F(MasterWithDrives, AtTheCia301DefaultAStallFreezesTheMastersReading) {
  remake_master([](canopen::MasterConfig& c) {
    c.drive_communication_error = 0;  // pre-operational
    for (auto& d : c.drives) d.quick_stop_deceleration = 9.0;
  });
  start_and_enable();
  EXPECT_EQ(drives_->drive(0).dictionary().get(0x1029, 1), 0u);
  stop_and_stall();
  EXPECT_EQ(drives_->drive(0).velocity(), 0.0) << "the drive stopped itself";
  EXPECT_EQ(drives_->drive(0).nmt_state(), canopen::NmtState::kPreOperational);
  EXPECT_GT(std::abs(master_->drives()[0].velocity), 0.05) << "the last TPDO before pre-operational";
  EXPECT_TRUE(master_->drives()[0].pdo_lost);
}

// The whole host freezes 150 ms while the arm moves: the simulated drives and
// the link stop together, and on waking each would find the other silent past
// its deadline (PDO 100 ms, RPDO 25 ms). Neither is: the time a process itself
// did not run counts only up to its own_stall against the other
// (rt::AwakeClock). With own_stall off on both ends the same freeze faults both.
TEST_F(MasterWithDrives, AFrozenHostIsNotADriveFaultOnEitherEnd) {
  for (const bool aware : {true, false}) {
    SCOPED_TRACE(aware ? "own stalls discounted" : "own stalls off");
    remake_master([&](canopen::MasterConfig& c) { c.own_stall = aware ? 30'000 : 0; });
    remake_drives([&](SimDriveConfig& c) { c.own_stall_us = aware ? 10'000 : 0; });
    start_and_enable();
    master_->set_velocities({0.5, -0.5});
    run(0.3);
    emcy_heard(1);
    freeze(0.15);
    run(0.5);
    if (aware) {
      EXPECT_FALSE(master_->any_fault()) << master_->drives()[0].fault_text;
      EXPECT_TRUE(emcy_heard(1).empty());
      EXPECT_EQ(drives_->drive(0).state(), canopen::Cia402State::kOperationEnabled);
      EXPECT_NEAR(drives_->drive(0).velocity(), 0.5, 1e-9) << "still following the master";
      EXPECT_EQ(master_->awake().stalls(), 1);
      EXPECT_EQ(master_->awake().lost_us(), 150'000 + 1000 - 30'000);  // the first step after it was 151 ms
      EXPECT_EQ(master_->counters().at("can_own_stalls"), 1);
    } else {
      EXPECT_TRUE(master_->drives()[0].pdo_lost);
      EXPECT_EQ(emcy_heard(1), (std::vector<uint16_t>{0x8130, 0x8250})) << "heartbeat and RPDO deadlines";
    }
  }
}

// A drive that falls silent while the master runs is still lost after the
// PDO timeout with own stalls discounted (the default): only gaps of the
// master's own loop are discounted, not the drive's.
TEST_F(MasterWithDrives, ASilentDriveIsLostAfterThePdoTimeoutDespiteOwnStallDiscount) {
  ASSERT_EQ(config_.own_stall, 30'000) << "the default";
  start_and_enable();
  drives_->drive(0).set_silent(true);
  run(0.1);
  EXPECT_FALSE(master_->drives()[0].pdo_lost);
  run(0.02);
  EXPECT_TRUE(master_->drives()[0].pdo_lost);
  EXPECT_EQ(master_->awake().stalls(), 0);
}

// Without an RPDO deadline (a drive that has none), the consumed heartbeat
// alone stops it: EMCY 0x8130 after the consumer time.
TEST_F(MasterWithDrives, LostMasterHeartbeatAloneStopsTheDrives) {
  remake_master([](canopen::MasterConfig& c) { c.drive_rpdo_timeout_ms = 0; });
  start_and_enable();
  master_->set_velocities({0.4, 0.4});
  run(0.5);
  emcy_heard(1);
  run_drives(0.045);
  EXPECT_EQ(drives_->drive(0).state(), canopen::Cia402State::kOperationEnabled);
  run_drives(0.02);
  EXPECT_EQ(drives_->drive(0).state(), canopen::Cia402State::kQuickStopActive);
  EXPECT_EQ(emcy_heard(1), std::vector<uint16_t>{0x8130});
}

// ---- CAN peers checked: what no drive and no master of ours would send.

TEST_F(MasterWithDrives, RpdoSyncOrSdoWriteFromAnotherMasterIsAFault) {
  start_and_enable();
  forge(0x201, {0x0F, 0x00, 0x10, 0x27, 0x00, 0x00});  // RPDO1 of node 1: enable, 10000 counts/s
  run(0.02);
  EXPECT_TRUE(master_->drives()[0].foreign);
  EXPECT_NE(master_->drives()[0].fault_text.find("an RPDO 0x201 we did not send"), std::string::npos)
      << master_->drives()[0].fault_text;
  EXPECT_FALSE(master_->drives()[1].foreign);
  master_->clear_faults();
  forge(0x080, {});  // SYNC
  run(0.02);
  EXPECT_NE(master_->bus_fault().find("another SYNC producer"), std::string::npos) << master_->bus_fault();
  EXPECT_TRUE(master_->any_fault());
  master_->clear_faults();
  forge(0x602, {0x2B, 0x40, 0x60, 0x00, 0x00, 0x00, 0x00, 0x00});  // SDO write 0x6040 = 0 to node 2
  run(0.02);
  EXPECT_NE(master_->drives()[1].fault_text.find("an SDO write to 0x6040:00 we did not send"), std::string::npos)
      << master_->drives()[1].fault_text;
  master_->clear_faults();
  master_->take_events();
  forge(0x602, {0x40, 0x41, 0x60, 0x00, 0, 0, 0, 0});  // an SDO read: logged, not a fault
  run(0.02);
  EXPECT_FALSE(master_->any_fault());
  const auto events = master_->take_events();
  ASSERT_FALSE(events.empty());
  EXPECT_NE(events.back().find("another SDO client reads 0x6041:00"), std::string::npos) << events.back();
  EXPECT_EQ(master_->counters().at("can_foreign_frames"), 4);
}

TEST_F(MasterWithDrives, ForgedHeartbeatsAndExtraTpdosAreFaults) {
  for (const auto& [state, text] :
       std::vector<std::pair<uint8_t, std::string>>{{0x04, "left operational (heartbeat: stopped)"},
                                                    {0x7F, "left operational (heartbeat: pre-operational)"},
                                                    {0x00, "rebooted (boot-up message)"}}) {
    start_and_enable();
    forge(0x701, {state});
    run(0.02);
    EXPECT_TRUE(master_->drives()[0].nmt_left) << text;
    EXPECT_NE(master_->drives()[0].fault_text.find(text), std::string::npos) << master_->drives()[0].fault_text;
    master_->clear_faults();  // the drive itself was fine: its start-up runs again and it comes back
    run(0.3);
    master_->set_goal(DriveGoal::kEnabled);
    run(0.1);
    EXPECT_FALSE(master_->any_fault()) << master_->drives()[0].fault_text;
    EXPECT_TRUE(master_->all_in(canopen::Cia402State::kOperationEnabled));
    remake_master([](canopen::MasterConfig&) {});
  }
  start_and_enable();
  forge(0x181, {0x37, 0x02, 0, 0, 0, 0});  // TPDO1 of node 1: operation enabled at position 0
  run(0.005);
  EXPECT_NE(master_->drives()[0].fault_text.find("more TPDO1 frames than SYNCs"), std::string::npos)
      << master_->drives()[0].fault_text;
}

// Stopped or reset by another master: a fault, and RESET_FAULT (clear_faults)
// runs that drive's start-up again (a reset drive has lost its configuration).
TEST_F(MasterWithDrives, NmtStopOrResetByAnotherMasterThenResetFaultRecovers) {
  for (const uint8_t cmd : {0x02, 0x81, 0x82}) {
    start_and_enable();
    master_->set_velocities({0.2, 0.2});
    run(0.3);
    forge(0x000, {cmd, 2});
    run(0.1);
    EXPECT_TRUE(master_->drives()[1].foreign) << int(cmd);
    EXPECT_NE(master_->drives()[1].fault_text.find("from another master"), std::string::npos);
    if (cmd != 0x02) {
      EXPECT_EQ(drives_->drive(1).dictionary().get(0x1400, 1) & 0x80000000u, 0x80000000u)
          << "a reset drive is back to its defaults (RPDO1 invalid)";
      EXPECT_EQ(drives_->drive(1).dictionary().get(0x1016, 1), 0u);
    }
    master_->set_goal(DriveGoal::kQuickStop);
    run(0.3);
    master_->clear_faults();
    master_->set_goal(DriveGoal::kEnabled);
    run(0.5);
    EXPECT_FALSE(master_->any_fault()) << int(cmd) << ": " << master_->drives()[1].fault_text;
    EXPECT_TRUE(master_->all_in(canopen::Cia402State::kOperationEnabled)) << int(cmd);
    EXPECT_EQ(drives_->drive(1).dictionary().get(0x1016, 1), (127u << 16) | 50u) << "configured again";
    master_->set_velocities({0.2, 0.2});
    run(0.5);
    EXPECT_NEAR(drives_->drive(1).velocity(), 0.2, 1e-9) << "moves again";
    remake_master([](canopen::MasterConfig&) {});
  }
}

TEST_F(MasterWithDrives, StateChangeWithoutACommandIsAFault) {
  start_and_enable();
  master_->set_velocities({0.2, 0.2});
  run(0.2);
  drives_->drive(1).local_disable();  // safe torque off, a local panel: not us
  run(0.03);
  EXPECT_TRUE(master_->drives()[1].uncommanded);
  EXPECT_NE(master_->drives()[1].fault_text.find(
                "state changed from operation enabled to switch on disabled without a command"),
            std::string::npos)
      << master_->drives()[1].fault_text;
  EXPECT_FALSE(master_->drives()[0].faulted()) << "commanded transitions are no fault";
  master_->set_goal(DriveGoal::kQuickStop);
  run(0.2);
  EXPECT_FALSE(master_->drives()[0].uncommanded) << "our own quick stop is commanded";
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
