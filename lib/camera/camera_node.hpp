// The camera driver (docs/camera-driver.md): frames from a V4L2 device, a
// video file or an image folder (frame_source.hpp), zoomed and scaled, as
// image_t (image_codec.hpp) at a fixed rate. A camera that cannot be opened
// or is lost is retried with back-off; a file source that ends stops the
// process.
#pragma once

#include <memory>
#include <opencv2/core.hpp>
#include <string>

#include "camera/frame_source.hpp"
#include "config/config.hpp"
#include "runtime/node.hpp"
#include "runtime/process_main.hpp"

namespace harvest::camera {

struct CameraConfig {
  std::string camera = "fixed";
  std::string channel;            // default CAMERA_FIXED / CAMERA_HAND from `camera`
  std::string source = "device";  // device | video | folder
  DeviceOptions device;
  std::string path;  // video file or image folder
  bool loop = false;
  double frame_rate_hz = 30;
  int output_width = 0, output_height = 0;  // 0: the sensor size
  bool jpeg = false;
  int jpeg_quality = 90;
  cv::Rect zoom;  // sensor pixels; empty = no zoom
  double retry_initial_s = 0.5, retry_max_s = 10;
  bool stop_at_end = true;  // end of a video/folder without loop stops the process

  static CameraConfig from_yaml(const config::Node& node);
};

class CameraNode : public rt::Node {
 public:
  CameraNode(CameraConfig config, std::unique_ptr<FrameSource> source);

 protected:
  void on_attach() override;

 private:
  void try_open();
  void tick();
  void publish_frame(const cv::Mat& frame);

  CameraConfig config_;
  std::unique_ptr<FrameSource> source_;
  bool open_ = false;
  rt::Micros retry_at_ = 0;
  double backoff_s_;
};

std::unique_ptr<FrameSource> make_source(const CameraConfig& config);

// The node list of harvest-camera.
rt::NodeList make_camera(const config::Node& cfg, const rt::ProcessEnv& env);

}  // namespace harvest::camera
