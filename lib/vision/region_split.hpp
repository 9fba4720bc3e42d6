// From one colour region to pieces that may each be one fruit: the region's
// holes filled, touching fruit split apart at their distance-transform peaks,
// slivers of other fruit peeled off a piece's best-supported circle, and
// fragments of one fruit (cut apart by a leaf) merged again (thesis section
// 2.2 finds regions; these steps make each region one fruit on a real
// canopy). Every step is switched by DetectorConfig.
#pragma once

#include <cstddef>
#include <opencv2/core.hpp>
#include <utility>
#include <vector>

#include "vision/detector_config.hpp"

namespace harvest::vision {

// The zeroth and first moments of a binary mask (nonzero = 1), the part of
// cv::moments the detector uses, as exact integer sums: the same values, a
// fifth of the work (cv::moments also sums the second and third moments).
struct MaskMoments {
  double m00 = 0, m10 = 0, m01 = 0;
};
MaskMoments mask_moments(const cv::Mat1b& mask);

// Fills the holes of a region's crop in place: background pixels not
// 4-connected to (0, 0), as cv::floodFill from (0, 0) leaves them.
void fill_holes(cv::Mat1b& crop);

// A piece of the mask that may be one fruit: a region, a part of a split
// region, or fragments merged because they lie on one circle.
struct Piece {
  cv::Mat1b mask;                  // with an empty frame of at least one pixel
  cv::Point offset;                // image position of mask(0, 0)
  std::vector<cv::Point> contour;  // largest outer outline, mask coordinates
  std::vector<cv::Point2d> edge;   // fruit-edge points, image coordinates
  std::vector<cv::Point2d> outer;  // every outer outline point, image coordinates
  std::size_t outline_points = 0;  // outer outline length of all fragments
  MaskMoments moments;             // of the mask
  double area = 0;
  cv::Rect box;  // image coordinates
  int fragments = 1;
};

class RegionSplitter {
 public:
  explicit RegionSplitter(const DetectorConfig& config) : config_(config) {}

  // One labelled region (its mask with an empty one-pixel frame, placed at
  // `offset` in an image of size `image`): appends its pieces to `out`.
  void add_region(cv::Mat1b crop, cv::Point offset, cv::Size image, std::vector<Piece>& out) const;

  // Joins the pieces that are fragments of one fruit (greedy, best fit
  // first); `bgr` is the image, for the open-sky check.
  void merge_fragments(std::vector<Piece>& pieces, const cv::Mat3b& bgr) const;

 private:
  // What is_one_fruit found out about a crop that make_piece needs again for
  // the same crop: its outer contours and, with one contour, its fruit-edge
  // points (the same maximum edge length: both take it from the area).
  struct Outline {
    bool traced = false;
    std::vector<std::vector<cv::Point>> contours;
    bool has_edge = false;
    std::vector<cv::Point2d> edge;
  };
  // `known`: is_one_fruit's findings for this very mask (and no region).
  Piece make_piece(cv::Mat1b mask, cv::Point offset, cv::Size image, const cv::Mat1b* region,
                   Outline* known = nullptr) const;
  void peel(Piece piece, cv::Size image, std::vector<Piece>& out) const;
  std::vector<std::pair<cv::Mat1b, cv::Point>> split(const cv::Mat1b& crop, cv::Point offset) const;
  // The region's visible outline fits one circle that covers it (a fruit, perhaps cut by a leaf).
  bool is_one_fruit(const cv::Mat1b& crop, cv::Point offset, cv::Size image, Outline& outline) const;

  DetectorConfig config_;
};

}  // namespace harvest::vision
