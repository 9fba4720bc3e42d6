// What the demo's integration tests share: harvest-demo started as a child
// on a private LCM URL, its summary written into the test's folder.
#pragma once

#include <chrono>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "test_support.hpp"

namespace harvest::testing {

inline std::string slurp(const std::filesystem::path& p) {
  std::ifstream f(p);
  std::stringstream s;
  s << f.rdbuf();
  return s.str();
}

// harvest-demo with `extra` options, output in dir/out, summary in
// dir/summary.json; its exit code (-1 when it overran `timeout`).
inline int run_demo(const std::vector<std::string>& extra, const std::filesystem::path& dir, std::string* output,
                    std::chrono::seconds timeout = std::chrono::seconds(240)) {
  std::vector<std::string> argv = {bin("harvest-demo"),
                                   "--no-plots",
                                   "--lcm-url",
                                   unique_lcm_url(),
                                   "--out",
                                   (dir / "out").string(),
                                   "--summary",
                                   (dir / "summary.json").string()};
  argv.insert(argv.end(), extra.begin(), extra.end());
  ChildProcess p(argv, dir / "demo.txt");
  const int code = p.wait(timeout);
  *output = p.output();
  return code;
}

}  // namespace harvest::testing
