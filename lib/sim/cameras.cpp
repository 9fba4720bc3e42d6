#include "sim/cameras.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <stdexcept>

#include "camera/image_codec.hpp"
#include "runtime/channels.hpp"
#include "sim/board.hpp"
#include "sim/splitmix.hpp"
#include "sim/sticker.hpp"

namespace harvest::sim {

const char* camera_name(CameraId camera) {
  switch (camera) {
    case CameraId::kFixed:
      return "fixed";
    case CameraId::kHand:
      return "hand";
    case CameraId::kZoom:
      return "zoom";
  }
  return "?";
}

SimCameras::SimCameras(const Scenario& scenario, const Scene& scene)
    : scenario_(scenario),
      scene_(scene),
      fixed_(scenario_.fixed_camera.model, scenario_.fixed_camera.noise_std, scenario_.seed + 1),
      hand_(scenario_.hand_camera.model, scenario_.hand_camera.noise_std, scenario_.seed + 2) {
  fixed_.set_look(scenario_.look, scenario_.fixed_camera.rate_hz);
  hand_.set_look(scenario_.look, scenario_.hand_camera.rate_hz);
  for (const BoardSetup& b : scenario_.boards) {
    // A board on the tool is where the tool starts until the first request poses it.
    const auto board =
        std::make_shared<BoardPrimitive>(b.spec, b.on_tool ? compose(start_tool_pose(scenario_.arm), b.pose) : b.pose);
    if (b.on_tool) tool_boards_.emplace_back(board, b.pose);
    fixed_.add_primitive(board);
    hand_.add_primitive(board);
  }
  // Stickers face the fixed camera (the side of the fruit facing the aisle).
  const Vec3 fixed_at = scenario_.fixed_camera_truth.position;
  stickers_.resize(scene_.fruit().size());
  for (std::size_t k = 0; k < scenario_.fruit.size(); ++k)
    if (scenario_.fruit[k].sticker > 0.0)
      stickers_[k] = std::make_shared<const StickerPrimitive>(scene_, k, scenario_.fruit[k].sticker, fixed_at,
                                                              splitmix_hash(scenario_.seed) + k);
  if (scenario_.zoom.enabled()) {
    // Zoomed so the fruit looks as from the camera-in-hand at zoom.distance: the hand camera's true intrinsics
    // with the focal length times the distance ratio.
    geometry::CameraModel m = scenario_.hand_camera.model;
    const double k = (zoom_aim() - fixed_at).norm() / scenario_.zoom.distance;
    m.fx *= k;
    m.fy *= k;
    m.skew *= k;
    m.dist.fill(0.0);  // a long focal length: no visible distortion
    zoom_.emplace(m, scenario_.fixed_camera.noise_std, scenario_.seed + 4);
    zoom_->set_look(scenario_.look, scenario_.zoom.rate_hz);
  }
  for (const auto& sticker : stickers_) {
    if (!sticker) continue;
    fixed_.add_primitive(sticker);
    hand_.add_primitive(sticker);
    if (zoom_) zoom_->add_primitive(sticker);
  }
  // What the fixed camera sees of each fruit before anything moves decides
  // which fruit the run is scored on: its visible pixels over its whole disc.
  // The silhouette is counted inside the image only: for a fruit the image
  // border cuts, the disc's projected area (without distortion, exact on the
  // optical axis, less off it) bounds it, else a fruit mostly outside the
  // image would count as whole.
  const Placement& cam = scenario_.fixed_camera_truth;
  fixed_.render(scene_, cam);
  const auto& vis = fixed_.visible_pixels();
  const auto& sil = fixed_.silhouette_pixels();
  const geometry::CameraModel& k = fixed_.model();
  for (std::size_t i = 0; i < scene_.fruit().size(); ++i) {
    const Fruit& f = scene_.fruit()[i];
    const Vec3 c = cam.rotation.transpose() * (f.position - cam.position);
    const double d2 = c.squaredNorm(), r2 = f.radius * f.radius;
    double whole = sil[i];
    if (c.z() > f.radius && d2 > r2) {
      const double radius_px = k.fx * f.radius / std::sqrt(d2 - r2);
      const Eigen::Vector2d px = k.project(c);
      const bool cut = px.x() - radius_px < 0.0 || px.y() - radius_px < 0.0 || px.x() + radius_px > k.width ||
                       px.y() + radius_px > k.height;
      if (cut) whole = std::max(whole, std::numbers::pi * k.fx * k.fy * r2 / (d2 - r2));
    }
    start_visible_fraction_.push_back(whole > 0.0 ? static_cast<float>(vis[i] / whole) : 0.0f);
  }
}

SimCameras::~SimCameras() = default;

const std::string& SimCameras::channel(CameraId camera) const {
  static const std::string names[kCameraCount] = {channels::kCameraFixed, channels::kCameraHand,
                                                  channels::kCameraFixedZoom};
  return names[static_cast<int>(camera)];
}

Vec3 SimCameras::zoom_aim() const {
  const auto k = static_cast<std::size_t>(scenario_.zoom.fruit);
  if (stickers_[k]) return stickers_[k]->centre();
  const Fruit& f = scene_.fruit()[k];
  return f.position + f.radius * (scenario_.fixed_camera_truth.position - f.position).normalized();
}

image_t SimCameras::render(const FrameRequest& request) {
  if (request.fruit.size() != scene_.fruit().size())
    throw std::invalid_argument("a frame request with " + std::to_string(request.fruit.size()) +
                                " fruit for a scene of " + std::to_string(scene_.fruit().size()));
  scene_.fruit() = request.fruit;
  for (auto& [board, in_tool] : tool_boards_) board->set_pose(compose(request.tool, in_tool));
  const cv::Mat* bgr = nullptr;
  const CameraSetup* cam = nullptr;
  switch (request.camera) {
    case CameraId::kFixed:
      bgr = &fixed_.render(scene_, scenario_.fixed_camera_truth);
      cam = &scenario_.fixed_camera;
      break;
    case CameraId::kHand:
      bgr = &hand_.render(scene_, request.hand_camera);
      cam = &scenario_.hand_camera;
      break;
    case CameraId::kZoom: {
      if (!zoom_) throw std::invalid_argument("a zoomed frame requested of a scenario without zoom");
      const Vec3 from = scenario_.fixed_camera_truth.position;
      bgr = &zoom_->render(scene_, {look_at_rotation(from, zoom_aim()), from});
      cam = &scenario_.hand_camera;  // the zoomed image stands for the hand camera's desired view
      break;
    }
  }
  image_t img = make_image(*bgr, cam->encoding, cam->jpeg_quality, cam->sensor_width, cam->sensor_height);
  img.header.utime = request.utime;
  img.header.frame_id =
      std::string("camera_") + (request.camera == CameraId::kZoom ? "fixed_zoom" : camera_name(request.camera));
  img.header.source_seq = -1;
  return img;
}

image_t SimCameras::make_image(const cv::Mat& bgr, const std::string& encoding, int jpeg_quality, int sensor_width,
                               int sensor_height) {
  image_t img;
  camera::encode_image(bgr, encoding == "jpeg", jpeg_quality, img);
  // The frame shows the whole sensor, binned to the output size, as a camera
  // driver with a smaller output resolution publishes it.
  img.sensor_width = sensor_width > 0 ? sensor_width : bgr.cols;
  img.sensor_height = sensor_height > 0 ? sensor_height : bgr.rows;
  img.roi_px[0] = img.roi_px[1] = 0.0f;
  img.roi_px[2] = static_cast<float>(img.sensor_width);
  img.roi_px[3] = static_cast<float>(img.sensor_height);
  return img;
}

}  // namespace harvest::sim
