#include "features/lucas_kanade.hpp"

#include <algorithm>
#include <cmath>

#include "features/simd.hpp"

namespace harvest::features {

namespace {

using simd::v8f;

// Every level is stored with kPadCols zero columns after each row and one
// zero row below, so a kernel may read 8 floats past a window's right edge
// (its vector tail) and the row below the last one (bilinear weight 0) with
// no bounds checks.
constexpr int kPadCols = 16;

cv::Mat1f padded(int rows, int cols) {
  cv::Mat1f full(rows + 1, cols + kPadCols, 0.f);
  return full(cv::Rect(0, 0, cols, rows));
}

inline int reflect101(int i, int n) {
  if (n == 1) return 0;
  while (i < 0 || i >= n) i = i < 0 ? -i : 2 * n - 2 - i;
  return i;
}

inline bool inside(const cv::Mat1f& im, float x, float y, int margin) {
  return x >= static_cast<float>(margin) && y >= static_cast<float>(margin) &&
         x <= static_cast<float>(im.cols - 1 - margin) && y <= static_cast<float>(im.rows - 1 - margin);
}

// [1 4 6 4 1]/16 down by two: the vertical pass on the kept rows over the
// whole width (vectorised), then the horizontal pass at the kept columns.
HARVEST_SIMD_INLINE void pyramid_down_impl(const cv::Mat1f& src, cv::Mat1f& out) {
  const int rows = src.rows, cols = src.cols, orow = out.rows, ocol = out.cols;
  std::vector<float> v(static_cast<std::size_t>(cols));
  float* t = v.data();
  for (int y = 0; y < orow; ++y) {
    const int r = 2 * y;
    const float* a = src[reflect101(r - 2, rows)];
    const float* b = src[reflect101(r - 1, rows)];
    const float* c = src[r];
    const float* d = src[reflect101(r + 1, rows)];
    const float* e = src[reflect101(r + 2, rows)];
    for (int x = 0; x < cols; ++x) t[x] = (a[x] + e[x]) + 4.f * (b[x] + d[x]) + 6.f * c[x];
    float* o = out[y];
    const float k = 1.f / 256.f;
    int x = 0;
    for (; x < ocol && 2 * x < 2; ++x) {
      const int q = 2 * x;
      o[x] = ((t[reflect101(q - 2, cols)] + t[reflect101(q + 2, cols)]) +
              4.f * (t[reflect101(q - 1, cols)] + t[reflect101(q + 1, cols)]) + 6.f * t[q]) *
             k;
    }
    for (; x < ocol && 2 * x + 2 < cols; ++x) {
      const int q = 2 * x;
      o[x] = ((t[q - 2] + t[q + 2]) + 4.f * (t[q - 1] + t[q + 1]) + 6.f * t[q]) * k;
    }
    for (; x < ocol; ++x) {
      const int q = 2 * x;
      o[x] = ((t[reflect101(q - 2, cols)] + t[reflect101(q + 2, cols)]) +
              4.f * (t[reflect101(q - 1, cols)] + t[reflect101(q + 1, cols)]) + 6.f * t[q]) *
             k;
    }
  }
}
HARVEST_SIMD_DISPATCH(pyramid_down_into, pyramid_down_impl, void, (const cv::Mat1f& src, cv::Mat1f& out), (src, out))

// Bilinear samples at (cx + i - half, cy + j - half), i, j < width, into rows
// of `pitch` (a multiple of 8) floats; the tail lanes of a row are samples
// past the window (never used with a non-zero weight). The weights are the
// same for every pixel of the window.
HARVEST_SIMD_INLINE void sample_window(const cv::Mat1f& im, float cx, float cy, int half, int width, int pitch,
                                       float* dst) {
  const float fx = std::floor(cx), fy = std::floor(cy);
  const float ax = cx - fx, ay = cy - fy;
  const v8f w00 = simd::splat((1.f - ax) * (1.f - ay)), w01 = simd::splat(ax * (1.f - ay)),
            w10 = simd::splat((1.f - ax) * ay), w11 = simd::splat(ax * ay);
  const std::size_t step = im.step1();
  const float* base = im.ptr<float>(0) + (static_cast<int>(fy) - half) * static_cast<std::ptrdiff_t>(step) +
                      (static_cast<int>(fx) - half);
  for (int j = 0; j < width; ++j) {
    const float* r0 = base + static_cast<std::ptrdiff_t>(j) * static_cast<std::ptrdiff_t>(step);
    const float* r1 = r0 + step;
    float* d = dst + j * pitch;
    for (int b = 0; b < pitch; b += 8)
      simd::store8(d + b, w00 * simd::load8(r0 + b) + w01 * simd::load8(r0 + b + 1) + w10 * simd::load8(r1 + b) +
                              w11 * simd::load8(r1 + b + 1));
  }
}

// Template of one level: the value and central-difference gradients of the
// side x side window around (px, py), from a patch with a one-pixel ring;
// tail lanes are zero so they add nothing. Returns G = sum [ix^2 ixiy; ixiy iy^2].
struct Gram {
  float xx, xy, yy;
};
HARVEST_SIMD_INLINE Gram make_template(const cv::Mat1f& I, float px, float py, int h, int pitch, float* patch,
                                       float* ival, float* ix, float* iy) {
  const int side = 2 * h + 1, ext = side + 2, epitch = pitch + 8;
  sample_window(I, px, py, h + 1, ext, epitch, patch);
  v8f gxx{}, gxy{}, gyy{};
  for (int j = 0; j < side; ++j) {
    const float* up = patch + j * epitch;
    const float* mid = up + epitch;
    const float* down = mid + epitch;
    for (int b = 0; b < pitch; b += 8) {
      v8f vx = 0.5f * (simd::load8(mid + b + 2) - simd::load8(mid + b));
      v8f vy = 0.5f * (simd::load8(down + b + 1) - simd::load8(up + b + 1));
      v8f vv = simd::load8(mid + b + 1);
      for (int l = 0; l < 8; ++l)
        if (b + l >= side) vx[l] = vy[l] = vv[l] = 0.f;
      simd::store8(ix + j * pitch + b, vx);
      simd::store8(iy + j * pitch + b, vy);
      simd::store8(ival + j * pitch + b, vv);
      gxx += vx * vx;
      gxy += vx * vy;
      gyy += vy * vy;
    }
  }
  return {simd::sum(gxx), simd::sum(gxy), simd::sum(gyy)};
}

// b = sum (I - J) [ix iy]^T over the window of J centred at (cx, cy).
HARVEST_SIMD_INLINE void mismatch(const cv::Mat1f& J, float cx, float cy, int h, int pitch, const float* ival,
                                  const float* ix, const float* iy, float& bx, float& by) {
  const int side = 2 * h + 1;
  const float fx = std::floor(cx), fy = std::floor(cy);
  const float ax = cx - fx, ay = cy - fy;
  const v8f w00 = simd::splat((1.f - ax) * (1.f - ay)), w01 = simd::splat(ax * (1.f - ay)),
            w10 = simd::splat((1.f - ax) * ay), w11 = simd::splat(ax * ay);
  const std::size_t step = J.step1();
  const float* base =
      J.ptr<float>(0) + (static_cast<int>(fy) - h) * static_cast<std::ptrdiff_t>(step) + (static_cast<int>(fx) - h);
  v8f sx{}, sy{};
  for (int j = 0; j < side; ++j) {
    const float* r0 = base + static_cast<std::ptrdiff_t>(j) * static_cast<std::ptrdiff_t>(step);
    const float* r1 = r0 + step;
    const int o = j * pitch;
    for (int b = 0; b < pitch; b += 8) {
      const v8f val = w00 * simd::load8(r0 + b) + w01 * simd::load8(r0 + b + 1) + w10 * simd::load8(r1 + b) +
                      w11 * simd::load8(r1 + b + 1);
      const v8f diff = simd::load8(ival + o + b) - val;
      sx += diff * simd::load8(ix + o + b);
      sy += diff * simd::load8(iy + o + b);
    }
  }
  bx = simd::sum(sx);
  by = simd::sum(sy);
}

struct Scratch {
  int pitch;
  float* patch;  // (side + 2) rows of pitch + 8
  float* ival;   // side rows of pitch each
  float* ix;
  float* iy;
};

inline float min_eig(float a, float b, float c) {
  return 0.5f * (a + c) - std::sqrt(0.25f * (a - c) * (a - c) + b * b);
}

// One feature, coarse to fine (Bouguet). Returns its result.
HARVEST_SIMD_INLINE LkResult track_one_impl(const Pyramid& prev, const Pyramid& next, cv::Point2f u, cv::Point2f guess,
                                            int levels, const LkParams& p, const Scratch& s) {
  LkResult r;
  const int h = std::max(p.window, 3) / 2;
  const int side = 2 * h + 1, n = side * side;
  const float eps2 = static_cast<float>(p.epsilon_px * p.epsilon_px);
  const float top_scale = 1.f / static_cast<float>(1 << (levels - 1));
  // g: displacement guess at the current level (Bouguet's g^L).
  float gx = (guess.x - u.x) * top_scale, gy = (guess.y - u.y) * top_scale;
  float dx = 0, dy = 0;
  for (int L = levels - 1; L >= 0; --L) {
    const cv::Mat1f& I = prev.level(L);
    const cv::Mat1f& J = next.level(L);
    const float scale = 1.f / static_cast<float>(1 << L);
    const float px = u.x * scale, py = u.y * scale;
    if (!inside(I, px, py, h + 1)) {
      // The window leaves the coarse image: skip this level, keep the guess.
      if (L == 0) return r;
      gx *= 2.f;
      gy *= 2.f;
      continue;
    }
    const Gram G = make_template(I, px, py, h, s.pitch, s.patch, s.ival, s.ix, s.iy);
    const float det = G.xx * G.yy - G.xy * G.xy;
    if (min_eig(G.xx, G.xy, G.yy) / static_cast<float>(n) < static_cast<float>(p.min_eigenvalue) || !(det > 0))
      return r;
    // Newton-Raphson on the residual: eta = G^-1 b.
    float vx = 0, vy = 0;
    int it = 0;
    for (; it < p.max_iterations; ++it) {
      const float cx = px + gx + vx, cy = py + gy + vy;
      if (!inside(J, cx, cy, h)) return r;
      float bx, by;
      mismatch(J, cx, cy, h, s.pitch, s.ival, s.ix, s.iy, bx, by);
      const float ex = (G.yy * bx - G.xy * by) / det, ey = (G.xx * by - G.xy * bx) / det;
      vx += ex;
      vy += ey;
      if (ex * ex + ey * ey < eps2) {
        ++it;
        break;
      }
    }
    dx = vx;
    dy = vy;
    if (L == 0) {
      r.iterations = it;
    } else {
      gx = 2.f * (gx + dx);
      gy = 2.f * (gy + dy);
    }
  }
  r.pt = cv::Point2f(u.x + gx + dx, u.y + gy + dy);
  const cv::Mat1f& J0 = next.level(0);
  if (!inside(J0, r.pt.x, r.pt.y, h + 1)) return r;
  // Residual against the level-0 template still in s.ival, and the gradient
  // matrix of the new window: a feature that landed on a flat or
  // one-directional patch is no longer trackable.
  float* jval = s.ival + side * s.pitch;  // the scratch has room for a second template
  float* jx = s.ix + side * s.pitch;
  float* jy = s.iy + side * s.pitch;
  const Gram Gj = make_template(J0, r.pt.x, r.pt.y, h, s.pitch, s.patch, jval, jx, jy);
  v8f err{};
  for (int q = 0; q < side * s.pitch; q += 8) {
    const v8f d = simd::load8(s.ival + q) - simd::load8(jval + q);
    err += d > 0 ? d : -d;
  }
  r.error = simd::sum(err) / static_cast<float>(n);
  r.found = min_eig(Gj.xx, Gj.xy, Gj.yy) / static_cast<float>(n) >= static_cast<float>(p.min_eigenvalue);
  return r;
}
HARVEST_SIMD_DISPATCH(track_one, track_one_impl, LkResult,
                      (const Pyramid& prev, const Pyramid& next, cv::Point2f u, cv::Point2f guess, int levels,
                       const LkParams& p, const Scratch& s),
                      (prev, next, u, guess, levels, p, s))

}  // namespace

cv::Mat1f pyramid_down(const cv::Mat1f& src, bool allow_simd) {
  cv::Mat1f out = padded((src.rows + 1) / 2, (src.cols + 1) / 2);
  pyramid_down_into(allow_simd, src, out);
  return out;
}

Pyramid::Pyramid(const cv::Mat1b& gray, int levels, bool allow_simd) {
  cv::Mat1f base = padded(gray.rows, gray.cols);
  gray.convertTo(base, CV_32F);
  level_.push_back(base);
  for (int i = 1; i < levels; ++i) {
    const cv::Mat1f& last = level_.back();
    if (last.cols < 16 || last.rows < 16) break;
    level_.push_back(pyramid_down(last, allow_simd));
  }
}

std::vector<LkResult> track_lk(const Pyramid& prev, const Pyramid& next, const std::vector<cv::Point2f>& points,
                               const LkParams& p, const std::vector<cv::Point2f>& guesses) {
  std::vector<LkResult> out(points.size());
  if (prev.empty() || next.empty()) return out;
  const int levels = std::min({prev.levels(), next.levels(), std::max(p.levels, 1)});
  const int h = std::max(p.window, 3) / 2;
  const int side = 2 * h + 1;
  const int pitch = (side + 7) / 8 * 8;
  std::vector<float> buf(static_cast<std::size_t>((side + 2) * (pitch + 8) + 6 * side * pitch));
  Scratch s{pitch, buf.data(), nullptr, nullptr, nullptr};
  s.ival = s.patch + (side + 2) * (pitch + 8);
  s.ix = s.ival + 2 * side * pitch;
  s.iy = s.ix + 2 * side * pitch;
  for (std::size_t k = 0; k < points.size(); ++k) {
    const cv::Point2f guess = guesses.size() == points.size() ? guesses[k] : points[k];
    out[k] = track_one(p.allow_simd, prev, next, points[k], guess, levels, p, s);
  }
  return out;
}

}  // namespace harvest::features
