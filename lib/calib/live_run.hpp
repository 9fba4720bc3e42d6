// Running one calibration node on live LCM from the command line (collecting
// views, locating the board, moving the arm through a plan).
#pragma once

#include <string>

#include "runtime/node.hpp"

namespace harvest::calib {

// Runs `node` on live LCM until the node stops the runner, stop_live() is
// called, Ctrl-C or SIGTERM arrives, or `timeout_s` passes (0: no limit).
// Returns the runner's exit code.
int run_live(rt::Node& node, const std::string& lcm_url, const std::string& prefix, double timeout_s);

// Ends the run_live() in progress (from a node's callback); nothing if none.
void stop_live();

}  // namespace harvest::calib
