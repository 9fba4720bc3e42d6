#include "vision/nodes.hpp"

#include <algorithm>
#include <cmath>
#include <opencv2/imgproc.hpp>

#include "runtime/channels.hpp"
#include "vision/depth.hpp"
#include "vision/image_codec.hpp"

namespace harvest::vision {

namespace {

std::string camera_channel(const std::string& camera, const char* fixed, const char* hand) {
  return camera == "hand" ? hand : fixed;
}

}  // namespace

// ---------------- camera driver ----------------

CameraConfig CameraConfig::from_yaml(const config::Node& n) {
  CameraConfig c;
  c.camera = n.get<std::string>("camera", c.camera);
  c.channel = n.get<std::string>("channel", camera_channel(c.camera, channels::kCameraFixed, channels::kCameraHand));
  c.source = n.choice("source", c.source, {"device", "video", "folder"});
  const config::Node dev = n.child("device");
  c.device.device = dev.get<std::string>("path", c.device.device);
  c.device.width = dev.get("width", c.device.width, {1, 8192});
  c.device.height = dev.get("height", c.device.height, {1, 8192});
  c.device.pixel_format = dev.get<std::string>("pixel_format", c.device.pixel_format);
  if (!c.device.pixel_format.empty() && c.device.pixel_format.size() != 4)
    dev.fail("pixel_format", "a four-character code such as MJPG or YUYV, or empty");
  if (c.source != "device") c.path = n.file_path("path").string();
  c.loop = n.get("loop", c.loop);
  c.frame_rate_hz = n.get("frame_rate_hz", c.frame_rate_hz, {0.01, 1000.0});
  c.device.fps = c.frame_rate_hz;
  c.output_width = n.get("output_width", c.output_width, {0, 8192});
  c.output_height = n.get("output_height", c.output_height, {0, 8192});
  if ((c.output_width == 0) != (c.output_height == 0)) n.fail("output_height", "set together with output_width");
  c.jpeg = n.choice("encoding", "bgr8", {"bgr8", "jpeg"}) == "jpeg";
  c.jpeg_quality = n.get("jpeg_quality", c.jpeg_quality, {1, 100});
  const std::vector<double> zoom = n.numbers("zoom_roi_px", {0, 0, 0, 0}, 4);
  c.zoom = cv::Rect(static_cast<int>(zoom[0]), static_cast<int>(zoom[1]), static_cast<int>(zoom[2]),
                    static_cast<int>(zoom[3]));
  if (c.zoom.width < 0 || c.zoom.height < 0 || c.zoom.x < 0 || c.zoom.y < 0)
    n.fail("zoom_roi_px", "x, y, width, height >= 0 (width 0 = no zoom)");
  c.retry_initial_s = n.get("retry_initial_s", c.retry_initial_s, {0.01, 3600.0});
  c.retry_max_s = n.get("retry_max_s", c.retry_max_s, {c.retry_initial_s, 3600.0});
  c.stop_at_end = n.get("stop_at_end", c.stop_at_end);
  return c;
}

std::unique_ptr<FrameSource> make_source(const CameraConfig& c) {
  if (c.source == "video") return make_video_source(c.path, c.loop);
  if (c.source == "folder") return make_folder_source(c.path, c.loop);
  return make_device_source(c.device);
}

CameraNode::CameraNode(CameraConfig config, std::unique_ptr<FrameSource> source)
    : rt::Node("camera-" + config.camera),
      config_(std::move(config)),
      source_(std::move(source)),
      backoff_s_(config_.retry_initial_s) {}

void CameraNode::on_attach() {
  advertise(config_.channel);
  try_open();
  every(static_cast<rt::Micros>(std::llround(1e6 / config_.frame_rate_hz)), [this] { tick(); });
}

void CameraNode::try_open() {
  try {
    source_->open();
    open_ = true;
    backoff_s_ = config_.retry_initial_s;
    set_health(rt::Health::kOk, "capturing from " + source_->describe());
  } catch (const std::exception& e) {
    open_ = false;
    count("open_failures");
    if (config_.source != "device") {  // a file will not get better by waiting: say which and stop
      set_health(rt::Health::kError, e.what());
      ctx().request_stop(1);
      retry_at_ = INT64_MAX;
      return;
    }
    set_health(rt::Health::kError,
               std::string(e.what()) + "; retrying in " + std::to_string(backoff_s_).substr(0, 4) + " s");
    retry_at_ = now() + static_cast<rt::Micros>(backoff_s_ * 1e6);
    backoff_s_ = std::min(2 * backoff_s_, config_.retry_max_s);
  }
}

void CameraNode::tick() {
  if (!open_) {
    if (now() >= retry_at_) try_open();
    return;
  }
  ReadResult r = source_->read();
  switch (r.status) {
    case ReadStatus::kFrame:
      publish_frame(r.frame);
      if (health() != rt::Health::kOk) set_health(rt::Health::kOk, "capturing from " + source_->describe());
      break;
    case ReadStatus::kBadFrame:
      count("bad_frames");
      set_health(rt::Health::kDegraded, r.error);
      break;
    case ReadStatus::kEnd:
      set_health(rt::Health::kOk, r.error);
      if (config_.stop_at_end) ctx().request_stop(0);
      open_ = false;
      retry_at_ = INT64_MAX;
      break;
    case ReadStatus::kLost:
      count("device_lost");
      source_->close();
      open_ = false;
      set_health(rt::Health::kError, r.error + "; reopening in " + std::to_string(backoff_s_).substr(0, 4) + " s");
      retry_at_ = now() + static_cast<rt::Micros>(backoff_s_ * 1e6);
      backoff_s_ = std::min(2 * backoff_s_, config_.retry_max_s);
      break;
  }
}

void CameraNode::publish_frame(const cv::Mat& frame) {
  image_t msg{};
  msg.header.utime = now();
  msg.header.frame_id = "camera_" + config_.camera;
  msg.header.source_seq = -1;
  msg.sensor_width = frame.cols;
  msg.sensor_height = frame.rows;
  cv::Rect roi(0, 0, frame.cols, frame.rows);
  if (config_.zoom.area() > 0) roi &= config_.zoom;
  if (roi.area() == 0) roi = cv::Rect(0, 0, frame.cols, frame.rows);  // zoom entirely outside: show all
  cv::Mat out = frame(roi);
  cv::Size size(config_.output_width, config_.output_height);
  if (size.area() == 0) size = frame.size();
  if (out.size() != size) {
    cv::Mat resized;
    cv::resize(out, resized, size, 0, 0, out.cols > size.width ? cv::INTER_AREA : cv::INTER_LINEAR);
    out = resized;
  }
  msg.roi_px[0] = static_cast<float>(roi.x);
  msg.roi_px[1] = static_cast<float>(roi.y);
  msg.roi_px[2] = static_cast<float>(roi.width);
  msg.roi_px[3] = static_cast<float>(roi.height);
  try {
    encode_image(out, config_.jpeg, config_.jpeg_quality, msg);
  } catch (const std::exception& e) {
    count("encode_failures");
    set_health(rt::Health::kDegraded, e.what());
    return;
  }
  publish(config_.channel, msg);
}

// ---------------- fruit detector ----------------

DetectorNodeConfig DetectorNodeConfig::from_yaml(const config::Node& n) {
  DetectorNodeConfig c;
  c.camera = n.choice("camera", c.camera, {"fixed", "hand"});
  c.input_channel =
      n.get<std::string>("input_channel", camera_channel(c.camera, channels::kCameraFixed, channels::kCameraHand));
  c.output_channel =
      n.get<std::string>("output_channel", camera_channel(c.camera, channels::kFruitFixed, channels::kFruitHand));
  const auto path = n.file_path("calibration", "config/cameras/" + c.camera + ".yaml");
  try {
    c.calibration = CameraModel::load(path);
  } catch (const std::exception& e) {
    n.fail("calibration", std::string("a readable camera calibration (") + e.what() + ")");
  }
  c.detector = DetectorConfig::from_yaml(n.child("detector"));
  return c;
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

  const DecodedImage decoded = decode_image(image);
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
      tracker_(1.0, 10, 0) {}

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

// ---------------- reconstructor ----------------

ReconstructorNode::ReconstructorNode(ReconstructorConfig config)
    : rt::Node("reconstructor"), reconstructor_(std::move(config)) {}

void ReconstructorNode::on_attach() {
  advertise(channels::kTargets);
  subscribe<robot_state_t>(channels::kRobotState, [this](const robot_state_t& m) { reconstructor_.on_robot_state(m); });
  subscribe<harvest_status_t>(channels::kHarvestStatus,
                              [this](const harvest_status_t& m) { reconstructor_.on_harvest_status(m); });
  subscribe<fruit_detections_t>(channels::kFruitFixed, [this](const fruit_detections_t& m) {
    publish_or_report(reconstructor_.on_fixed(m), "fixed_rejected");
  });
  subscribe<fruit_detections_t>(channels::kFruitHand, [this](const fruit_detections_t& m) {
    publish_or_report(reconstructor_.on_hand(m), "hand_rejected");
  });
  set_health(rt::Health::kOk);
}

void ReconstructorNode::publish_or_report(const std::optional<targets_t>& targets, const char* counter) {
  if (!targets) {
    count(counter);
    set_health(rt::Health::kDegraded, reconstructor_.last_error());
    return;
  }
  targets_t out = *targets;
  publish(channels::kTargets, out);
  count("targets", out.num_targets);
  if (health() != rt::Health::kOk) set_health(rt::Health::kOk);
}

// ---------------- factories ----------------

rt::NodeList make_camera(const config::Node& cfg, const rt::ProcessEnv&) {
  CameraConfig c = CameraConfig::from_yaml(cfg);
  rt::NodeList nodes;
  auto source = make_source(c);
  nodes.push_back(std::make_unique<CameraNode>(std::move(c), std::move(source)));
  return nodes;
}

rt::NodeList make_fruit_detector(const config::Node& cfg, const rt::ProcessEnv&) {
  rt::NodeList nodes;
  nodes.push_back(std::make_unique<DetectorNode>(DetectorNodeConfig::from_yaml(cfg)));
  return nodes;
}

rt::NodeList make_reconstructor(const config::Node& cfg, const rt::ProcessEnv&) {
  rt::NodeList nodes;
  nodes.push_back(std::make_unique<ReconstructorNode>(ReconstructorConfig::from_yaml(cfg)));
  return nodes;
}

}  // namespace harvest::vision
