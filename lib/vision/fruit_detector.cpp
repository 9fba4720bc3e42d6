#include "vision/fruit_detector.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <opencv2/imgproc.hpp>
#include <optional>

#include "vision/circle_fit.hpp"
#include "vision/depth.hpp"
#include "vision/outline_circle.hpp"

namespace harvest::vision {

FruitDetector::FruitDetector(const DetectorConfig& config, double fx, double fy)
    : config_(config), fx_(fx), fy_(fy), splitter_(config) {
  if (config_.open_radius_px > 0) open_disc_ = StructuringElement::disc(config_.open_radius_px);
  if (config_.close_radius_px > 0) close_disc_ = StructuringElement::disc(config_.close_radius_px);
  if (config_.mode == DetectorConfig::Mode::learned) learned_ = std::make_shared<LearnedDetector>(config_.learned);
}

void FruitDetector::finish(Fruit& f, cv::Size image) const {
  f.depth_m = depth_from_diameter(fx_, fy_, config_.fruit_diameter_m, f.diameter_px);
  f.cost = config_.kr * (image.width / (0.5 * f.diameter_px) - 1.0) + config_.kd_per_m * f.depth_m;
}
void FruitDetector::analyse(const Piece& piece, cv::Size image, std::vector<Fruit>& out) const {
  if (piece.area <= static_cast<double>(config_.min_area_px) || piece.area <= 0 || piece.contour.empty()) return;
  const MaskMoments& mo = piece.moments;
  const auto& contour = piece.contour;
  const cv::Point offset = piece.offset;
  const bool merged = piece.fragments > 1;

  Fruit f;
  f.area_px = mo.m00;
  f.u = mo.m10 / mo.m00 + offset.x;
  f.v = mo.m01 / mo.m00 + offset.y;
  f.diameter_px = 2.0 * std::sqrt(f.area_px / std::numbers::pi);
  const cv::Rect box = merged ? piece.box - offset : cv::boundingRect(contour);
  f.bbox = box + offset;
  f.diameter_x_px = box.width;
  f.diameter_y_px = box.height;
  const double perimeter = cv::arcLength(contour, true);
  f.roundness = perimeter > 0 ? std::min(1.0, 4 * std::numbers::pi * f.area_px / (perimeter * perimeter)) : 0.0;
  const double hull_area = convex_hull_area(contour);
  f.solidity = hull_area > 0 ? std::min(1.0, cv::contourArea(contour) / hull_area) : 1.0;

  const auto& edge = piece.edge;
  f.visible_fraction = angular_coverage(edge, piece.outline_points, f.u, f.v);
  if (config_.circle_fit && edge.size() >= 8) {
    std::optional<Circle> c;
    if (merged) {
      const double extent = std::max(box.width, box.height);
      if (const auto fit = fit_outline_circle(edge, piece.outer, 0.5 * extent - 1.0, extent)) c = fit->circle;
    } else {
      c = fit_circle(edge);
    }
    if (c) {
      const double coverage = angular_coverage(edge, piece.outline_points, c->cx, c->cy);
      // Outline points are pixel centres, half a pixel inside the true edge.
      if (coverage >= config_.min_visible_fraction && c->r < 2 * f.diameter_px) {
        f.u = c->cx;
        f.v = c->cy;
        f.diameter_px = 2 * (c->r + 0.5);
        f.visible_fraction = coverage;
        f.circle_fitted = true;
      }
    }
  }
  if (config_.reject_shapes && !(merged && f.circle_fitted)) {
    const double aspect =
        static_cast<double>(std::max(box.width, box.height)) / std::max(1, std::min(box.width, box.height));
    // Fruit cut by a leaf are not round by area, so the fitted circle's
    // visible arc stands in for roundness when there is one.
    const bool round_enough = f.roundness >= config_.min_roundness || f.circle_fitted;
    // ... and a leaf biting into one leaves a piece whose hull is far larger than it: with its outline on a circle, a
    // lower solidity is still a fruit (on ten tree seeds' first fixed-camera frames 14 of 304 fruit at least half
    // visible were missed with 0.75 for all, 5 with 0.6 for these; docs/perception.md).
    const double min_solidity = f.circle_fitted ? config_.min_solidity_fitted : config_.min_solidity;
    if (!round_enough || f.solidity < min_solidity || aspect > config_.max_aspect_ratio) return;
  }
  f.confidence =
      std::clamp(0.4 * std::min(1.0, f.roundness / 0.8) + 0.3 * f.solidity + 0.3 * f.visible_fraction, 0.0, 1.0);
  f.outline.reserve(contour.size());
  for (const cv::Point& p : contour) f.outline.push_back(p + offset);
  finish(f, image);
  out.push_back(std::move(f));
}

const cv::Mat1b& FruitDetector::mask() const {
  if (mask_stale_) {
    bits_.unpack(mask_);
    mask_stale_ = false;
  }
  return mask_;
}

Detections FruitDetector::detect(const cv::Mat3b& bgr) {
  Detections out;
  if (learned_) {
    out.fruits = learned_->detect(bgr);
    for (Fruit& f : out.fruits) finish(f, bgr.size());
  } else {
    detect_colour(bgr, out);
  }
  for (std::size_t i = 0; i < out.fruits.size(); ++i)
    if (out.selected < 0 || out.fruits[i].cost < out.fruits[static_cast<std::size_t>(out.selected)].cost)
      out.selected = static_cast<int>(i);
  if (out.selected >= 0) out.fruits[static_cast<std::size_t>(out.selected)].selected = true;
  return out;
}

void FruitDetector::detect_colour(const cv::Mat3b& bgr, Detections& out) {
  // Threshold, opening and closing on the packed mask: the pixels
  // cv::morphologyEx gives on the byte mask (bitmask.hpp), a tenth of the work.
  threshold_crcgcb(bgr, config_.thresholds, bits_);
  if (!open_disc_.empty()) morphology_.open(bits_, open_disc_);
  if (!close_disc_.empty()) morphology_.close(bits_, close_disc_);
  mask_stale_ = true;

  const auto& regions = labeler_.label(bits_, config_.min_area_px);
  // Merging needs every piece first; otherwise each region is done at once.
  const bool merging = config_.merge_fragments && config_.circle_fit;
  std::vector<Piece> pieces;
  for (std::size_t i = 0; i < regions.size(); ++i) {
    const cv::Point offset(regions[i].x0 - 1, regions[i].y0 - 1);
    splitter_.add_region(labeler_.region_mask(i, 1), offset, bgr.size(), pieces);
    if (!merging) {
      for (const Piece& p : pieces) analyse(p, bgr.size(), out.fruits);
      pieces.clear();
    }
  }
  if (merging) {
    splitter_.merge_fragments(pieces, bgr);
    for (const Piece& p : pieces) analyse(p, bgr.size(), out.fruits);
  }
}

}  // namespace harvest::vision
