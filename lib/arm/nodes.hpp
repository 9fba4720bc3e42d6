// Node factories of the robot link processes (used by the process mains and
// by the replay tool).
#pragma once

#include "config/config.hpp"
#include "runtime/process_main.hpp"

namespace harvest::arm {

// harvest-robot-link
rt::NodeList make_robot_link(const config::Node& cfg, const rt::ProcessEnv& env);

}  // namespace harvest::arm
