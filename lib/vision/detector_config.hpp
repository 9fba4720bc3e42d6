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
struct Section;
}

namespace harvest::vision {

// The detector's keys (docs/perception.md). Switches whose canopy preset
// differs from the thesis default say so in `derived`; canopy() sets them.
namespace detector_keys {
using config::Key;
inline constexpr config::Choice mode{"mode", "canopy", {"thesis", "canopy", "learned"},
                                     "thesis: every improvement off; canopy: all on; learned: the network"};
inline constexpr Key<int64_t> min_area_px{"min_area_px", 50, {0, 100'000'000}, "px",
                                          "regions keep area > this (thesis MinRegionArea)"};
inline constexpr Key<double> fruit_diameter_m{"fruit_diameter_m", 0.0725, {0.01, 0.5}, "m",
                                              "statistical mean fruit diameter D_o"};
inline constexpr Key<double> kr{"kr", 1.0, {0.0, 1e6}, "", "appendix B.1 weight Kr on size"};
inline constexpr Key<double> kd_per_m{"kd_per_m", 25.0, {0.0, 1e6}, "1/m", "weight Kd on depth (thesis 0.025 per mm)"};
inline constexpr Key<int> open_radius_px{.name = "open_radius_px", .range = {0, 50}, .unit = "px",
                                         .doc = "morphological opening of the mask (0: off)", .derived = "0 (canopy: 1)"};
inline constexpr Key<int> close_radius_px{.name = "close_radius_px", .range = {0, 50}, .unit = "px",
                                          .doc = "closing (0: off)", .derived = "0 (canopy: 2)"};
inline constexpr Key<bool> fill_holes{.name = "fill_holes", .doc = "fill holes of each region",
                                      .derived = "false (canopy: true)"};
inline constexpr Key<bool> split_touching{.name = "split_touching",
                                          .doc = "split a region at distance-transform peaks",
                                          .derived = "false (canopy: true)"};
inline constexpr Key<double> split_min_radius_px{"split_min_radius_px", 4.0, {0.5, 1000.0}, "px",
                                                 "distance-transform peaks lower than this are not fruit centres"};
inline constexpr Key<double> split_min_peak_ratio{"split_min_peak_ratio", 0.35, {0.0, 1.0}, "",
                                                  "nor peaks below this fraction of the region's highest"};
inline constexpr Key<bool> peel_to_circle{.name = "peel_to_circle",
                                          .doc = "cut what sticks out of a piece's best-supported circle (needs circle_fit)",
                                          .derived = "false (canopy: true)"};
inline constexpr Key<bool> merge_fragments{.name = "merge_fragments",
                                           .doc = "join pieces whose outer edges fit one circle (needs circle_fit)",
                                           .derived = "false (canopy: true)"};
inline constexpr Key<double> merge_max_gap_ratio{"merge_max_gap_ratio", 0.5, {0.0, 10.0}, "",
                                                 "pieces farther apart than this x the larger one's size are not tried"};
inline constexpr Key<double> sky_cb_min{"sky_cb_min", 10.0, {-1000.0, 1000.0}, "",
                                        "Cb above this is open sky, never inside a fruit's disc (merge check)"};
inline constexpr Key<bool> reject_shapes{.name = "reject_shapes", .doc = "drop regions that are not fruit-like",
                                         .derived = "false (canopy: true)"};
inline constexpr Key<double> min_roundness{"min_roundness", 0.45, {0.0, 1.0}, "", "4 pi A / P^2"};
inline constexpr Key<double> min_solidity{"min_solidity", 0.75, {0.0, 1.0}, "", "A / convex hull area"};
inline constexpr Key<double> min_solidity_fitted{
    "min_solidity_fitted", 0.6, {0.0, 1.0}, "",
    "... of a piece whose visible outline a circle fits (circle_fit): a leaf biting into a fruit leaves a piece far "
    "smaller than its hull"};
inline constexpr Key<double> max_aspect_ratio{"max_aspect_ratio", 2.5, {1.0, 100.0}, "", "longest / shortest side"};
inline constexpr Key<bool> circle_fit{.name = "circle_fit",
                                      .doc = "diameter and centre from a circle through the visible convex outline",
                                      .derived = "false (canopy: true)"};
inline constexpr Key<double> min_visible_fraction{"min_visible_fraction", 0.3, {0.0, 1.0}, "",
                                                  "below this the circle fit is not trusted"};
}  // namespace detector_keys

struct DetectorConfig {
  enum class Mode { thesis, canopy, learned };
  Mode mode = Mode::thesis;
  LearnedConfig learned;  // mode learned only: the colour keys below are then unused

  ColorThresholds thresholds;
  int64_t min_area_px = detector_keys::min_area_px.fallback;          // regions keep area > min_area_px (thesis MinRegionArea)
  double fruit_diameter_m = detector_keys::fruit_diameter_m.fallback;  // statistical mean fruit diameter D_o
  double kr = detector_keys::kr.fallback;                   // appendix B.1 weights: Kr on size,
  double kd_per_m = detector_keys::kd_per_m.fallback;            // Kd on depth (thesis 0.025 per mm)

  int open_radius_px = detector_keys::open_radius_px.fallback;   // morphological opening of the mask, 0 = off
  int close_radius_px = detector_keys::close_radius_px.fallback;  // closing, 0 = off
  bool fill_holes = detector_keys::fill_holes.fallback;
  bool split_touching = detector_keys::split_touching.fallback;
  double split_min_radius_px = detector_keys::split_min_radius_px.fallback;    // distance-transform peaks lower than this are not fruit centres
  double split_min_peak_ratio = detector_keys::split_min_peak_ratio.fallback;  // nor peaks below this fraction of the region's highest
  bool peel_to_circle = detector_keys::peel_to_circle.fallback;         // cut what sticks out of a piece's best-supported circle (needs circle_fit)
  bool merge_fragments = detector_keys::merge_fragments.fallback;        // join pieces whose outer edges fit one circle (needs circle_fit)
  double merge_max_gap_ratio = detector_keys::merge_max_gap_ratio.fallback;    // pieces farther apart than this times the larger one's size are not tried
  double sky_cb_min = detector_keys::sky_cb_min.fallback;            // Cb above this is open sky, never inside a fruit's disc (merge check)
  bool reject_shapes = detector_keys::reject_shapes.fallback;
  double min_roundness = detector_keys::min_roundness.fallback;  // 4 pi A / P^2
  double min_solidity = detector_keys::min_solidity.fallback;   // A / convex hull area
  double min_solidity_fitted = detector_keys::min_solidity_fitted.fallback;  // ... with a circle fitted to its outline
  double max_aspect_ratio = detector_keys::max_aspect_ratio.fallback;
  bool circle_fit = detector_keys::circle_fit.fallback;
  double min_visible_fraction = detector_keys::min_visible_fraction.fallback;  // below this the circle fit is not trusted

  // mode "thesis": every improvement off; "canopy": all on; "learned": the
  // network of learned_detector.hpp (size, depth and cost as the others).
  static DetectorConfig thesis();
  static DetectorConfig canopy();
  static DetectorConfig learned_mode(const std::filesystem::path& model);
  // Reads the keys documented in docs/perception.md; throws config::Error
  // (in mode learned also for a model file that does not load, naming it).
  static DetectorConfig from_yaml(const config::Node& node);
  // The keys above, in a section at `path` (with the learned ones and the thresholds).
  static config::Section schema(const std::string& path, const std::string& where);
};

}  // namespace harvest::vision
