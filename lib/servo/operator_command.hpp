// The verbs of harvest-operator and the messages they become.
#pragma once

#include <string>
#include <variant>
#include <vector>

#include "harvest/emergency_stop_t.hpp"
#include "harvest/harvest_status_t.hpp"
#include "harvest/operator_command_t.hpp"
#include "runtime/clock.hpp"

namespace harvest::servo {

using OperatorMessage = std::variant<operator_command_t, emergency_stop_t>;

// start, pause, resume, abort, home, reset-fault, estop, estop-clear.
const std::vector<std::string>& operator_verbs();

// The message for `verb`, stamped with `utime`; throws std::invalid_argument
// listing the valid verbs for anything else.
OperatorMessage make_operator_message(const std::string& verb, const std::string& source, const std::string& reason,
                                      rt::Micros utime);

// The controller's reply to one command, read from HARVEST_STATUS (it
// publishes one at once on every operator command): the summary names the
// sender of an accepted command ("started by SOURCE", "paused by SOURCE", ...)
// or of a refused one ("command refused: WHY (from SOURCE)"); an emergency
// stop shows as the latched flag, its release as the flag cleared. SOURCE
// should be unique to the sender (harvest-operator adds its pid).
enum class AckState { kWaiting, kAccepted, kRefused };
struct Acknowledgement {
  AckState state = AckState::kWaiting;
  std::string detail;  // the controller's summary line
};
Acknowledgement acknowledgement(const std::string& verb, const std::string& source, const harvest_status_t& status);

}  // namespace harvest::servo
