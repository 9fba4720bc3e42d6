// The demo runs the committed process set unchanged except for what one run
// needs: the scenario and run number given to the simulator, and absolute
// working directories and executables so the copy can live anywhere.
#pragma once

#include <filesystem>
#include <string>
#include <vector>

namespace harvest::demo {

struct SetRewrite {
  std::filesystem::path set_file;  // the committed set, e.g. config/sets/sim.yaml
  std::string sim_process = "sim";
  std::vector<std::string> sim_extra_args;  // appended to the simulator's args
  std::filesystem::path bin_dir;            // empty: keep the set's
};

// Returns the YAML text of the rewritten set. Throws std::runtime_error naming
// the file when it cannot be read or has no process called `sim_process`.
std::string rewrite_set(const SetRewrite& r);

}  // namespace harvest::demo
