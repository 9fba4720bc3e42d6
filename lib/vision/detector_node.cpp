#include "vision/detector_node.hpp"

#include <cmath>
#include <opencv2/core/utility.hpp>

#include "camera/image_codec.hpp"
#include "config/schema.hpp"
#include "runtime/channels.hpp"
#include "vision/depth.hpp"

namespace harvest::vision {

using camera::decode_image;
using camera::DecodedImage;
using camera::image_roi;

DetectorNodeConfig DetectorNodeConfig::from_yaml(const config::Node& n) {
  namespace k = detector_node_keys;
  DetectorNodeConfig c;
  c.camera = n.get(k::camera);
  c.input_channel =
      n.get(k::input_channel, std::string(c.camera == "hand" ? channels::kCameraHand : channels::kCameraFixed));
  c.output_channel =
      n.get(k::output_channel, std::string(c.camera == "hand" ? channels::kFruitHand : channels::kFruitFixed));
  c.calibration = geometry::CameraModel::from_config(n, k::calibration, "config/cameras/" + c.camera + ".yaml");
  c.detector = DetectorConfig::from_yaml(n.child("detector"));
  return c;
}

std::vector<config::Section> DetectorNodeConfig::schema() {
  namespace k = detector_node_keys;
  const std::string where =
      "harvest-fruit-detector, config/vision/detector-*.yaml (docs/perception.md); the same `detector` mapping "
      "in the simulator's and offline tools' files.";
  return {config::section("fruit_detector", where, k::camera, k::input_channel, k::output_channel, k::calibration),
          DetectorConfig::schema("fruit_detector.detector", where)};
}

fruit_detections_t detect_image(const image_t& image, const DetectorNodeConfig& config, FruitDetector& detector) {
  fruit_detections_t out{};
  out.header.utime = image.header.utime;
  out.header.frame_id = image.header.frame_id;
  out.header.source_seq = image.header.seq;
  out.camera = config.camera;
  out.image_width = image.sensor_width > 0 ? image.sensor_width : image.width;
  out.image_height = image.sensor_height > 0 ? image.sensor_height : image.height;
  out.status = fruit_detections_t::STATUS_OK;
  out.selected_index = -1;
  out.num_fruits = 0;

  // A frame is never larger than the sensor it comes from: that bounds what a JPEG may decode to.
  const DecodedImage decoded =
      decode_image(image, static_cast<int64_t>(config.calibration.width) * config.calibration.height);
  std::string error = decoded.error;
  if (error.empty() && (out.image_width != config.calibration.width || out.image_height != config.calibration.height))
    error = "sensor size " + std::to_string(out.image_width) + "x" + std::to_string(out.image_height) +
            " does not match the " + std::to_string(config.calibration.width) + "x" +
            std::to_string(config.calibration.height) + " calibration";
  if (!error.empty()) {
    out.status = fruit_detections_t::STATUS_BAD_IMAGE;
    out.status_text = error;
    return out;
  }
  // Detections are made in image pixels, reported in sensor pixels (zoom).
  const cv::Rect2d roi = image_roi(image);
  const double sx = roi.width / decoded.bgr.cols, sy = roi.height / decoded.bgr.rows;
  const Detections d = detector.detect(decoded.bgr);
  for (const Fruit& f : d.fruits) {
    fruit_t t{};
    t.id = -1;
    t.u_px = static_cast<float>((f.u + 0.5) * sx + roi.x - 0.5);
    t.v_px = static_cast<float>((f.v + 0.5) * sy + roi.y - 0.5);
    t.diameter_px = static_cast<float>(f.diameter_px * 0.5 * (sx + sy));
    t.diameter_x_px = static_cast<float>(f.diameter_x_px * sx);
    t.diameter_y_px = static_cast<float>(f.diameter_y_px * sy);
    t.area_px = static_cast<float>(f.area_px * sx * sy);
    t.roundness = static_cast<float>(f.roundness);
    t.visible_fraction = static_cast<float>(f.visible_fraction);
    t.confidence = static_cast<float>(f.confidence);
    t.depth_m = static_cast<float>(depth_from_diameter(config.calibration.fx, config.calibration.fy,
                                                       config.detector.fruit_diameter_m, t.diameter_px));
    t.cost = static_cast<float>(f.cost);
    t.selected = f.selected;
    t.bbox_px[0] = static_cast<int32_t>(std::floor(f.bbox.x * sx + roi.x));
    t.bbox_px[1] = static_cast<int32_t>(std::floor(f.bbox.y * sy + roi.y));
    t.bbox_px[2] = static_cast<int32_t>(std::ceil(f.bbox.width * sx));
    t.bbox_px[3] = static_cast<int32_t>(std::ceil(f.bbox.height * sy));
    out.fruits.push_back(t);
  }
  out.num_fruits = static_cast<int32_t>(out.fruits.size());
  out.selected_index = d.selected;
  return out;
}

DetectorNode::DetectorNode(DetectorNodeConfig config)
    : rt::Node("fruit-detector-" + config.camera),
      config_(std::move(config)),
      detector_(config_.detector, config_.calibration.fx, config_.calibration.fy),
      tracker_(1.0, 10, 0) {
  // One thread for OpenCV: a camera's detector has a core at most (two
  // detectors, a reconstructor and a controller share two), and OpenCV's
  // pool spinning on a 320x240 frame's connected components and distance
  // map cost more CPU than it saved wall time.
  cv::setNumThreads(1);
}

void DetectorNode::on_attach() {
  advertise(config_.output_channel);
  subscribe<image_t>(config_.input_channel, [this](const image_t& m) { on_image(m); });
}

void DetectorNode::on_image(const image_t& image) {
  fruit_detections_t out = detect_image(image, config_, detector_);
  if (out.status != fruit_detections_t::STATUS_OK) {
    count("bad_images");
    set_health(rt::Health::kError, "image seq " + std::to_string(image.header.seq) + " on " + config_.input_channel +
                                       ": " + out.status_text);
  } else {
    std::vector<PixelObservation> obs;
    for (const fruit_t& f : out.fruits) obs.push_back({f.u_px, f.v_px, f.diameter_px});
    const auto ids = tracker_.update(obs);
    for (std::size_t i = 0; i < ids.size(); ++i) out.fruits[i].id = ids[i];
    count("fruits", out.num_fruits);
    if (health() != rt::Health::kOk) set_health(rt::Health::kOk);
  }
  publish(config_.output_channel, out);
}

rt::NodeList make_fruit_detector(const config::Node& cfg, const rt::ProcessEnv&) {
  rt::NodeList nodes;
  nodes.push_back(std::make_unique<DetectorNode>(DetectorNodeConfig::from_yaml(cfg)));
  return nodes;
}

}  // namespace harvest::vision
