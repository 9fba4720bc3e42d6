// Least-squares circle through 2D points: an algebraic (Kasa) fit as the
// starting point, refined by Gauss-Newton on the geometric distances.
#pragma once

#include <opencv2/core.hpp>
#include <optional>
#include <vector>

namespace harvest::vision {

struct Circle {
  double cx = 0, cy = 0, r = 0;
  double rms = 0;  // RMS of the geometric residuals
};

// Needs at least three points not on one line; nullopt otherwise.
std::optional<Circle> fit_circle(const std::vector<cv::Point2d>& points, int iterations = 10);

}  // namespace harvest::vision
