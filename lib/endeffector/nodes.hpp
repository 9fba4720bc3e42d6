// Node factories of the end-effector processes (used by the process mains
// and by the replay tool).
#pragma once

#include "config/config.hpp"
#include "runtime/process_main.hpp"

namespace harvest::endeffector {

// harvest-ee-bridge
rt::NodeList make_ee_bridge(const config::Node& cfg, const rt::ProcessEnv& env);

}  // namespace harvest::endeffector
