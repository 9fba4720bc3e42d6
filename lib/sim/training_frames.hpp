// Rendered frames with exact fruit boxes, for training and scoring the
// learned detector (docs/perception.md "Rendered training frames"; issue 19
// items 2 and 4). Each scene is a scenario drawn with another seed and
// randomised looks (sun, light, ripeness, dry leaves, shutter), seen by the
// fixed camera from its true pose and by the hand camera from poses a
// harvest visits: towards a fruit from 0.1 to 0.9 m, not always centred,
// rolled, moving up to the arm's speed limit (motion blur). Written as the
// DeepFruits photos are (images/ and boxes.csv, one box per fruit), plus a
// `visible` column: the fruit's visible share of its in-image silhouette.
#pragma once

#include <cstdint>
#include <filesystem>
#include <iosfwd>
#include <string>
#include <vector>

#include "sim/scenario.hpp"

namespace harvest::sim {

struct TrainingFramesOptions {
  int scenes = 20;            // scenes per scenario file
  int hand_views = 8;         // hand-camera views per scene
  bool fixed_view = true;     // the fixed camera's view of each scene
  uint64_t seed = 1;          // scenes k use seed + k (another tree each)
  double min_visible = 0.15;  // fruit less visible are not written at all
  double max_speed = 0.381;   // [m/s] hand camera speed at most (motion blur); the link's limit
  int warmup_frames = 4;      // frames rendered before each written one (auto exposure settles)
};

// One fruit in one frame: its projected silhouette's box (image px; may
// extend past the image border) and visible share.
struct FrameBox {
  double x1 = 0, y1 = 0, x2 = 0, y2 = 0;
  double visible = 0;
};

// The box of a sphere (centre in the camera frame, z > 0) through `model`:
// the extent of its limb circle's projection (distortion included).
FrameBox sphere_box(const geometry::CameraModel& model, const Eigen::Vector3d& centre_cam, double radius);

// Scenes from `scenario` (its file name `name` prefixes every image) into
// out_dir/images; returns the boxes.csv rows written (without the header).
// Deterministic: the same options give the same files.
std::vector<std::string> render_training_frames(const Scenario& scenario, const std::string& name,
                                                const TrainingFramesOptions& options,
                                                const std::filesystem::path& out_dir);

// The boxes.csv header (the DeepFruits columns, then `visible`).
inline constexpr const char* kTrainingFramesHeader = "image,img_w,img_h,x1,y1,x2,y2,visible";

}  // namespace harvest::sim
