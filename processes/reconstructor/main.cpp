// harvest-reconstructor: fruit detections + robot state -> 3D targets (docs/perception.md).
#include "vision/reconstructor_node.hpp"

int main(int argc, char** argv) {
  return harvest::rt::run_process(argc, argv, "reconstructor", harvest::vision::make_reconstructor);
}
