// harvest-camera: camera driver (V4L2 device, video file or image folder) -> image_t (docs/camera-driver.md).
#include "vision/nodes.hpp"

int main(int argc, char** argv) {
  return harvest::rt::run_process(argc, argv, "camera", harvest::vision::make_camera);
}
