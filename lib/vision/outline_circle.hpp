// The circle a fruit's visible outline lies on. A fruit cut by leaves, by
// the image border or by a neighbour shows only part of its outline; these
// functions pick the points that are fruit edge (convex, short hull edges),
// measure how much of the circle they cover, and find the circle most of them
// lie on (robust to leaf edges inside the disc). Used by the region splitter
// and the detector (fruit_detector.hpp).
#pragma once

#include <cstddef>
#include <opencv2/core.hpp>
#include <optional>
#include <vector>

#include "vision/circle_fit.hpp"

namespace harvest::vision {

// Outline points (contour in crop coordinates, placed at `offset` in an image
// of size `image`) that are fruit edge, in image coordinates: on the convex
// hull, on a hull edge no longer than max_edge_px, and off the image border.
std::vector<cv::Point2d> fruit_edge_points(const std::vector<cv::Point>& contour, cv::Point offset, cv::Size image,
                                           double max_edge_px);

// The area of the points' convex hull, exactly cv::contourArea(cv::convexHull(points))
// (integer points: both are exact), in linear time: the hull of a point set
// on a grid is that of each column's top and bottom point, already in x
// order, so the monotone chain needs no sort.
double convex_hull_area(const std::vector<cv::Point>& points);

// Share (0..1) of directions around (cx, cy) holding one of `points`, for an
// outline of `outline_points` points.
double angular_coverage(const std::vector<cv::Point2d>& points, std::size_t outline_points, double cx, double cy);

// Points within the circle's tolerance band (max(1.5 px, 6 % of r)).
std::size_t points_on_circle(const std::vector<cv::Point2d>& points, const Circle& c);
std::vector<cv::Point2d> on_circle(const std::vector<cv::Point2d>& points, const Circle& c);

// Angular share of the circle its on-circle points cover.
double circle_coverage(const std::vector<cv::Point2d>& points, const Circle& c);

struct OutlineFit {
  Circle circle;
  std::size_t on = 0;  // edge points on the circle
};

// The circle with radius in [r_min, r_max] that the most edge points lie on
// and that no more than 3 % of the outline points (if any are given) lie
// outside; nullopt with fewer than 8 edge points or no such circle.
std::optional<OutlineFit> fit_outline_circle(const std::vector<cv::Point2d>& edge,
                                             const std::vector<cv::Point2d>& outline, double r_min, double r_max);

}  // namespace harvest::vision
