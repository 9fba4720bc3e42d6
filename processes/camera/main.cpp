// harvest-camera: camera driver (V4L2 device, video file or image folder) -> image_t (docs/camera-driver.md).
#include "camera/camera_node.hpp"

int main(int argc, char** argv) { return harvest::rt::run_process(argc, argv, "camera", harvest::camera::make_camera); }
