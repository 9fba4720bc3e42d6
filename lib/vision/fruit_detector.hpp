// Fruit detection in one colour image (thesis section 2.2, 6.2, appendix B.1).
//
// Thesis mode: CrCgCb colour thresholds, 4-connected regions larger than a
// minimum area, centroid, radius from area (r = sqrt(A / pi)), depth from the
// statistical fruit diameter (eq. 6-11) and the selection cost of appendix
// B.1, cost = Kr (W / r - 1) + Kd Z. The thesis wrote W as the constant 320
// (its image width); using the actual width keeps the cost independent of
// the image size and equal to the thesis's for 320-pixel images.
//
// Improvements for a real canopy, each switchable (DetectorConfig): mask
// clean-up (opening, closing, hole filling), splitting of touching fruit
// (distance-transform peaks), cutting off slivers of other fruit that stick
// out of a piece's best-supported circle, merging of the fragments of one
// fruit (pieces cut apart by a leaf or by the splitter whose outer edges lie
// on one circle), rejection of shapes that are not fruit-like, and a
// diameter from a circle fitted to the visible outer contour, which survives
// occlusion by leaves where the area-based diameter does not.
#pragma once

#include <cstdint>
#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "vision/segmentation.hpp"

namespace harvest::config {
class Node;
}

namespace harvest::vision {

struct DetectorConfig {
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

  // mode "thesis": every improvement off; "canopy": all on.
  static DetectorConfig thesis();
  static DetectorConfig canopy();
  // Reads the keys documented in docs/perception.md; throws config::Error.
  static DetectorConfig from_yaml(const config::Node& node);
};

struct Fruit {
  double u = 0, v = 0;                          // centre [px]
  double diameter_px = 0;                       // used for depth
  double diameter_x_px = 0, diameter_y_px = 0;  // extents
  double area_px = 0;
  double roundness = 0;
  double solidity = 0;
  double visible_fraction = 0;  // angular share of the outline that is convex fruit edge
  double confidence = 0;
  double depth_m = 0;
  double cost = 0;
  bool selected = false;
  bool circle_fitted = false;
  cv::Rect bbox;
  std::vector<cv::Point> outline;  // image pixels
};

struct Detections {
  std::vector<Fruit> fruits;
  int selected = -1;
};

class FruitDetector {
 public:
  // fx, fy: focal lengths [px] of the image being processed (depth, eq. 6-11).
  FruitDetector(const DetectorConfig& config, double fx, double fy);

  Detections detect(const cv::Mat3b& bgr);

  // The colour mask of the last image after clean-up (for overlays and tests).
  const cv::Mat1b& mask() const { return mask_; }
  const DetectorConfig& config() const { return config_; }

 private:
  struct Piece;
  Piece make_piece(cv::Mat1b mask, cv::Point offset, cv::Size image, const cv::Mat1b* region) const;
  void peel(Piece piece, cv::Size image, std::vector<Piece>& out) const;
  void merge_fragments(std::vector<Piece>& pieces, const cv::Mat3b& bgr) const;
  void analyse(const Piece& piece, cv::Size image, std::vector<Fruit>& out) const;
  std::vector<std::pair<cv::Mat1b, cv::Point>> split(const cv::Mat1b& crop, cv::Point offset) const;
  // The region's visible outline fits one circle that covers it (a fruit, perhaps cut by a leaf).
  bool is_one_fruit(const cv::Mat1b& crop, cv::Point offset, cv::Size image) const;

  DetectorConfig config_;
  double fx_, fy_;
  cv::Mat1b mask_;
  cv::Mat open_kernel_, close_kernel_;
  RegionLabeler labeler_;
};

}  // namespace harvest::vision
