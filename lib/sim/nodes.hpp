// Node factories of the simulator processes.
#pragma once

#include "config/config.hpp"
#include "runtime/process_main.hpp"

namespace harvest::sim {

// harvest-sim: reads `scenario` (a path relative to the configuration file)
// and the SimConfig keys; see docs/simulator.md.
harvest::rt::NodeList make_sim(const harvest::config::Node& cfg, const harvest::rt::ProcessEnv& env);

}  // namespace harvest::sim
