#include "features/corners.hpp"

#include <algorithm>
#include <cmath>
#include <functional>
#include <limits>
#include <numeric>

#include "features/simd.hpp"

namespace harvest::features {

namespace {

using simd::v8f;

// Sums of Sobel products are exact in int32: |gx|, |gy| <= 1020, so a
// product is <= 1040400 and a W x W sum stays below 2^31 for W <= 45.
constexpr int kMaxWindow = 45;

// The smaller eigenvalue of Z (eq. 2-2, 2-3) at every pixel whose window lies
// where gradients exist, row by row: Sobel products of each image row are
// summed along the row (window W), kept in a ring of W + 1 rows, and the
// column sums over the last W rows are updated by adding the newest row and
// subtracting the oldest. All integer until the eigenvalue, so the sums are
// exact (no drift of running float sums).
// Sobel products of image row r (1 <= r <= rows-2), summed along the row
// (window W, centres x in [lo, cols - lo)) into hxx/hxy/hyy.
HARVEST_SIMD_INLINE void summed_products_row(const cv::Mat1b& gray, int r, int window, int32_t* prod, int32_t* hxx,
                                             int32_t* hxy, int32_t* hyy) {
  const int cols = gray.cols, h = window / 2, lo = h + 1;
  const auto n = static_cast<std::size_t>(cols);
  const uint8_t* a = gray[r - 1];
  const uint8_t* b = gray[r];
  const uint8_t* c = gray[r + 1];
  int32_t* pxx = prod;
  int32_t* pxy = prod + n;
  int32_t* pyy = prod + 2 * n;
  for (int x = 1; x + 1 < cols; ++x) {
    const int32_t gx = (a[x + 1] + 2 * b[x + 1] + c[x + 1]) - (a[x - 1] + 2 * b[x - 1] + c[x - 1]);
    const int32_t gy = (c[x - 1] + 2 * c[x] + c[x + 1]) - (a[x - 1] + 2 * a[x] + a[x + 1]);
    pxx[x] = gx * gx;
    pxy[x] = gx * gy;
    pyy[x] = gy * gy;
  }
  int32_t* const dst[3] = {hxx, hxy, hyy};
  for (int ch = 0; ch < 3; ++ch) {
    const int32_t* p = prod + static_cast<std::size_t>(ch) * n;
    int32_t* d = dst[ch];
    // p[x - h .. x + h] stays in [1, cols - 2], where the products exist.
    for (int x = lo; x < cols - lo; ++x) d[x] = p[x - h];
    for (int k = 1; k < window; ++k)
      for (int x = lo; x < cols - lo; ++x) d[x] += p[x - h + k];
  }
}

// The smaller eigenvalue of Z (eq. 2-2, 2-3) at every pixel whose window lies
// where gradients exist, row by row: the Sobel products of each image row are
// summed along the row, kept in a ring of W + 1 rows, and the column sums over
// the last W rows are updated by adding the newest row and subtracting the
// oldest. All integer until the eigenvalue, so the sums are exact.
HARVEST_SIMD_INLINE void eigen_map_impl(const cv::Mat1b& gray, int window, cv::Mat1f& out) {
  const int rows = gray.rows, cols = gray.cols, h = window / 2, lo = h + 1;
  out.setTo(0);
  if (rows < 2 * lo + 1 || cols < 2 * lo + 1) return;
  const auto n = static_cast<std::size_t>(cols);
  const int ring = window + 1;
  // ring x 3 summed product rows (xx, xy, yy), 3 column accumulators, 3 product rows.
  std::vector<int32_t> buf(n * static_cast<std::size_t>(3 * ring + 6), 0);
  int32_t* const acc = buf.data() + n * static_cast<std::size_t>(3 * ring);
  int32_t* const prod = acc + 3 * n;

  // Output row lo sums image rows 1 .. 2h+1.
  for (int r = 1; r <= window; ++r) {
    int32_t* s = buf.data() + n * static_cast<std::size_t>((r % ring) * 3);
    summed_products_row(gray, r, window, prod, s, s + n, s + 2 * n);
    for (std::size_t i = 0; i < 3 * n; ++i) acc[i] += s[i];
  }
  const double k = 1.0 / 64.0;  // (Sobel / 8)^2
  for (int y = lo; y < rows - lo; ++y) {
    if (y > lo) {
      int32_t* in = buf.data() + n * static_cast<std::size_t>(((y + h) % ring) * 3);
      const int32_t* old = buf.data() + n * static_cast<std::size_t>(((y - h - 1) % ring) *
                                                                     3);  // not overwritten: the ring holds W + 1 rows
      summed_products_row(gray, y + h, window, prod, in, in + n, in + 2 * n);
      for (std::size_t i = 0; i < 3 * n; ++i) acc[i] += in[i] - old[i];
    }
    const int32_t* sa = acc;
    const int32_t* sb = acc + n;
    const int32_t* sc = acc + 2 * n;
    float* o = out[y];
    for (int x = lo; x < cols - lo; ++x) {
      const double a = k * sa[x], b = k * sb[x], c = k * sc[x];
      const double hd = 0.5 * (a - c);
      o[x] = static_cast<float>(0.5 * (a + c) - std::sqrt(hd * hd + b * b));
    }
  }
}
HARVEST_SIMD_DISPATCH(eigen_map, eigen_map_impl, void, (const cv::Mat1b& gray, int window, cv::Mat1f& out),
                      (gray, window, out))

// Largest eigenvalue in the search rectangle (allowed pixels only).
HARVEST_SIMD_INLINE float region_max_impl(const cv::Mat1f& eig, const cv::Rect& r, const cv::Mat1b* mask) {
  v8f m{};
  float best = 0;
  for (int y = r.y; y < r.br().y; ++y) {
    const float* e = eig[y];
    const uint8_t* mk = mask ? (*mask)[y] : nullptr;
    int x = r.x;
    if (!mk) {
      for (; x + 8 <= r.br().x; x += 8) {
        const v8f v = simd::load8(e + x);
        m = m > v ? m : v;
      }
    }
    for (; x < r.br().x; ++x)
      if ((!mk || mk[x]) && e[x] > best) best = e[x];
  }
  for (int i = 0; i < 8; ++i) best = std::max(best, m[i]);
  return best;
}
HARVEST_SIMD_DISPATCH(region_max, region_max_impl, float,
                      (const cv::Mat1f& eig, const cv::Rect& r, const cv::Mat1b* mask), (eig, r, mask))

// Candidates: above the threshold, allowed, and a 3x3 local maximum (ties
// allowed). Each is a key (eigenvalue bits << 32 | pixel index): eigenvalues
// are positive, so their IEEE bits order like the values, and sorting the
// keys descending gives strongest first, equal values later pixel first.
HARVEST_SIMD_INLINE void peaks_impl(const cv::Mat1f& eig, const cv::Rect& r, float threshold, const cv::Mat1b* mask,
                                    std::vector<uint64_t>& keys) {
  const int w = r.width;
  std::vector<uint8_t> flag(static_cast<std::size_t>(w) + 8, 0);
  for (int y = r.y; y < r.br().y; ++y) {
    const float* a = eig[y - 1] + r.x;
    const float* b = eig[y] + r.x;
    const float* c = eig[y + 1] + r.x;
    uint8_t* f = flag.data();
    for (int i = 0; i < w; ++i) {
      const float v = b[i];
      const float m0 = std::max(std::max(a[i - 1], a[i]), a[i + 1]);
      const float m1 = std::max(b[i - 1], b[i + 1]);
      const float m2 = std::max(std::max(c[i - 1], c[i]), c[i + 1]);
      f[i] = static_cast<uint8_t>((v > threshold) & (v >= std::max(std::max(m0, m1), m2)));
    }
    if (mask) {
      const uint8_t* mk = (*mask)[y] + r.x;
      for (int i = 0; i < w; ++i) f[i] = static_cast<uint8_t>(f[i] & (mk[i] != 0));
    }
    for (int i = 0; i < w; i += 8) {
      uint64_t any;
      std::memcpy(&any, f + i, 8);  // the buffer has 8 spare zero bytes
      if (!any) continue;
      for (int j = i; j < std::min(i + 8, w); ++j) {
        if (!f[j]) continue;
        uint32_t bits;
        std::memcpy(&bits, b + j, 4);
        keys.push_back(uint64_t(bits) << 32 | static_cast<uint32_t>(y * eig.cols + r.x + j));
      }
    }
  }
}
HARVEST_SIMD_DISPATCH(peaks, peaks_impl, void,
                      (const cv::Mat1f& eig, const cv::Rect& r, float threshold, const cv::Mat1b* mask,
                       std::vector<uint64_t>& keys),
                      (eig, r, threshold, mask, keys))

}  // namespace

cv::Mat1f min_eigenvalue_map(const cv::Mat1b& gray, int window, bool allow_simd) {
  CV_Assert(window >= 3 && window % 2 == 1);
  if (window > kMaxWindow)
    CV_Error(cv::Error::StsOutOfRange, "Shi-Tomasi window " + std::to_string(window) + " > " +
                                           std::to_string(kMaxWindow) + " (integer sums would overflow)");
  cv::Mat1f out(gray.rows, gray.cols);
  eigen_map(allow_simd, gray, window, out);
  return out;
}

std::vector<Corner> detect_corners(const cv::Mat1b& gray, const CornerParams& p, const cv::Rect& region,
                                   const cv::Mat1b& mask, const std::vector<cv::Point2f>& existing) {
  std::vector<Corner> out;
  if (gray.empty()) return out;
  const cv::Mat1f eig = min_eigenvalue_map(gray, p.window, p.allow_simd);
  const int edge = std::max(p.border, p.window / 2 + 1);
  cv::Rect search(edge, edge, gray.cols - 2 * edge, gray.rows - 2 * edge);
  if (search.width <= 0 || search.height <= 0) return out;
  if (region.area() > 0) search &= region;
  if (search.area() <= 0) return out;
  const cv::Mat1b* use_mask = !mask.empty() && mask.size() == gray.size() ? &mask : nullptr;

  const double max_val = region_max(p.allow_simd, eig, search, use_mask);
  // Only positive eigenvalues are corners (their keys below sort by value).
  const double threshold = std::max(0.0, std::max(p.min_eigenvalue, p.quality_level * max_val));
  // The map is float: compare with the largest float <= threshold, so a value
  // passes exactly when it exceeds the threshold.
  float thr = static_cast<float>(threshold);
  if (static_cast<double>(thr) > threshold) thr = std::nextafter(thr, -std::numeric_limits<float>::infinity());
  std::vector<uint64_t> keys;
  peaks(p.allow_simd, eig, search, thr, use_mask, keys);

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

  // Strongest first. Only the head of the order is ever needed: sort it in
  // chunks (a few times max_corners), partitioning the rest off unsorted.
  const std::size_t want = p.max_corners > 0 ? static_cast<std::size_t>(p.max_corners) : keys.size();
  const std::size_t chunk = std::max<std::size_t>(4 * want, 256);
  auto next = keys.begin();
  while (next != keys.end()) {
    auto end =
        keys.end() - next > static_cast<std::ptrdiff_t>(chunk) ? next + static_cast<std::ptrdiff_t>(chunk) : keys.end();
    if (end != keys.end()) std::nth_element(next, end, keys.end(), std::greater<>());
    std::sort(next, end, std::greater<>());
    for (auto it = next; it != end; ++it) {
      const auto index = static_cast<int>(*it & 0xffffffffu);
      const cv::Point2f q(static_cast<float>(index % gray.cols), static_cast<float>(index / gray.cols));
      if (too_close(q)) continue;
      add(q);
      uint32_t bits = static_cast<uint32_t>(*it >> 32);
      float v;
      std::memcpy(&v, &bits, 4);
      out.push_back({q, v});
      if (p.max_corners > 0 && static_cast<int>(out.size()) >= p.max_corners) return out;
    }
    next = end;
  }
  return out;
}

}  // namespace harvest::features
