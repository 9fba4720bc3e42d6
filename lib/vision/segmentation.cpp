#include "vision/segmentation.hpp"

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstring>

namespace harvest::vision {

namespace {
// 1000 C is an integer, so C >= lo  <=>  1000 C >= ceil(1000 lo), and likewise for hi.
int32_t lower_bound_milli(double v) { return static_cast<int32_t>(std::ceil(v * 1000.0 - 1e-9)); }
int32_t upper_bound_milli(double v) { return static_cast<int32_t>(std::floor(v * 1000.0 + 1e-9)); }
}  // namespace

IntThresholds IntThresholds::from(const ColorThresholds& t) {
  IntThresholds it{};
  const double lo[3] = {t.cr_min, t.cg_min, t.cb_min};
  const double hi[3] = {t.cr_max, t.cg_max, t.cb_max};
  for (int i = 0; i < 3; ++i) {
    it.lo[i] = lower_bound_milli(std::clamp(lo[i], -1e6, 1e6));
    it.hi[i] = upper_bound_milli(std::clamp(hi[i], -1e6, 1e6));
  }
  return it;
}

CrCgCb crcgcb(uint8_t b, uint8_t g, uint8_t r) {
  return {0.721 * r - 0.587 * g - 0.114 * b, -0.299 * r + 0.413 * g - 0.114 * b, -0.299 * r - 0.587 * g + 0.886 * b};
}

namespace {
// One branch-free pass over a row; the unsigned range test (v - lo <= hi - lo)
// keeps the loop vectorisable. Built for AVX2 and baseline x86-64, chosen at
// load time, since a distribution binary cannot assume AVX2.
#if defined(__x86_64__) && defined(__GNUC__)
__attribute__((target_clones("avx2", "default")))
#endif
void threshold_row(const uint8_t* __restrict p, uint8_t* __restrict m, int width, const IntThresholds& it) {
  const int32_t lo0 = it.lo[0], lo1 = it.lo[1], lo2 = it.lo[2];
  const uint32_t w0 = static_cast<uint32_t>(it.hi[0] - lo0), w1 = static_cast<uint32_t>(it.hi[1] - lo1),
                 w2 = static_cast<uint32_t>(it.hi[2] - lo2);
  for (int x = 0; x < width; ++x) {
    const int32_t b = p[3 * x], g = p[3 * x + 1], r = p[3 * x + 2];
    const int32_t cr = 721 * r - 587 * g - 114 * b;
    const int32_t cg = -299 * r + 413 * g - 114 * b;
    const int32_t cb = -299 * r - 587 * g + 886 * b;
    const bool in = (static_cast<uint32_t>(cr - lo0) <= w0) & (static_cast<uint32_t>(cg - lo1) <= w1) &
                    (static_cast<uint32_t>(cb - lo2) <= w2);
    m[x] = static_cast<uint8_t>(-static_cast<int8_t>(in));
  }
}
}  // namespace

void threshold_crcgcb(const uint8_t* bgr, int width, int height, std::size_t stride, const ColorThresholds& t,
                      uint8_t* mask, std::size_t mask_stride) {
  const IntThresholds it = IntThresholds::from(t);
  // An empty range (lo > hi) must reject everything.
  const bool empty = it.lo[0] > it.hi[0] || it.lo[1] > it.hi[1] || it.lo[2] > it.hi[2];
  for (int y = 0; y < height; ++y) {
    uint8_t* m = mask + static_cast<std::size_t>(y) * mask_stride;
    if (empty)
      std::memset(m, 0, static_cast<std::size_t>(width));
    else
      threshold_row(bgr + static_cast<std::size_t>(y) * stride, m, width, it);
  }
}

cv::Mat1b threshold_crcgcb(const cv::Mat3b& bgr, const ColorThresholds& t) {
  cv::Mat1b mask(bgr.size());
  threshold_crcgcb(bgr.data, bgr.cols, bgr.rows, bgr.step, t, mask.data, mask.step);
  return mask;
}

namespace {
// Bit i set iff byte i of the (little-endian) word is nonzero. The first line
// sets each byte's top bit iff the byte is nonzero without carries between
// bytes; the multiply gathers the eight top bits into the top byte.
inline uint64_t nonzero_bits(uint64_t w) {
  const uint64_t t = (((w & 0x7F7F7F7F7F7F7F7FULL) + 0x7F7F7F7F7F7F7F7FULL) | w) & 0x8080808080808080ULL;
  return ((t >> 7) * 0x0102040810204080ULL) >> 56;
}
static_assert(std::endian::native == std::endian::little, "nonzero_bits assumes a little-endian machine");
}  // namespace

int32_t RegionLabeler::find(int32_t i) {
  while (parent_[i] != i) {
    parent_[i] = parent_[parent_[i]];  // path halving
    i = parent_[i];
  }
  return i;
}

const std::vector<Region>& RegionLabeler::label(const cv::Mat1b& mask, int64_t min_area) {
  runs_.clear();
  parent_.clear();
  regions_.clear();
  const int width = mask.cols;
  int32_t prev_begin = 0, prev_end = 0;
  for (int y = 0; y < mask.rows; ++y) {
    const uint8_t* row = mask.ptr<uint8_t>(y);
    const auto cur_begin = static_cast<int32_t>(runs_.size());
    // Runs are found 64 pixels at a time on a bit mask of the row (bit i =
    // pixel i nonzero), so the work is per run, not per pixel, and there is no
    // branch per pixel to mispredict on a speckled mask.
    bool in_run = false;
    int start = 0;
    auto scan = [&](uint64_t bits, int base, uint64_t valid) {
      uint64_t zeros = ~bits & valid;
      for (;;) {
        if (!in_run) {
          if (!bits) return;
          const int s = std::countr_zero(bits);
          start = base + s;
          in_run = true;
          zeros &= ~uint64_t{0} << s;
        }
        if (!zeros) return;  // the run goes on into the next chunk
        const int e = std::countr_zero(zeros);
        const auto id = static_cast<int32_t>(runs_.size());
        runs_.push_back({y, start, base + e, -1});
        parent_.push_back(id);
        in_run = false;
        bits &= ~uint64_t{0} << e;
      }
    };
    int x = 0;
    for (; x + 64 <= width; x += 64) {
      uint64_t bits = 0;
      for (int k = 0; k < 8; ++k) {
        uint64_t w;
        std::memcpy(&w, row + x + 8 * k, 8);
        bits |= nonzero_bits(w) << (8 * k);
      }
      if (bits != 0 || in_run) scan(bits, x, ~uint64_t{0});
    }
    if (x < width) {
      const int n = width - x;
      uint64_t bits = 0;
      for (int i = 0; i < n; ++i) bits |= static_cast<uint64_t>(row[x + i] != 0) << i;
      scan(bits, x, (uint64_t{1} << n) - 1);
    }
    if (in_run) {
      const auto id = static_cast<int32_t>(runs_.size());
      runs_.push_back({y, start, width, -1});
      parent_.push_back(id);
    }
    const auto cur_end = static_cast<int32_t>(runs_.size());
    // Merge with 4-connected (x-overlapping) runs of the previous row; the
    // smaller index stays root, so a root is its region's first run.
    for (int32_t i = cur_begin, j = prev_begin; i < cur_end && j < prev_end;) {
      const Run& a = runs_[i];
      const Run& b = runs_[j];
      if (b.x1 <= a.x0) {
        ++j;
      } else if (a.x1 <= b.x0) {
        ++i;
      } else {
        const int32_t ra = find(i), rb = find(j);
        if (ra != rb) parent_[std::max(ra, rb)] = std::min(ra, rb);
        if (a.x1 < b.x1)
          ++i;
        else
          ++j;
      }
    }
    prev_begin = cur_begin;
    prev_end = cur_end;
  }

  // Accumulate statistics on roots.
  const auto n = static_cast<int32_t>(runs_.size());
  std::vector<Region> acc(static_cast<std::size_t>(n));
  for (int32_t i = 0; i < n; ++i) {
    const int32_t root = find(i);
    parent_[i] = root;
    const Run& r = runs_[i];
    Region& g = acc[root];
    const int64_t len = r.x1 - r.x0;
    if (g.area == 0) {
      g.x0 = r.x0;
      g.x1 = r.x1;
      g.y0 = r.y;
      g.y1 = r.y + 1;
    } else {
      g.x0 = std::min(g.x0, r.x0);
      g.x1 = std::max(g.x1, r.x1);
      g.y1 = r.y + 1;
    }
    g.area += len;
    g.sum_x += 0.5 * static_cast<double>(r.x0 + r.x1 - 1) * static_cast<double>(len);
    g.sum_y += static_cast<double>(r.y) * static_cast<double>(len);
  }
  std::vector<int32_t> index_of_root(static_cast<std::size_t>(n), -1);
  region_first_run_.clear();
  next_run_.assign(static_cast<std::size_t>(n), -1);
  std::vector<int32_t> last_run;
  for (int32_t i = 0; i < n; ++i) {
    const int32_t root = parent_[i];
    if (root == i && acc[i].area > min_area) {
      index_of_root[i] = static_cast<int32_t>(regions_.size());
      regions_.push_back(acc[i]);
      region_first_run_.push_back(i);
      last_run.push_back(i);
    }
    const int32_t idx = index_of_root[root];
    runs_[i].label = idx;
    if (idx >= 0 && root != i) {
      next_run_[last_run[idx]] = i;
      last_run[idx] = i;
    }
  }
  return regions_;
}

cv::Mat1b RegionLabeler::region_mask(std::size_t index, int pad) const {
  const Region& g = regions_.at(index);
  cv::Mat1b crop = cv::Mat1b::zeros(g.y1 - g.y0 + 2 * pad, g.x1 - g.x0 + 2 * pad);
  for (int32_t i = region_first_run_[index]; i >= 0; i = next_run_[i]) {
    const Run& r = runs_[i];
    std::memset(crop.ptr<uint8_t>(r.y - g.y0 + pad) + (r.x0 - g.x0 + pad), 255, static_cast<std::size_t>(r.x1 - r.x0));
  }
  return crop;
}

cv::Mat1i RegionLabeler::label_image(int width, int height) const {
  cv::Mat1i labels = cv::Mat1i::zeros(height, width);
  for (const Run& r : runs_)
    if (r.label >= 0)
      for (int x = r.x0; x < r.x1; ++x) labels(r.y, x) = r.label + 1;
  return labels;
}

}  // namespace harvest::vision
