#include "servo/harvest/states.hpp"

#include <array>

namespace harvest::servo {

namespace {

using M = Motion;
using T = Timeouts;
using E = Expiry;
using O = fruit_outcome_t;

// clang-format off
constexpr int8_t kNo = 0;
constexpr std::array<StateSpec, 19> kStates{{
  // state              name           motion        timeout          running follows rests  when the timeout expires
  {State::kIdle,       "IDLE",        M::kNone,     nullptr,          false,  false,  true,  E::kNone, kNo, ""},
  {State::kSelect,     "SELECT",      M::kNone,     &T::select,       true,   false,  false, E::kDone, kNo,
                                                                                   "no view from the fixed camera"},
  {State::kOrient,     "ORIENT",      M::kPoseGoal, &T::motion,       true,   false,  false, E::kMotionBlocked, kNo, ""},
  {State::kOrientPd,   "ORIENT_PD",   M::kTwist,    &T::motion,       true,   false,  false, E::kMotionBlocked, kNo, ""},
  {State::kAcquire,    "ACQUIRE",     M::kTwist,    &T::acquire,      true,   true,   false, E::kGiveUp, O::LOST,
                                                                                   "not seen by the camera-in-hand"},
  {State::kApproach,   "APPROACH",    M::kTwist,    &T::approach,     true,   true,   false, E::kGiveUpRetreat, O::LOST,
                                                                                   "approach timed out"},
  {State::kReacquire,  "REACQUIRE",   M::kTwist,    &T::reacquire,    true,   true,   false, E::kGiveUpRetreat, O::LOST,
                                                                                   "lost from view, not re-acquired"},
  {State::kIrApproach, "IR_APPROACH", M::kTwist,    &T::ir_approach,  true,   true,   false, E::kIrAttempt,
                                                                    O::FAILED_GRASP, "IR sensor never triggered"},
  {State::kBackoff,    "BACKOFF",     M::kPoseGoal, &T::motion,       true,   false,  false, E::kMotionBlocked, kNo, ""},
  {State::kGrasp,      "GRASP",       M::kTwist,    &T::grasp,        true,   false,  false, E::kFault, kNo,
                                                                       "gripper did not report holding or closed in time"},
  {State::kDetach,     "DETACH",      M::kPoseGoal, &T::motion,       true,   false,  false, E::kMotionBlocked, kNo, ""},
  {State::kDrop,       "DROP",        M::kPoseGoal, &T::motion,       true,   false,  false, E::kMotionBlocked, kNo, ""},
  {State::kRelease,    "RELEASE",     M::kStop,     &T::release,      true,   false,  false, E::kFault, kNo,
                                                                                   "gripper did not report open in time"},
  {State::kRetreat,    "RETREAT",     M::kPoseGoal, &T::motion,       true,   false,  false, E::kMotionBlocked, kNo, ""},
  {State::kReturn,     "RETURN",      M::kPoseGoal, &T::motion,       true,   false,  false, E::kMotionBlocked, kNo, ""},
  {State::kHoming,     "HOMING",      M::kPoseGoal, &T::motion,       true,   false,  false, E::kMotionBlocked, kNo, ""},
  {State::kDone,       "DONE",        M::kNone,     nullptr,          false,  false,  true,  E::kNone, kNo, ""},
  {State::kFault,      "FAULT",       M::kStop,     nullptr,          false,  false,  false, E::kNone, kNo, ""},
  {State::kEstop,      "ESTOP",       M::kStop,     nullptr,          false,  false,  false, E::kNone, kNo, ""},
}};
// clang-format on

constexpr bool rows_in_enum_order() {
  for (std::size_t i = 0; i < kStates.size(); ++i)
    if (static_cast<std::size_t>(kStates[i].state) != i) return false;
  return true;
}
static_assert(rows_in_enum_order(), "kStates rows must follow the State enum");

}  // namespace

const StateSpec& spec(State s) { return kStates.at(static_cast<std::size_t>(s)); }
const char* state_name(State s) { return spec(s).name; }

}  // namespace harvest::servo
