// Fruit detection in one colour image (thesis section 2.2, 6.2, appendix B.1).
//
// Thesis mode: CrCgCb colour thresholds, 4-connected regions larger than a
// minimum area, centroid, radius from area (r = sqrt(A / pi)), depth from the
// statistical fruit diameter (eq. 6-11) and the selection cost of appendix
// B.1, cost = Kr (W / r - 1) + Kd Z. The thesis wrote W as the constant 320
// (its image width); using the actual width keeps the cost independent of
// the image size and equal to the thesis's for 320-pixel images.
//
// Mode learned (learned_detector.hpp) replaces the colour steps by a network;
// depth, cost and selection stay as here.
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
#include <memory>
#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "vision/bitmask.hpp"
#include "vision/detector_config.hpp"
#include "vision/region_split.hpp"
#include "vision/segmentation.hpp"

namespace harvest::vision {

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

  // The colour mask of the last image after clean-up (for overlays and tests;
  // unpacked from the detector's packed mask when asked for).
  const cv::Mat1b& mask() const;
  const DetectorConfig& config() const { return config_; }

 private:
  void analyse(const Piece& piece, cv::Size image, std::vector<Fruit>& out) const;
  void detect_colour(const cv::Mat3b& bgr, Detections& out);
  void finish(Fruit& f, cv::Size image) const;  // depth and selection cost

  DetectorConfig config_;
  double fx_, fy_;
  BitMask bits_;  // the colour mask, cleaned up
  BinaryMorphology morphology_;
  StructuringElement open_disc_, close_disc_;
  mutable cv::Mat1b mask_;  // bits_ unpacked, by mask()
  mutable bool mask_stale_ = false;
  RegionLabeler labeler_;
  RegionSplitter splitter_;
  std::shared_ptr<LearnedDetector> learned_;  // mode learned only
};

}  // namespace harvest::vision
