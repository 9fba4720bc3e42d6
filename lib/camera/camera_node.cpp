#include "camera/camera_node.hpp"

#include <algorithm>
#include <cmath>
#include <opencv2/imgproc.hpp>

#include "camera/image_codec.hpp"
#include "harvest/image_t.hpp"
#include "runtime/channels.hpp"

namespace harvest::camera {

CameraConfig CameraConfig::from_yaml(const config::Node& n) {
  CameraConfig c;
  c.camera = n.get<std::string>("camera", c.camera);
  c.channel = n.get<std::string>("channel", c.camera == "hand" ? channels::kCameraHand : channels::kCameraFixed);
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

rt::NodeList make_camera(const config::Node& cfg, const rt::ProcessEnv&) {
  CameraConfig c = CameraConfig::from_yaml(cfg);
  rt::NodeList nodes;
  auto source = make_source(c);
  nodes.push_back(std::make_unique<CameraNode>(std::move(c), std::move(source)));
  return nodes;
}

}  // namespace harvest::camera
