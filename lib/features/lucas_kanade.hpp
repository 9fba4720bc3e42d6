// Pyramidal Lucas-Kanade feature tracking (thesis section 2.2 and appendix
// B.2, after Bouguet's description of the pyramidal KLT tracker, thesis
// ref. [1]). A feature's window is assumed to translate (eq. 2-4 with
// delta = d); the displacement is found coarse to fine over an image
// pyramid, iterating Newton-Raphson steps at every level until a step is
// shorter than `epsilon_px` (thesis: 0.1 px).
#pragma once

#include <opencv2/core.hpp>
#include <vector>

namespace harvest::features {

// Gaussian pyramid: level 0 is the image (float), each further level is
// smoothed with the 5-tap [1 4 6 4 1]/16 kernel and subsampled by 2. Levels
// are views into buffers with zero padding right of and below the image (the
// SIMD kernels read past a window's edge); they are not continuous.
class Pyramid {
 public:
  Pyramid() = default;
  Pyramid(const cv::Mat1b& gray, int levels, bool allow_simd = true);
  int levels() const { return static_cast<int>(level_.size()); }
  const cv::Mat1f& level(int i) const { return level_[static_cast<std::size_t>(i)]; }
  bool empty() const { return level_.empty(); }

 private:
  std::vector<cv::Mat1f> level_;
};

// One pyramid level down (exposed for tests).
cv::Mat1f pyramid_down(const cv::Mat1f& src, bool allow_simd = true);

struct LkParams {
  int window = 7;           // window side [px], odd (thesis Wx = Wy = 7)
  int levels = 3;           // pyramid levels including the image (thesis n_res = 3)
  int max_iterations = 30;  // per level
  double epsilon_px = 0.1;  // stop when a Newton step is shorter than this (thesis track_tol)
  // Min eigenvalue of the gradient matrix / window area [(grey/px)^2], in the
  // previous window (before tracking) and in the new one (after): below it
  // the window is flat or one-directional and the feature is lost.
  double min_eigenvalue = 1e-2;
  // AVX2 when the CPU has it; the portable build gives bit-identical results.
  bool allow_simd = true;
};

struct LkResult {
  cv::Point2f pt;      // position in the next image
  bool found = false;  // false: left the image, or a window's gradient matrix was (nearly) singular
  float error = 0;     // mean absolute grey-level difference over the window at the end
  int iterations = 0;  // Newton steps at level 0
};

// Tracks `points` from `prev` to `next`. `guesses` (same size, optional) are
// initial positions in `next`; by default the points themselves.
std::vector<LkResult> track_lk(const Pyramid& prev, const Pyramid& next, const std::vector<cv::Point2f>& points,
                               const LkParams& params, const std::vector<cv::Point2f>& guesses = {});

}  // namespace harvest::features
