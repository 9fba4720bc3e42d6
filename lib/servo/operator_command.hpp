// The verbs of harvest-operator and the messages they become.
#pragma once

#include <string>
#include <variant>
#include <vector>

#include "harvest/emergency_stop_t.hpp"
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

}  // namespace harvest::servo
