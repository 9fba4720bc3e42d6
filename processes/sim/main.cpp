// harvest-sim: the simulated orchard, arm and gripper (docs/simulator.md).
#include "runtime/process_main.hpp"
#include "sim/nodes.hpp"

int main(int argc, char** argv) { return harvest::rt::run_process(argc, argv, "sim", harvest::sim::make_sim); }
