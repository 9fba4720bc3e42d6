// Node factories of the servo processes (used by the process mains and by
// the replay tool to build nodes by process name).
#pragma once

#include "config/config.hpp"
#include "runtime/process_main.hpp"

namespace harvest::servo {

// harvest-servo-controller: one ServoControllerNode configured from the root.
rt::NodeList make_servo_controller(const config::Node& cfg, const rt::ProcessEnv& env);

}  // namespace harvest::servo
