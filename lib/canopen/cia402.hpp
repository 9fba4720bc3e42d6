// CiA 402 (IEC 61800-7-201) drive state machine: statusword decoding and
// controlword commands for the master, and the device side of the same
// state machine for the simulated drive.
#pragma once

#include <cstdint>

namespace harvest::canopen {

// Values match robot_state_t.drive_state (docs/can.md, docs/robot-link.md).
enum class Cia402State : int8_t {
  kNotReadyToSwitchOn = 0,
  kSwitchOnDisabled = 1,
  kReadyToSwitchOn = 2,
  kSwitchedOn = 3,
  kOperationEnabled = 4,
  kQuickStopActive = 5,
  kFaultReactionActive = 6,
  kFault = 7,
};
const char* to_string(Cia402State s);

namespace od {
inline constexpr uint16_t kDeviceType = 0x1000;
inline constexpr uint16_t kErrorRegister = 0x1001;
inline constexpr uint16_t kDeviceName = 0x1008;
inline constexpr uint16_t kHeartbeatConsumer = 0x1016;  // :01.. (producer node << 16) | time [ms]
inline constexpr uint16_t kHeartbeatProducer = 0x1017;
inline constexpr uint16_t kErrorBehaviour = 0x1029;  // :01 on a communication error: 0 pre-op, 1 none, 2 stopped
inline constexpr uint16_t kRpdoComm = 0x1400;  // + n
inline constexpr uint16_t kRpdoMap = 0x1600;
inline constexpr uint16_t kTpdoComm = 0x1800;
inline constexpr uint16_t kTpdoMap = 0x1A00;
inline constexpr uint16_t kAbortConnectionOption = 0x6007;  // i16: 0 none, 1 fault, 2 disable voltage, 3 quick stop
inline constexpr uint16_t kErrorCode = 0x603F;
inline constexpr uint16_t kControlword = 0x6040;
inline constexpr uint16_t kStatusword = 0x6041;
inline constexpr uint16_t kQuickStopOption = 0x605A;
inline constexpr uint16_t kModesOfOperation = 0x6060;
inline constexpr uint16_t kModesOfOperationDisplay = 0x6061;
inline constexpr uint16_t kPositionActual = 0x6064;
inline constexpr uint16_t kVelocityActual = 0x606C;
inline constexpr uint16_t kProfileAcceleration = 0x6083;
inline constexpr uint16_t kQuickStopDeceleration = 0x6085;
inline constexpr uint16_t kTargetVelocity = 0x60FF;
inline constexpr int8_t kModeCyclicSynchronousVelocity = 9;
inline constexpr uint32_t kDeviceTypeCia402 = 0x00020192;  // profile 402, servo drive
}  // namespace od

namespace controlword {
inline constexpr uint16_t kDisableVoltage = 0x0000;
inline constexpr uint16_t kShutdown = 0x0006;
inline constexpr uint16_t kSwitchOn = 0x0007;  // also "disable operation"
inline constexpr uint16_t kEnableOperation = 0x000F;
inline constexpr uint16_t kQuickStop = 0x0002;
inline constexpr uint16_t kFaultReset = 0x0080;  // acts on the rising edge of bit 7
}  // namespace controlword

Cia402State decode_statusword(uint16_t statusword);
uint16_t encode_statusword(Cia402State state);  // state bits + voltage enabled where the standard sets it

// What the master wants a drive to be.
enum class DriveGoal { kDisabled, kEnabled, kQuickStop };

// The master's side: the controlword that moves a drive one transition
// toward `goal` from its reported state. Fault reset needs a rising edge on
// bit 7, so from Fault it alternates kDisableVoltage and kFaultReset using
// `previous` (the last controlword sent). `allow_fault_reset` = false leaves a
// faulted drive in Fault (the safety layer latches faults until an operator resets).
uint16_t next_controlword(Cia402State state, DriveGoal goal, uint16_t previous, bool allow_fault_reset);

// The device's side: state after receiving `controlword` in `state`.
Cia402State apply_controlword(Cia402State state, uint16_t controlword, uint16_t previous);

// The master's check of a reported state change: true if going from `from`
// to `to` follows from one of the last two controlwords it sent (`last`, and
// `before` it: a TPDO may answer the SYNC before) or is one a drive makes on
// its own (not ready -> switch on disabled, the end of a quick stop, fault
// reaction -> fault, or into fault). Anything else (enabled, disabled or
// stopped by someone else) is a state change without a command.
bool commanded_transition(Cia402State from, Cia402State to, uint16_t last, uint16_t before);

}  // namespace harvest::canopen
