// harvest-servo-controller: the harvest sequence (docs/servo-controller.md).
#include "servo/nodes.hpp"

int main(int argc, char** argv) {
  return harvest::rt::run_process(argc, argv, "servo-controller", harvest::servo::make_servo_controller);
}
