// harvest-fruit-detector: image_t -> fruit_detections_t, one instance per camera (docs/perception.md).
#include "vision/detector_node.hpp"

int main(int argc, char** argv) {
  return harvest::rt::run_process(argc, argv, "fruit-detector", harvest::vision::make_fruit_detector);
}
