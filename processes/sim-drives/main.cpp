// harvest-sim-drives: simulated CiA 402 drives of the arm on the virtual CAN bus (docs/robot-link.md).
#include "simdrive/nodes.hpp"

int main(int argc, char** argv) {
  return harvest::rt::run_process(argc, argv, "sim-drives", harvest::simdrive::make_sim_drives);
}
