// harvest-demo: the simulated harvest end to end (docs/demo.md). tools/harvest
// demo builds everything and runs this.
#include <iostream>

#include "demo/demo_driver.hpp"

int main(int argc, char** argv) {
  harvest::demo::DemoOptions options;
  int code = 0;
  if (!harvest::demo::parse_demo_args(argc, argv, options, code)) return code;
  return harvest::demo::run_demo(options, std::cout, std::cerr);
}
