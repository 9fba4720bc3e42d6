// Shi-Tomasi corners (thesis eq. 2-2, 2-3): a pixel is a candidate feature
// when the smaller eigenvalue of the gradient matrix
//     Z = sum over a W x W window of [gx^2 gx*gy; gx*gy gy^2]
// exceeds a threshold. Candidates are local maxima of that eigenvalue,
// sorted strongest first and thinned to a minimum spacing, optionally only
// inside a region (the detected fruit) and a mask.
//
// Units: gx, gy are 3x3 Sobel derivatives divided by 8, i.e. grey levels per
// pixel, so the eigenvalue is in (grey levels / px)^2 summed over the window.
// The thesis threshold 5000 on raw Sobel sums is 5000 / 64 = 78 here.
#pragma once

#include <opencv2/core.hpp>
#include <vector>

namespace harvest::features {

struct CornerParams {
  int window = 7;                // W, odd (eq. 2-2 window, thesis 7 x 7)
  double min_eigenvalue = 78.0;  // absolute threshold lambda of eq. 2-3 (see units above)
  double quality_level = 0.0;    // also reject below quality_level * strongest eigenvalue (0 = off)
  double min_distance = 10.0;    // minimum spacing between accepted corners [px]
  int max_corners = 200;         // 0 = no limit
  int border = 10;               // pixels along the image edge that are not searched
  bool allow_simd = true;        // AVX2 when the CPU has it (same result as the portable build; tests compare)
};

struct Corner {
  cv::Point2f pt;        // integer pixel centre of the window
  float min_eigenvalue;  // quality of the corner
};

// Smaller eigenvalue of Z at every pixel (CV_32F, zero where the window
// leaves the image). `gray` is CV_8U, one channel; `window` odd, 3..45 (the
// sums are exact integers; larger windows would overflow them: cv::Exception).
cv::Mat1f min_eigenvalue_map(const cv::Mat1b& gray, int window, bool allow_simd = true);

// Corners, strongest first (equal values: the later pixel in row-major order first). `region` (empty = whole image) and
// `mask` (empty = everything; non-zero = allowed, same size as the image) restrict where corners may be. `existing` are
// features already held: new corners keep min_distance from them too (replenishment).
std::vector<Corner> detect_corners(const cv::Mat1b& gray, const CornerParams& params, const cv::Rect& region = {},
                                   const cv::Mat1b& mask = {}, const std::vector<cv::Point2f>& existing = {});

}  // namespace harvest::features
