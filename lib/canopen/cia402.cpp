#include "canopen/cia402.hpp"

namespace harvest::canopen {

const char* to_string(Cia402State s) {
  switch (s) {
    case Cia402State::kNotReadyToSwitchOn:
      return "not ready to switch on";
    case Cia402State::kSwitchOnDisabled:
      return "switch on disabled";
    case Cia402State::kReadyToSwitchOn:
      return "ready to switch on";
    case Cia402State::kSwitchedOn:
      return "switched on";
    case Cia402State::kOperationEnabled:
      return "operation enabled";
    case Cia402State::kQuickStopActive:
      return "quick stop active";
    case Cia402State::kFaultReactionActive:
      return "fault reaction active";
    case Cia402State::kFault:
      return "fault";
  }
  return "unknown";
}

Cia402State decode_statusword(uint16_t sw) {
  // Table of CiA 402 part 2, 8.4.1: bits 6, 5, 3, 2, 1, 0.
  if ((sw & 0x4F) == 0x00) return Cia402State::kNotReadyToSwitchOn;
  if ((sw & 0x4F) == 0x40) return Cia402State::kSwitchOnDisabled;
  if ((sw & 0x6F) == 0x21) return Cia402State::kReadyToSwitchOn;
  if ((sw & 0x6F) == 0x23) return Cia402State::kSwitchedOn;
  if ((sw & 0x6F) == 0x27) return Cia402State::kOperationEnabled;
  if ((sw & 0x6F) == 0x07) return Cia402State::kQuickStopActive;
  if ((sw & 0x4F) == 0x0F) return Cia402State::kFaultReactionActive;
  if ((sw & 0x4F) == 0x08) return Cia402State::kFault;
  return Cia402State::kNotReadyToSwitchOn;  // undefined pattern: treat as not ready
}

uint16_t encode_statusword(Cia402State s) {
  switch (s) {
    case Cia402State::kNotReadyToSwitchOn:
      return 0x0000;
    case Cia402State::kSwitchOnDisabled:
      return 0x0040;
    case Cia402State::kReadyToSwitchOn:
      return 0x0021;
    case Cia402State::kSwitchedOn:
      return 0x0023 | 0x0010;
    case Cia402State::kOperationEnabled:
      return 0x0027 | 0x0010;
    case Cia402State::kQuickStopActive:
      return 0x0007 | 0x0010;
    case Cia402State::kFaultReactionActive:
      return 0x000F | 0x0010;
    case Cia402State::kFault:
      return 0x0008;
  }
  return 0;
}

uint16_t next_controlword(Cia402State state, DriveGoal goal, uint16_t previous, bool allow_fault_reset) {
  using S = Cia402State;
  namespace cw = controlword;
  if (state == S::kFault) {
    if (!allow_fault_reset || goal != DriveGoal::kEnabled) return cw::kDisableVoltage;
    return (previous & cw::kFaultReset) ? cw::kDisableVoltage : cw::kFaultReset;  // make a rising edge
  }
  if (state == S::kFaultReactionActive || state == S::kNotReadyToSwitchOn) return cw::kDisableVoltage;
  switch (goal) {
    case DriveGoal::kQuickStop:
      // Quick stop only acts from the enabled states; elsewhere the drive is not producing torque anyway.
      return (state == S::kOperationEnabled || state == S::kQuickStopActive) ? cw::kQuickStop : cw::kDisableVoltage;
    case DriveGoal::kDisabled:
      // Operation enabled -> switched on (stop torque under control) -> ready -> switch on disabled.
      if (state == S::kOperationEnabled) return cw::kSwitchOn;
      if (state == S::kSwitchedOn) return cw::kShutdown;
      return cw::kDisableVoltage;
    case DriveGoal::kEnabled:
      switch (state) {
        case S::kSwitchOnDisabled:
          return cw::kShutdown;
        case S::kReadyToSwitchOn:
          return cw::kSwitchOn;
        case S::kSwitchedOn:
          return cw::kEnableOperation;
        case S::kOperationEnabled:
          return cw::kEnableOperation;
        case S::kQuickStopActive:
          return cw::kDisableVoltage;  // leave quick stop through switch on disabled
        default:
          return cw::kDisableVoltage;
      }
  }
  return cw::kDisableVoltage;
}

Cia402State apply_controlword(Cia402State state, uint16_t cw, uint16_t previous) {
  using S = Cia402State;
  const bool fault_reset_edge = (cw & 0x80) && !(previous & 0x80);
  const bool enable_voltage = cw & 0x02;
  const bool quick_stop_inactive = cw & 0x04;  // quick stop is active low
  const bool switch_on = cw & 0x01;
  const bool enable_operation = cw & 0x08;
  switch (state) {
    case S::kFault:
      return fault_reset_edge ? S::kSwitchOnDisabled : S::kFault;  // transition 15
    case S::kFaultReactionActive:
    case S::kNotReadyToSwitchOn:
      return state;  // left by the device itself
    case S::kSwitchOnDisabled:
      return (enable_voltage && quick_stop_inactive && !switch_on) ? S::kReadyToSwitchOn : state;  // 2
    case S::kReadyToSwitchOn:
      if (!enable_voltage || !quick_stop_inactive) return S::kSwitchOnDisabled;  // 7
      if (switch_on && enable_operation) return S::kOperationEnabled;            // 3 + 4 (allowed shortcut)
      if (switch_on) return S::kSwitchedOn;                                      // 3
      return state;
    case S::kSwitchedOn:
      if (!enable_voltage || !quick_stop_inactive) return S::kSwitchOnDisabled;  // 10
      if (!switch_on) return S::kReadyToSwitchOn;                                // 6
      if (enable_operation) return S::kOperationEnabled;                         // 4
      return state;
    case S::kOperationEnabled:
      if (!enable_voltage) return S::kSwitchOnDisabled;      // 9
      if (!quick_stop_inactive) return S::kQuickStopActive;  // 11
      if (!switch_on) return S::kReadyToSwitchOn;            // 8
      if (!enable_operation) return S::kSwitchedOn;          // 5
      return state;
    case S::kQuickStopActive:
      if (!enable_voltage) return S::kSwitchOnDisabled;  // 12
      // Transition 16 (back to operation enabled) is not supported: leaving a
      // quick stop always goes through switch on disabled (quick stop option 6).
      return state;
  }
  return state;
}

bool commanded_transition(Cia402State from, Cia402State to, uint16_t last, uint16_t before) {
  using S = Cia402State;
  if (to == from || to == S::kFault || to == S::kFaultReactionActive) return true;
  if (from == S::kNotReadyToSwitchOn && to == S::kSwitchOnDisabled) return true;
  if (from == S::kFaultReactionActive && to == S::kFault) return true;
  if (from == S::kQuickStopActive && to == S::kSwitchOnDisabled) return true;  // quick stop options 1-4 end there
  if (from == S::kFault) return to == S::kSwitchOnDisabled && ((last | before) & controlword::kFaultReset);
  return apply_controlword(from, last, before) == to || apply_controlword(from, before, before) == to;
}

}  // namespace harvest::canopen
