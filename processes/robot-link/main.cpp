// harvest-robot-link: the arm's CAN bus, CiA 402 drives, kinematics and motion safety (docs/robot-link.md).
#include "arm/nodes.hpp"

int main(int argc, char** argv) {
  return harvest::rt::run_process(argc, argv, "robot-link", harvest::arm::make_robot_link);
}
