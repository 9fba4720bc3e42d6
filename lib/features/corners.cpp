#include "features/corners.hpp"

#include <algorithm>
#include <cmath>
#include <numeric>

namespace harvest::features {

namespace {

// In-place sum over a running window of `w` along rows, result centred;
// entries whose window leaves the row are left zero.
void box_rows(const cv::Mat1f& src, cv::Mat1f& dst, int w) {
  const int half = w / 2;
  dst.create(src.size());
  dst.setTo(0);
  for (int y = 0; y < src.rows; ++y) {
    const float* s = src[y];
    float* d = dst[y];
    if (src.cols < w) continue;
    double acc = 0;
    for (int x = 0; x < w; ++x) acc += s[x];
    d[half] = static_cast<float>(acc);
    for (int x = half + 1; x + half < src.cols; ++x) {
      acc += s[x + half] - s[x - half - 1];
      d[x] = static_cast<float>(acc);
    }
  }
}

void box_cols(const cv::Mat1f& src, cv::Mat1f& dst, int w) {
  const int half = w / 2;
  dst.create(src.size());
  dst.setTo(0);
  if (src.rows < w) return;
  std::vector<double> acc(static_cast<std::size_t>(src.cols), 0.0);
  for (int y = 0; y < w; ++y)
    for (int x = 0; x < src.cols; ++x) acc[x] += src(y, x);
  for (int x = 0; x < src.cols; ++x) dst(half, x) = static_cast<float>(acc[x]);
  for (int y = half + 1; y + half < src.rows; ++y) {
    const float* add = src[y + half];
    const float* sub = src[y - half - 1];
    float* d = dst[y];
    for (int x = 0; x < src.cols; ++x) {
      acc[x] += add[x] - sub[x];
      d[x] = static_cast<float>(acc[x]);
    }
  }
}

}  // namespace

cv::Mat1f min_eigenvalue_map(const cv::Mat1b& gray, int window) {
  CV_Assert(window >= 3 && window % 2 == 1);
  const int rows = gray.rows, cols = gray.cols;
  cv::Mat1f gxx(rows, cols, 0.f), gxy(rows, cols, 0.f), gyy(rows, cols, 0.f);
  // 3x3 Sobel / 8: grey levels per pixel. The outermost ring stays zero.
  for (int y = 1; y + 1 < rows; ++y) {
    const uint8_t* a = gray[y - 1];
    const uint8_t* b = gray[y];
    const uint8_t* c = gray[y + 1];
    float* pxx = gxx[y];
    float* pxy = gxy[y];
    float* pyy = gyy[y];
    for (int x = 1; x + 1 < cols; ++x) {
      const int gx = (a[x + 1] + 2 * b[x + 1] + c[x + 1]) - (a[x - 1] + 2 * b[x - 1] + c[x - 1]);
      const int gy = (c[x - 1] + 2 * c[x] + c[x + 1]) - (a[x - 1] + 2 * a[x] + a[x + 1]);
      const float fx = static_cast<float>(gx) * 0.125f, fy = static_cast<float>(gy) * 0.125f;
      pxx[x] = fx * fx;
      pxy[x] = fx * fy;
      pyy[x] = fy * fy;
    }
  }
  cv::Mat1f tmp, sxx, sxy, syy;
  box_rows(gxx, tmp, window);
  box_cols(tmp, sxx, window);
  box_rows(gxy, tmp, window);
  box_cols(tmp, sxy, window);
  box_rows(gyy, tmp, window);
  box_cols(tmp, syy, window);
  cv::Mat1f out(rows, cols, 0.f);
  // The window must lie where gradients exist (one pixel in from the edge).
  const int lo = window / 2 + 1;
  for (int y = lo; y < rows - lo; ++y) {
    const float* a = sxx[y];
    const float* b = sxy[y];
    const float* c = syy[y];
    float* o = out[y];
    for (int x = lo; x < cols - lo; ++x) {
      // Smaller eigenvalue of [a b; b c] (eq. 2-3).
      const double h = 0.5 * (a[x] - c[x]);
      o[x] = static_cast<float>(0.5 * (a[x] + c[x]) - std::sqrt(h * h + double(b[x]) * b[x]));
    }
  }
  return out;
}

std::vector<Corner> detect_corners(const cv::Mat1b& gray, const CornerParams& p, const cv::Rect& region,
                                   const cv::Mat1b& mask, const std::vector<cv::Point2f>& existing) {
  std::vector<Corner> out;
  if (gray.empty()) return out;
  const cv::Mat1f eig = min_eigenvalue_map(gray, p.window);
  const int edge = std::max(p.border, p.window / 2 + 1);
  cv::Rect search(edge, edge, gray.cols - 2 * edge, gray.rows - 2 * edge);
  if (search.width <= 0 || search.height <= 0) return out;
  if (region.area() > 0) search &= region;
  if (search.area() <= 0) return out;
  const bool use_mask = !mask.empty() && mask.size() == gray.size();

  double max_val = 0;
  for (int y = search.y; y < search.br().y; ++y)
    for (int x = search.x; x < search.br().x; ++x)
      if ((!use_mask || mask(y, x)) && eig(y, x) > max_val) max_val = eig(y, x);
  const double threshold = std::max(p.min_eigenvalue, p.quality_level * max_val);

  struct Candidate {
    float value;
    int index;
  };
  std::vector<Candidate> cand;
  for (int y = search.y; y < search.br().y; ++y) {
    for (int x = search.x; x < search.br().x; ++x) {
      const float v = eig(y, x);
      if (!(v > threshold) || (use_mask && !mask(y, x))) continue;
      // Local maximum over the 3x3 neighbourhood (ties allowed).
      bool peak = true;
      for (int dy = -1; dy <= 1 && peak; ++dy)
        for (int dx = -1; dx <= 1; ++dx)
          if (eig(y + dy, x + dx) > v) {
            peak = false;
            break;
          }
      if (peak) cand.push_back({v, y * gray.cols + x});
    }
  }
  // Strongest first; equal values: later pixel first (deterministic).
  std::sort(cand.begin(), cand.end(), [](const Candidate& a, const Candidate& b) {
    return a.value > b.value || (a.value == b.value && a.index > b.index);
  });

  // Minimum spacing with a grid of min_distance cells.
  const double md = std::max(p.min_distance, 0.0);
  const int cell = std::max(1, static_cast<int>(std::ceil(md)));
  const int gw = (gray.cols + cell - 1) / cell, gh = (gray.rows + cell - 1) / cell;
  std::vector<std::vector<cv::Point2f>> grid(static_cast<std::size_t>(gw * gh));
  auto too_close = [&](const cv::Point2f& q) {
    if (md <= 0) return false;
    const int cx = static_cast<int>(q.x) / cell, cy = static_cast<int>(q.y) / cell;
    for (int yy = std::max(cy - 1, 0); yy <= std::min(cy + 1, gh - 1); ++yy)
      for (int xx = std::max(cx - 1, 0); xx <= std::min(cx + 1, gw - 1); ++xx)
        for (const auto& o : grid[static_cast<std::size_t>(yy * gw + xx)]) {
          const float dx = o.x - q.x, dy = o.y - q.y;
          if (dx * dx + dy * dy < md * md) return true;
        }
    return false;
  };
  auto add = [&](const cv::Point2f& q) {
    const int cx = std::clamp(static_cast<int>(q.x) / cell, 0, gw - 1);
    const int cy = std::clamp(static_cast<int>(q.y) / cell, 0, gh - 1);
    grid[static_cast<std::size_t>(cy * gw + cx)].push_back(q);
  };
  for (const auto& e : existing)
    if (e.x >= 0 && e.y >= 0 && e.x < gray.cols && e.y < gray.rows) add(e);
  for (const auto& c : cand) {
    const cv::Point2f q(static_cast<float>(c.index % gray.cols), static_cast<float>(c.index / gray.cols));
    if (too_close(q)) continue;
    add(q);
    out.push_back({q, c.value});
    if (p.max_corners > 0 && static_cast<int>(out.size()) >= p.max_corners) break;
  }
  return out;
}

}  // namespace harvest::features
