#include "features/lucas_kanade.hpp"

#include <algorithm>
#include <cmath>

namespace harvest::features {

namespace {

inline int reflect101(int i, int n) {
  if (n == 1) return 0;
  while (i < 0 || i >= n) i = i < 0 ? -i : 2 * n - 2 - i;
  return i;
}

// Bilinear sample; the caller keeps (x, y) inside [0, cols-1] x [0, rows-1].
inline float sample(const cv::Mat1f& im, float x, float y) {
  const int x0 = std::min(static_cast<int>(x), im.cols - 2);
  const int y0 = std::min(static_cast<int>(y), im.rows - 2);
  const float ax = x - static_cast<float>(x0), ay = y - static_cast<float>(y0);
  const float* r0 = im[y0];
  const float* r1 = im[y0 + 1];
  const float top = r0[x0] + ax * (r0[x0 + 1] - r0[x0]);
  const float bot = r1[x0] + ax * (r1[x0 + 1] - r1[x0]);
  return top + ay * (bot - top);
}

inline bool inside(const cv::Mat1f& im, float x, float y, int margin) {
  return x >= static_cast<float>(margin) && y >= static_cast<float>(margin) &&
         x <= static_cast<float>(im.cols - 1 - margin) && y <= static_cast<float>(im.rows - 1 - margin);
}

}  // namespace

cv::Mat1f pyramid_down(const cv::Mat1f& src) {
  const int rows = src.rows, cols = src.cols;
  const int orow = (rows + 1) / 2, ocol = (cols + 1) / 2;
  // Horizontal pass at the kept columns, then vertical at the kept rows.
  cv::Mat1f h(rows, ocol);
  for (int y = 0; y < rows; ++y) {
    const float* s = src[y];
    float* d = h[y];
    for (int x = 0; x < ocol; ++x) {
      const int c = 2 * x;
      if (c >= 2 && c + 2 < cols) {
        d[x] = (s[c - 2] + s[c + 2] + 4.f * (s[c - 1] + s[c + 1]) + 6.f * s[c]) * (1.f / 16.f);
      } else {
        d[x] = (s[reflect101(c - 2, cols)] + s[reflect101(c + 2, cols)] +
                4.f * (s[reflect101(c - 1, cols)] + s[reflect101(c + 1, cols)]) + 6.f * s[reflect101(c, cols)]) *
               (1.f / 16.f);
      }
    }
  }
  cv::Mat1f out(orow, ocol);
  for (int y = 0; y < orow; ++y) {
    const int r = 2 * y;
    const float* a = h[reflect101(r - 2, rows)];
    const float* b = h[reflect101(r - 1, rows)];
    const float* c = h[r];
    const float* d = h[reflect101(r + 1, rows)];
    const float* e = h[reflect101(r + 2, rows)];
    float* o = out[y];
    for (int x = 0; x < ocol; ++x) o[x] = (a[x] + e[x] + 4.f * (b[x] + d[x]) + 6.f * c[x]) * (1.f / 16.f);
  }
  return out;
}

Pyramid::Pyramid(const cv::Mat1b& gray, int levels) {
  cv::Mat1f base;
  gray.convertTo(base, CV_32F);
  level_.push_back(base);
  for (int i = 1; i < levels; ++i) {
    const cv::Mat1f& last = level_.back();
    if (last.cols < 16 || last.rows < 16) break;
    level_.push_back(pyramid_down(last));
  }
}

std::vector<LkResult> track_lk(const Pyramid& prev, const Pyramid& next, const std::vector<cv::Point2f>& points,
                               const LkParams& p, const std::vector<cv::Point2f>& guesses) {
  std::vector<LkResult> out(points.size());
  if (prev.empty() || next.empty()) return out;
  const int levels = std::min({prev.levels(), next.levels(), std::max(p.levels, 1)});
  const int h = std::max(p.window, 3) / 2;
  const int side = 2 * h + 1, n = side * side;
  const int ext = side + 2;  // patch with a one-pixel ring for central differences
  std::vector<float> patch(static_cast<std::size_t>(ext * ext)), ix(static_cast<std::size_t>(n)),
      iy(static_cast<std::size_t>(n)), ival(static_cast<std::size_t>(n));
  const double eps2 = p.epsilon_px * p.epsilon_px;

  for (std::size_t k = 0; k < points.size(); ++k) {
    LkResult& r = out[k];
    const cv::Point2f u = points[k];
    const cv::Point2f guess = guesses.size() == points.size() ? guesses[k] : u;
    const float top_scale = 1.f / static_cast<float>(1 << (levels - 1));
    // g: displacement guess at the current level (Bouguet's g^L).
    float gx = (guess.x - u.x) * top_scale, gy = (guess.y - u.y) * top_scale;
    bool ok = true;
    float dx = 0, dy = 0;
    for (int L = levels - 1; L >= 0 && ok; --L) {
      const cv::Mat1f& I = prev.level(L);
      const cv::Mat1f& J = next.level(L);
      const float scale = 1.f / static_cast<float>(1 << L);
      const float px = u.x * scale, py = u.y * scale;
      if (!inside(I, px, py, h + 1)) {
        // The window leaves the coarse image: skip this level, keep the guess.
        if (L == 0) ok = false;
        if (L > 0) {
          gx *= 2.f;
          gy *= 2.f;
        }
        continue;
      }
      // Template patch and its derivatives (central differences).
      for (int j = 0; j < ext; ++j)
        for (int i = 0; i < ext; ++i)
          patch[static_cast<std::size_t>(j * ext + i)] =
              sample(I, px + static_cast<float>(i - h - 1), py + static_cast<float>(j - h - 1));
      double gxx = 0, gxy = 0, gyy = 0;
      for (int j = 0; j < side; ++j)
        for (int i = 0; i < side; ++i) {
          const std::size_t c = static_cast<std::size_t>((j + 1) * ext + (i + 1));
          const std::size_t q = static_cast<std::size_t>(j * side + i);
          ix[q] = 0.5f * (patch[c + 1] - patch[c - 1]);
          iy[q] = 0.5f * (patch[c + static_cast<std::size_t>(ext)] - patch[c - static_cast<std::size_t>(ext)]);
          ival[q] = patch[c];
          gxx += double(ix[q]) * ix[q];
          gxy += double(ix[q]) * iy[q];
          gyy += double(iy[q]) * iy[q];
        }
      const double det = gxx * gyy - gxy * gxy;
      const double hmin = 0.5 * (gxx + gyy) - std::sqrt(0.25 * (gxx - gyy) * (gxx - gyy) + gxy * gxy);
      if (hmin / n < p.min_eigenvalue || !(det > 0)) {
        ok = false;
        break;
      }
      // Newton-Raphson on the residual (Bouguet eq. for eta = G^-1 b).
      float vx = 0, vy = 0;
      int it = 0;
      for (; it < p.max_iterations; ++it) {
        const float cx = px + gx + vx, cy = py + gy + vy;
        if (!inside(J, cx, cy, h)) {
          ok = false;
          break;
        }
        double bx = 0, by = 0;
        for (int j = 0; j < side; ++j)
          for (int i = 0; i < side; ++i) {
            const std::size_t q = static_cast<std::size_t>(j * side + i);
            const float diff = ival[q] - sample(J, cx + static_cast<float>(i - h), cy + static_cast<float>(j - h));
            bx += double(diff) * ix[q];
            by += double(diff) * iy[q];
          }
        const double ex = (gyy * bx - gxy * by) / det, ey = (gxx * by - gxy * bx) / det;
        vx += static_cast<float>(ex);
        vy += static_cast<float>(ey);
        if (ex * ex + ey * ey < eps2) {
          ++it;
          break;
        }
      }
      if (!ok) break;
      dx = vx;
      dy = vy;
      if (L == 0) {
        r.iterations = it;
      } else {
        gx = 2.f * (gx + dx);
        gy = 2.f * (gy + dy);
      }
    }
    if (!ok) continue;
    r.pt = cv::Point2f(u.x + gx + dx, u.y + gy + dy);
    const cv::Mat1f& I0 = prev.level(0);
    const cv::Mat1f& J0 = next.level(0);
    if (!inside(J0, r.pt.x, r.pt.y, h + 1)) continue;
    // Residual, and the gradient matrix of the new window: a feature that
    // landed on a flat or one-directional patch is no longer trackable.
    double err = 0, jxx = 0, jxy = 0, jyy = 0;
    for (int j = -h; j <= h; ++j)
      for (int i = -h; i <= h; ++i) {
        const float x = r.pt.x + static_cast<float>(i), y = r.pt.y + static_cast<float>(j);
        err += std::abs(sample(I0, u.x + static_cast<float>(i), u.y + static_cast<float>(j)) - sample(J0, x, y));
        const double jx = 0.5 * (sample(J0, x + 1, y) - sample(J0, x - 1, y));
        const double jy = 0.5 * (sample(J0, x, y + 1) - sample(J0, x, y - 1));
        jxx += jx * jx;
        jxy += jx * jy;
        jyy += jy * jy;
      }
    r.error = static_cast<float>(err / n);
    const double jmin = 0.5 * (jxx + jyy) - std::sqrt(0.25 * (jxx - jyy) * (jxx - jyy) + jxy * jxy);
    r.found = jmin / n >= p.min_eigenvalue;
  }
  return out;
}

}  // namespace harvest::features
