// The verbs of harvest-operator and the messages they become.
#pragma once

#include <string>
#include <variant>
#include <vector>

#include "harvest/emergency_stop_t.hpp"
#include "harvest/harvest_status_t.hpp"
#include "harvest/operator_command_t.hpp"
#include "runtime/clock.hpp"
#include "security/auth.hpp"

namespace lcm {
class LCM;
}

namespace harvest::servo {

using OperatorMessage = std::variant<operator_command_t, emergency_stop_t>;

// start, pause, resume, abort, home, reset-fault, estop, estop-clear.
const std::vector<std::string>& operator_verbs();

// The message for `verb`, stamped with `utime`; throws std::invalid_argument
// listing the valid verbs for anything else.
OperatorMessage make_operator_message(const std::string& verb, const std::string& source, const std::string& reason,
                                      rt::Micros utime);

// "USER@HOST (TOOL PID)": who sends a command, unique to this process so
// the controller's reply names this very sender.
std::string operator_source(const std::string& tool);

// How many copies of `verb` go out by default: three of an emergency stop or
// its release (UDP multicast may drop a datagram), one of anything else.
int default_repeat(const std::string& verb);

// Signs `msg` (docs/security.md: the receivers obey operator commands and an
// e-stop clear only when signed by an operator they know).
void sign_operator_message(OperatorMessage& msg, security::Signer& signer);

// Publishes `msg` on PREFIX + OPERATOR_COMMAND or EMERGENCY_STOP, `repeat`
// copies 20 ms apart, each signed afresh (a receiver refuses a repeated seq
// as a replay). The one path every operator front end (harvest-operator,
// harvest-console) sends through. Returns false when a publish fails.
bool send_operator_message(lcm::LCM& lcm, const std::string& prefix, OperatorMessage msg, int repeat,
                           security::Signer& signer);

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
