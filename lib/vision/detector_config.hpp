// Configuration of the fruit detector (fruit_detector.hpp): the thesis's
// colour thresholds and selection weights, and the switches of the canopy
// improvements (region_split.hpp, outline_circle.hpp). Keys in
// docs/perception.md.
#pragma once

#include <cstdint>

#include "vision/learned_detector.hpp"
#include "vision/segmentation.hpp"

namespace harvest::config {
class Node;
}

namespace harvest::vision {

struct DetectorConfig {
  enum class Mode { thesis, canopy, learned };
  Mode mode = Mode::thesis;
  LearnedConfig learned;  // mode learned only: the colour keys below are then unused

  ColorThresholds thresholds;
  int64_t min_area_px = 50;          // regions keep area > min_area_px (thesis MinRegionArea)
  double fruit_diameter_m = 0.0725;  // statistical mean fruit diameter D_o
  double kr = 1.0;                   // appendix B.1 weights: Kr on size,
  double kd_per_m = 25.0;            // Kd on depth (thesis 0.025 per mm)

  int open_radius_px = 0;   // morphological opening of the mask, 0 = off
  int close_radius_px = 0;  // closing, 0 = off
  bool fill_holes = false;
  bool split_touching = false;
  double split_min_radius_px = 4.0;    // distance-transform peaks lower than this are not fruit centres
  double split_min_peak_ratio = 0.35;  // nor peaks below this fraction of the region's highest
  bool peel_to_circle = false;         // cut what sticks out of a piece's best-supported circle (needs circle_fit)
  bool merge_fragments = false;        // join pieces whose outer edges fit one circle (needs circle_fit)
  double merge_max_gap_ratio = 0.5;    // pieces farther apart than this times the larger one's size are not tried
  double sky_cb_min = 10.0;            // Cb above this is open sky, never inside a fruit's disc (merge check)
  bool reject_shapes = false;
  double min_roundness = 0.45;  // 4 pi A / P^2
  double min_solidity = 0.75;   // A / convex hull area
  double max_aspect_ratio = 2.5;
  bool circle_fit = false;
  double min_visible_fraction = 0.3;  // below this the circle fit is not trusted

  // mode "thesis": every improvement off; "canopy": all on; "learned": the
  // network of learned_detector.hpp (size, depth and cost as the others).
  static DetectorConfig thesis();
  static DetectorConfig canopy();
  static DetectorConfig learned_mode(const std::filesystem::path& model);
  // Reads the keys documented in docs/perception.md; throws config::Error
  // (in mode learned also for a model file that does not load, naming it).
  static DetectorConfig from_yaml(const config::Node& node);
};

}  // namespace harvest::vision
