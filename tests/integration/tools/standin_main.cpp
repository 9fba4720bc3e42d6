// tools-standin: the stand-in process of the tooling tests (standin_node.hpp).
#include "standin_node.hpp"

int main(int argc, char** argv) {
  return harvest::rt::run_process(argc, argv, "tools-standin", harvest::testing::make_tools_standin);
}
