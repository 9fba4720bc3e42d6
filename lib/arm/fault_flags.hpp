// robot_state_t.fault_flags: why the arm does not do what it was asked
// (docs/robot-link.md says when each is set).
#pragma once

#include <cstdint>

namespace harvest::arm {

enum FaultFlag : int32_t {
  kFlagDriveFault = 1 << 0,     // a drive reported Fault / fault reaction
  kFlagEmcy = 1 << 1,           // EMCY with an error code
  kFlagHeartbeatLost = 1 << 2,  // a drive's heartbeat timed out
  kFlagPdoLost = 1 << 3,        // a drive stopped sending PDOs
  kFlagEstop = 1 << 4,          // emergency stop latched
  kFlagCommandStale = 1 << 5,   // the last command expired (controlled stop)
  kFlagLimited = 1 << 6,        // the current command is being clipped
  kFlagRefused = 1 << 7,        // the last command was refused
  kFlagBus = 1 << 8,            // CAN bus / drive configuration failure
  kFlagEnableTimeout = 1 << 9,  // drives did not reach operation enabled in time
  kFlagForeign = 1 << 10,       // frames on the bus we did not send: another master, forged PDOs
  kFlagNmtLeft = 1 << 11,       // a drive's heartbeat says it left operational, or it rebooted
  kFlagUncommanded = 1 << 12,   // a drive's CiA 402 state changed without a command
  kFlagJointLimit = 1 << 13,    // a joint is braking for (or held at) its position limit this period
};

}  // namespace harvest::arm
