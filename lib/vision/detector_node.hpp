// The fruit detector node (docs/perception.md): each image_t on the input
// channel -> its fruit_detections_t in sensor pixels (zoom undone), with
// per-fruit track ids.
#pragma once

#include <string>

#include "config/config.hpp"
#include "config/schema.hpp"
#include "geometry/camera_model.hpp"
#include "harvest/fruit_detections_t.hpp"
#include "harvest/image_t.hpp"
#include "runtime/node.hpp"
#include "runtime/process_main.hpp"
#include "vision/fruit_detector.hpp"
#include "vision/tracking.hpp"

namespace harvest::vision {

namespace detector_node_keys {
using config::Key;
inline constexpr config::Choice camera{"camera", "fixed", {"fixed", "hand"}, "which camera's images it reads"};
inline constexpr Key<std::string> input_channel{
    .name = "input_channel", .doc = "images in", .derived = "CAMERA_FIXED or CAMERA_HAND (by camera)"};
inline constexpr Key<std::string> output_channel{
    .name = "output_channel", .doc = "detections out", .derived = "FRUIT_FIXED or FRUIT_HAND (by camera)"};
inline constexpr Key<config::Path> calibration{.name = "calibration",
                                               .doc = "the camera's intrinsic calibration",
                                               .derived = "config/cameras/CAMERA.yaml"};
}  // namespace detector_node_keys

struct DetectorNodeConfig {
  std::string camera{detector_node_keys::camera.fallback};
  std::string input_channel, output_channel;  // default from `camera`
  geometry::CameraModel calibration;
  DetectorConfig detector;
  static DetectorNodeConfig from_yaml(const config::Node& node);
  static std::vector<config::Section> schema();
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

// The node list of harvest-fruit-detector.
rt::NodeList make_fruit_detector(const config::Node& cfg, const rt::ProcessEnv& env);

}  // namespace harvest::vision
