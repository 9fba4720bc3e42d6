// Node factory of harvest-sim-drives (used by the process main and the replay tool).
#pragma once

#include "config/config.hpp"
#include "runtime/process_main.hpp"

namespace harvest::simdrive {

// harvest-sim-drives
rt::NodeList make_sim_drives(const config::Node& cfg, const rt::ProcessEnv& env);

}  // namespace harvest::simdrive
