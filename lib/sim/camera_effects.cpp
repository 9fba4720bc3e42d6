#include "sim/camera_effects.hpp"

#include <algorithm>
#include <cmath>
#include <random>

#include "sim/materials.hpp"
#include "sim/splitmix.hpp"

namespace harvest::sim {
namespace {

constexpr std::size_t kNoiseTable = 1 << 16;


}  // namespace

FieldCamera::FieldCamera(const Look& look, std::vector<float> cos_field, int width, int height, double rate_hz,
                         double noise_std, uint64_t seed)
    : look_(look), vignette_(std::move(cos_field)), w_(width), h_(height), rate_hz_(rate_hz), noise_state_(seed) {
  for (auto& c : vignette_) c = c * c * c;  // cos^3: natural vignetting of a wide lens, mostly
  for (int c = 0; c < 3; ++c) {
    wb_phase_[c] = 2.0 * M_PI * hashed_unit(seed, 21, c);
    wb_freq_[c] = 0.03 + 0.05 * hashed_unit(seed, 22, c);
    wb_cast_[c] = look.white_balance_drift * (hashed_unit(seed, 23, c) - 0.5);
  }
  // Shot noise grows with the signal: sigma^2 = read^2 + k v; noise_std is
  // the sigma at mid grey.
  noise_sigma_.resize(256);
  for (int v = 0; v < 256; ++v) noise_sigma_[v] = static_cast<float>(noise_std * std::sqrt(0.35 + v / 100.0));
  std::mt19937_64 rng(seed);
  std::normal_distribution<float> gauss(0.0f, 1.0f);
  noise_.resize(kNoiseTable);
  for (auto& v : noise_) v = gauss(rng);
}

void FieldCamera::blur(std::vector<float>& rgb, const Eigen::Vector2f& b) {
  const float len = b.norm();
  if (len < 0.75f) return;
  const int taps = std::min(25, static_cast<int>(std::ceil(len)) + 1);
  scratch_.assign(rgb.size(), 0.0f);
  for (int k = 0; k < taps; ++k) {
    const float t = -0.5f + static_cast<float>(k) / static_cast<float>(taps - 1);
    const int dx = static_cast<int>(std::lround(t * b.x())), dy = static_cast<int>(std::lround(t * b.y()));
    for (int y = 0; y < h_; ++y) {
      const int sy = std::clamp(y + dy, 0, h_ - 1);
      const float* src = rgb.data() + static_cast<std::size_t>(sy) * w_ * 3;
      float* dst = scratch_.data() + static_cast<std::size_t>(y) * w_ * 3;
      const int x0 = std::clamp(-dx, 0, w_), x1 = std::clamp(w_ - dx, 0, w_);
      for (int x = 0; x < x0; ++x)
        for (int c = 0; c < 3; ++c) dst[3 * x + c] += src[3 * std::clamp(x + dx, 0, w_ - 1) + c];
      const float* s = src + 3 * (x0 + dx);
      float* d = dst + 3 * x0;
      for (int i = 0, n = 3 * (x1 - x0); i < n; ++i) d[i] += s[i];
      for (int x = x1; x < w_; ++x)
        for (int c = 0; c < 3; ++c) dst[3 * x + c] += src[3 * std::clamp(x + dx, 0, w_ - 1) + c];
    }
  }
  const float inv = 1.0f / static_cast<float>(taps);
  for (std::size_t i = 0; i < rgb.size(); ++i) rgb[i] = scratch_[i] * inv;
}

void FieldCamera::develop(std::vector<float>& rgb, const Eigen::Vector2f& blur_px, cv::Mat& out) {
  blur(rgb, blur_px);
  const std::size_t n = static_cast<std::size_t>(w_) * h_;
  if (look_.auto_exposure) {
    // Meter (every other pixel of every other row) what the sensor records at
    // the current gain, clipped at full scale, then move the gain a third of
    // the way (in stops) to the one that brings the mean to the target. The
    // first frame iterates to convergence instead.
    for (int pass = 0; pass < (metered_ ? 1 : 6); ++pass) {
      const float clip = static_cast<float>(255.0 / gain_);
      double sum = 0.0;
      int count = 0;
      for (int y = 0; y < h_; y += 2)
        for (int x = 0; x < w_; x += 2) {
          const float* p = rgb.data() + 3 * (static_cast<std::size_t>(y) * w_ + x);
          sum += 0.299f * std::min(p[0], clip) + 0.587f * std::min(p[1], clip) + 0.114f * std::min(p[2], clip);
          ++count;
        }
      const double mean = std::max(1e-3, gain_ * sum / std::max(1, count));
      const double target = std::clamp(gain_ * kTargetMean / mean, 0.35, 3.0);
      gain_ = std::exp(std::log(gain_) + (metered_ ? 0.35 : 1.0) * (std::log(target) - std::log(gain_)));
    }
    metered_ = true;
  }
  const double t = static_cast<double>(frame_++) / rate_hz_;
  float g[3];
  for (int c = 0; c < 3; ++c)
    g[c] = static_cast<float>(gain_ * (1.0 + wb_cast_[c] +
                                       look_.white_balance_drift * std::sin(2.0 * M_PI * wb_freq_[c] * t + wb_phase_[c])));
  const uint64_t offset = splitmix_next(noise_state_);
  out.create(h_, w_, CV_8UC3);
  auto* px = out.ptr<uint8_t>(0);
  for (std::size_t i = 0; i < n; ++i) {
    const float vig = vignette_[i];
    for (int c = 0; c < 3; ++c) {
      const float v = rgb[3 * i + c] * g[c] * vig;
      const int level = std::clamp(static_cast<int>(v), 0, 255);
      const float e = noise_[(offset + 3 * i + static_cast<std::size_t>(c)) & (kNoiseTable - 1)] * noise_sigma_[level];
      px[3 * i + (2 - c)] = static_cast<uint8_t>(std::clamp(v + e + 0.5f, 0.0f, 255.0f));  // BGR order
    }
  }
}

}  // namespace harvest::sim
