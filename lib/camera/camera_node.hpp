// The camera driver (docs/camera-driver.md): frames from a V4L2 device, a
// video file or an image folder (frame_source.hpp), zoomed and scaled, as
// image_t (image_codec.hpp) at a fixed rate. A camera that cannot be opened
// or is lost is retried with back-off; a file source that ends stops the
// process.
#pragma once

#include <memory>
#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "camera/frame_source.hpp"
#include "config/config.hpp"
#include "config/schema.hpp"
#include "runtime/node.hpp"
#include "runtime/process_main.hpp"

namespace harvest::camera {

// The keys of config/vision/camera-*.yaml (docs/camera-driver.md); `device`
// is device_keys.
namespace camera_keys {
using config::Key;
inline constexpr Key<std::string> camera{"camera", "fixed", {}, "", "the camera's name (fixed, hand)"};
inline constexpr Key<std::string> channel{.name = "channel", .doc = "images out",
                                          .derived = "CAMERA_HAND for camera hand, else CAMERA_FIXED"};
inline constexpr config::Choice source{"source", "device", {"device", "video", "folder"}, "where frames come from"};
inline constexpr Key<config::Path> path{.name = "path", .doc = "source video or folder: the file or folder",
                                        .derived = "required unless source is device"};
inline constexpr Key<bool> loop{"loop", false, {}, "", "start a video or folder again at its end"};
inline constexpr Key<double> frame_rate_hz{"frame_rate_hz", 30.0, {0.01, 1000.0}, "Hz", "frames published"};
inline constexpr Key<int> output_width{"output_width", 0, {0, 8192}, "px", "binned output width (0: the sensor's)"};
inline constexpr Key<int> output_height{"output_height", 0, {0, 8192}, "px",
                                        "binned output height, set together with output_width"};
inline constexpr config::Choice encoding{"encoding", "bgr8", {"bgr8", "jpeg"}, "image encoding"};
inline constexpr Key<int> jpeg_quality{"jpeg_quality", 90, {1, 100}, "", "JPEG quality"};
inline constexpr config::Numbers zoom_roi_px{"zoom_roi_px", 4, {0, 0, 0, 0}, "px",
                                             "x, y, width, height of a sensor region to publish (width 0: no zoom)"};
inline constexpr Key<double> retry_initial_s{"retry_initial_s", 0.5, {0.01, 3600.0}, "s",
                                             "first wait before opening a failed source again, doubled ..."};
inline constexpr Key<double> retry_max_s{"retry_max_s", 10.0, {0.01, 3600.0}, "s",
                                         "... up to this (at least retry_initial_s)"};
inline constexpr Key<bool> stop_at_end{"stop_at_end", true, {}, "",
                                       "the end of a video or folder without loop stops the process"};
}  // namespace camera_keys

struct CameraConfig {
  std::string camera{camera_keys::camera.fallback};
  std::string channel;                                 // default CAMERA_FIXED / CAMERA_HAND from `camera`
  std::string source{camera_keys::source.fallback};  // device | video | folder
  DeviceOptions device;
  std::string path;  // video file or image folder
  bool loop = camera_keys::loop.fallback;
  double frame_rate_hz = camera_keys::frame_rate_hz.fallback;
  int output_width = camera_keys::output_width.fallback, output_height = camera_keys::output_height.fallback;
  bool jpeg = camera_keys::encoding.fallback == "jpeg";
  int jpeg_quality = camera_keys::jpeg_quality.fallback;
  cv::Rect zoom;  // sensor pixels; empty = no zoom
  double retry_initial_s = camera_keys::retry_initial_s.fallback, retry_max_s = camera_keys::retry_max_s.fallback;
  bool stop_at_end = camera_keys::stop_at_end.fallback;  // end of a video/folder without loop stops the process

  static CameraConfig from_yaml(const config::Node& node);
  static std::vector<config::Section> schema();
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
