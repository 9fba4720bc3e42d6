// The demo runs the committed process set unchanged except for what one run
// needs: extra arguments for named processes (the simulator's scenario and run
// number, --set overrides given on the demo's command line), and absolute
// working directories and executables so the copy can live anywhere.
#pragma once

#include <filesystem>
#include <map>
#include <string>
#include <vector>

namespace harvest::demo {

struct SetRewrite {
  std::filesystem::path set_file;  // the committed set, e.g. config/sets/sim.yaml
  // Appended to the args of the process of that name; every name must exist.
  std::map<std::string, std::vector<std::string>> extra_args;
  std::filesystem::path bin_dir;  // empty: keep the set's
};

// Returns the YAML text of the rewritten set. Throws std::runtime_error naming
// the file when it cannot be read or lacks a process named in extra_args.
std::string rewrite_set(const SetRewrite& r);

}  // namespace harvest::demo
