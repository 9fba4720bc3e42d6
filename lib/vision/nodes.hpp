// Nodes and node factories of the perception processes (docs/perception.md,
// docs/camera-driver.md). The process mains and the replay tool build nodes
// by process name through the make_* factories.
#pragma once

#include <memory>
#include <opencv2/core.hpp>
#include <optional>
#include <string>

#include "config/config.hpp"
#include "harvest/fruit_detections_t.hpp"
#include "harvest/image_t.hpp"
#include "runtime/node.hpp"
#include "runtime/process_main.hpp"
#include "vision/camera_model.hpp"
#include "vision/frame_source.hpp"
#include "vision/fruit_detector.hpp"
#include "vision/reconstructor.hpp"
#include "vision/tracking.hpp"

namespace harvest::vision {

// ---- camera driver ----

struct CameraConfig {
  std::string camera = "fixed";
  std::string channel;                   // default CAMERA_FIXED / CAMERA_HAND from `camera`
  std::string source = "device";         // device | video | folder
  DeviceOptions device;
  std::string path;                      // video file or image folder
  bool loop = false;
  double frame_rate_hz = 30;
  int output_width = 0, output_height = 0;  // 0: the sensor size
  bool jpeg = false;
  int jpeg_quality = 90;
  cv::Rect zoom;                          // sensor pixels; empty = no zoom
  double retry_initial_s = 0.5, retry_max_s = 10;
  bool stop_at_end = true;                // end of a video/folder without loop stops the process

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

// ---- fruit detector ----

struct DetectorNodeConfig {
  std::string camera = "fixed";
  std::string input_channel, output_channel;  // default from `camera`
  CameraModel calibration;
  DetectorConfig detector;
  static DetectorNodeConfig from_yaml(const config::Node& node);
};

// Pure function of the node: one image message -> its detections (sensor pixels).
fruit_detections_t detect_image(const image_t& image, const DetectorNodeConfig& config, FruitDetector& detector);

class DetectorNode : public rt::Node {
 public:
  explicit DetectorNode(DetectorNodeConfig config);

 protected:
  void on_attach() override;

 private:
  void on_image(const image_t& image);
  DetectorNodeConfig config_;
  FruitDetector detector_;
  PixelTracker tracker_;
};

// ---- reconstructor ----

class ReconstructorNode : public rt::Node {
 public:
  explicit ReconstructorNode(ReconstructorConfig config);

 protected:
  void on_attach() override;

 private:
  void publish_or_report(const std::optional<targets_t>& targets, const char* counter);
  Reconstructor reconstructor_;
};

// ---- factories ----
rt::NodeList make_camera(const config::Node& cfg, const rt::ProcessEnv& env);
rt::NodeList make_fruit_detector(const config::Node& cfg, const rt::ProcessEnv& env);
rt::NodeList make_reconstructor(const config::Node& cfg, const rt::ProcessEnv& env);

}  // namespace harvest::vision
