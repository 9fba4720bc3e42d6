// Synthetic images for the feature tests: analytic textures that can be
// shifted by exact sub-pixel amounts, and a textured planar target that can
// be rendered from any camera pose.
#pragma once

#include <cmath>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>
#include <random>
#include <vector>

namespace harvest::features::testing {

// Sum of random plane waves: I(x, y) = 128 + sum a_k sin(w_k . (x, y) + phi_k).
// Frequencies stay below 0.6 rad/px so the texture is band-limited and an
// image of it, shifted by any real (dx, dy), is exact up to quantisation.
class WaveTexture {
 public:
  explicit WaveTexture(uint64_t seed, int waves = 24) {
    std::mt19937_64 rng(seed);
    std::uniform_real_distribution<double> ang(0, 2 * M_PI), freq(0.08, 0.6), amp(4.0, 12.0);
    for (int k = 0; k < waves; ++k) {
      const double a = ang(rng), f = freq(rng);
      w_.push_back({f * std::cos(a), f * std::sin(a), ang(rng), amp(rng)});
    }
  }
  // The image sampled at (x - dx, y - dy): the texture moved by (+dx, +dy).
  cv::Mat1b render(cv::Size size, double dx = 0, double dy = 0) const {
    cv::Mat1b out(size);
    for (int y = 0; y < size.height; ++y)
      for (int x = 0; x < size.width; ++x) {
        double v = 128;
        for (const auto& w : w_) v += w.a * std::sin(w.wx * (x - dx) + w.wy * (y - dy) + w.phi);
        out(y, x) = cv::saturate_cast<uint8_t>(v);
      }
    return out;
  }

 private:
  struct Wave {
    double wx, wy, phi, a;
  };
  std::vector<Wave> w_;
};

// A "sticker": random filled shapes over smoothed noise, good for ORB.
inline cv::Mat1b sticker_texture(int side, uint64_t seed) {
  cv::RNG rng(seed);
  cv::Mat1f noise(side / 8, side / 8);
  rng.fill(noise, cv::RNG::UNIFORM, 60, 200);
  cv::Mat1f up;
  cv::resize(noise, up, cv::Size(side, side), 0, 0, cv::INTER_CUBIC);
  cv::Mat1b img;
  up.convertTo(img, CV_8U);
  for (int i = 0; i < side / 6; ++i) {
    const cv::Point c(rng.uniform(0, side), rng.uniform(0, side));
    const int r = rng.uniform(side / 60 + 2, side / 14 + 3);
    const int grey = rng.uniform(0, 256);
    if (rng.uniform(0, 2) == 0)
      cv::circle(img, c, r, cv::Scalar(grey), cv::FILLED, cv::LINE_AA);
    else
      cv::rectangle(img, cv::Rect(c.x - r, c.y - r / 2, 2 * r, r), cv::Scalar(grey), cv::FILLED, cv::LINE_AA);
  }
  cv::GaussianBlur(img, img, cv::Size(3, 3), 0.8);
  return img;
}

// Render `texture` mapped by the homography H (texture px -> image px) over a
// flat background, with optional Gaussian pixel noise from a seeded RNG.
inline cv::Mat1b render_plane(const cv::Mat1b& texture, const cv::Matx33d& H, cv::Size size, int background = 90,
                              double noise_sigma = 0, uint64_t noise_seed = 0) {
  cv::Mat1b out;
  cv::warpPerspective(texture, out, cv::Mat(H), size, cv::INTER_LINEAR, cv::BORDER_CONSTANT, cv::Scalar(background));
  if (noise_sigma > 0) {
    cv::Mat1f n(size);
    cv::RNG rng(noise_seed);
    rng.fill(n, cv::RNG::NORMAL, 0, noise_sigma);
    cv::Mat1f f;
    out.convertTo(f, CV_32F);
    f += n;
    f.convertTo(out, CV_8U);
  }
  return out;
}

}  // namespace harvest::features::testing
