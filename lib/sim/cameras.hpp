// The simulated cameras: their renderers and what they draw besides the scene
// (calibration boards, stickers), over the cameras' own copy of the scene.
//
// A frame is drawn from a FrameRequest, a snapshot the simulator's loop takes
// at the frame's time: the fruit as the physics left them and the tool's and
// hand camera's true poses (a board clamped to the tool is drawn where the
// tool was at that tick). Leaves, branches and boards on stands never move,
// so the copy made at construction holds them. The renderers keep state between frames
// (noise, auto-exposure, the previous pose for motion blur), so one thread at
// a time renders (render_worker.hpp: the render thread, or the loop itself).
#pragma once

#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "harvest/image_t.hpp"
#include "sim/renderer.hpp"
#include "sim/scenario.hpp"
#include "sim/scene.hpp"

namespace harvest::sim {

class BoardPrimitive;
class StickerPrimitive;

enum class CameraId : int { kFixed = 0, kHand = 1, kZoom = 2 };
inline constexpr int kCameraCount = 3;
const char* camera_name(CameraId camera);  // "fixed", "hand", "zoom"

struct FrameRequest {
  CameraId camera = CameraId::kFixed;
  int64_t utime = 0;         // the simulation time of the state below: the frame's header.utime
  std::vector<Fruit> fruit;  // every fruit at utime
  Placement hand_camera;     // the hand camera's true pose at utime (kHand)
  Placement tool;            // the tool's true pose at utime (boards clamped to it)
};

class SimCameras {
 public:
  // `scene` as drawn from the scenario, before anything moves.
  SimCameras(const Scenario& scenario, const Scene& scene);
  ~SimCameras();
  SimCameras(const SimCameras&) = delete;
  SimCameras& operator=(const SimCameras&) = delete;

  bool has_zoom() const { return zoom_.has_value(); }
  // Per fruit: the share of it the fixed camera sees at the start (which
  // fruit a run is scored on).
  const std::vector<float>& start_visible_fraction() const { return start_visible_fraction_; }

  // Renders the requested frame and encodes it as that camera's driver
  // publishes it: header.utime = request.utime, frame_id set, seq left to the
  // publisher.
  image_t render(const FrameRequest& request);
  const std::string& channel(CameraId camera) const;

  // Encodes a rendered BGR frame as the camera drivers publish it; the frame
  // is the whole sensor of the given size (0: the frame's own size), binned.
  static image_t make_image(const cv::Mat& bgr, const std::string& encoding, int jpeg_quality, int sensor_width = 0,
                            int sensor_height = 0);

 private:
  // Where the zoomed camera looks: the sticker's centre, or the peel facing
  // the fixed camera.
  Vec3 zoom_aim() const;

  const Scenario scenario_;  // a copy: the render thread reads it
  Scene scene_;              // the cameras' copy: fruit replaced by each request's
  Renderer fixed_, hand_;
  std::optional<Renderer> zoom_;                                   // scenario zoom: CAMERA_FIXED_ZOOM
  std::vector<std::shared_ptr<const StickerPrimitive>> stickers_;  // per fruit, null without a sticker
  // Boards clamped to the tool, with their pose in the tool frame: posed from each request's tool before drawing.
  std::vector<std::pair<std::shared_ptr<BoardPrimitive>, Placement>> tool_boards_;
  std::vector<float> start_visible_fraction_;
};

}  // namespace harvest::sim
