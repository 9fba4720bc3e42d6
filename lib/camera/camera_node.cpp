#include "camera/camera_node.hpp"

#include <algorithm>
#include <cmath>
#include <opencv2/imgproc.hpp>

#include "camera/image_codec.hpp"
#include "harvest/image_t.hpp"
#include "runtime/channels.hpp"

namespace harvest::camera {

CameraConfig CameraConfig::from_yaml(const config::Node& n) {
  namespace k = camera_keys;
  CameraConfig c;
  c.camera = n.get(k::camera);
  c.channel = n.get(k::channel, std::string(c.camera == "hand" ? channels::kCameraHand : channels::kCameraFixed));
  c.source = n.get(k::source);
  const config::Node dev = n.child("device");
  c.device.device = dev.get(device_keys::path);
  c.device.width = dev.get(device_keys::width);
  c.device.height = dev.get(device_keys::height);
  c.device.pixel_format = dev.get(device_keys::pixel_format);
  if (!c.device.pixel_format.empty() && c.device.pixel_format.size() != 4)
    dev.fail("pixel_format", "a four-character code such as MJPG or YUYV, or empty");
  if (c.source != "device") c.path = n.file_path(k::path.name).string();
  c.loop = n.get(k::loop);
  c.frame_rate_hz = n.get(k::frame_rate_hz);
  c.device.fps = c.frame_rate_hz;
  c.output_width = n.get(k::output_width);
  c.output_height = n.get(k::output_height);
  if ((c.output_width == 0) != (c.output_height == 0)) n.fail("output_height", "set together with output_width");
  c.jpeg = n.get(k::encoding) == "jpeg";
  c.jpeg_quality = n.get(k::jpeg_quality);
  const std::vector<double> zoom = n.get(k::zoom_roi_px);
  c.zoom = cv::Rect(static_cast<int>(zoom[0]), static_cast<int>(zoom[1]), static_cast<int>(zoom[2]),
                    static_cast<int>(zoom[3]));
  if (c.zoom.width < 0 || c.zoom.height < 0 || c.zoom.x < 0 || c.zoom.y < 0)
    n.fail("zoom_roi_px", "x, y, width, height >= 0 (width 0 = no zoom)");
  c.retry_initial_s = n.get(k::retry_initial_s);
  // Its range starts at retry_initial_s.
  c.retry_max_s = n.get<double>(k::retry_max_s.name, k::retry_max_s.fallback, {c.retry_initial_s, k::retry_max_s.range.max});
  c.stop_at_end = n.get(k::stop_at_end);
  return c;
}

std::vector<config::Section> CameraConfig::schema() {
  namespace k = camera_keys;
  const std::string where = "harvest-camera, config/vision/camera-*.yaml (docs/camera-driver.md).";
  return {config::section("camera", where, k::camera, k::channel, k::source, k::path, k::loop, k::frame_rate_hz,
                          k::output_width, k::output_height, k::encoding, k::jpeg_quality, k::zoom_roi_px,
                          k::retry_initial_s, k::retry_max_s, k::stop_at_end),
          config::section("camera.device", where, device_keys::path, device_keys::width, device_keys::height,
                          device_keys::pixel_format)};
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

rt::NodeList make_camera(const config::Node& cfg, const rt::ProcessEnv&) {
  CameraConfig c = CameraConfig::from_yaml(cfg);
  rt::NodeList nodes;
  auto source = make_source(c);
  nodes.push_back(std::make_unique<CameraNode>(std::move(c), std::move(source)));
  return nodes;
}

}  // namespace harvest::camera
