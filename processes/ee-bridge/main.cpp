// harvest-ee-bridge: the end-effector board (IR proximity + gripper) on the bus.
#include "endeffector/nodes.hpp"

int main(int argc, char** argv) {
  return harvest::rt::run_process(argc, argv, "ee-bridge", harvest::endeffector::make_ee_bridge);
}
