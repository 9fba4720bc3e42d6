// The camera of the "field" look (scenario `look.style: field`): what a real
// colour camera does to the light that reaches it. Motion blur of the moving
// camera during the exposure, auto-exposure that meters each frame and adapts
// its gain with a lag (a bright sky gap darkens the canopy), a slowly drifting
// white balance, lens vignetting, signal-dependent sensor noise (shot + read
// noise) and clipping at full scale.
#pragma once

#include <Eigen/Core>
#include <array>
#include <cstdint>
#include <opencv2/core.hpp>
#include <vector>

#include "sim/scenario.hpp"

namespace harvest::sim {

class FieldCamera {
 public:
  // `cos_field` per pixel: cosine of the angle between its ray and the
  // optical axis (vignetting); `rate_hz`: frame rate (the drift's clock).
  FieldCamera(const Look& look, std::vector<float> cos_field, int width, int height, double rate_hz,
              double noise_std, uint64_t seed);

  // Turns linear radiance (RGB floats, 3 per pixel, row-major, 0..255 at unit
  // gain) into the 8-bit BGR image, blurred along `blur_px` (the image motion
  // while the shutter is open). `radiance` is used as scratch.
  void develop(std::vector<float>& radiance, const Eigen::Vector2f& blur_px, cv::Mat& out);

  double gain() const { return gain_; }
  // Mean luminance the auto-exposure aims at (grey levels).
  static constexpr double kTargetMean = 105.0;

 private:
  void blur(std::vector<float>& radiance, const Eigen::Vector2f& blur_px);

  Look look_;
  std::vector<float> vignette_;
  int w_, h_;
  double rate_hz_;
  double gain_ = 1.0;
  bool metered_ = false;
  int64_t frame_ = 0;
  std::array<double, 3> wb_phase_{}, wb_freq_{}, wb_cast_{};
  std::vector<float> noise_sigma_;  // per grey level 0..255
  std::vector<float> noise_;        // N(0, 1) table
  uint64_t noise_state_;
  std::vector<float> scratch_;
};

}  // namespace harvest::sim
