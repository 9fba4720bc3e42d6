#include "vision/segmentation.hpp"

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstring>

#if defined(__x86_64__) && defined(__GNUC__)
#include <immintrin.h>
#endif

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
  const auto w0 = static_cast<uint32_t>(static_cast<int64_t>(it.hi[0]) - lo0),
             w1 = static_cast<uint32_t>(static_cast<int64_t>(it.hi[1]) - lo1),
             w2 = static_cast<uint32_t>(static_cast<int64_t>(it.hi[2]) - lo2);
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

#if defined(__x86_64__) && defined(__GNUC__)
#define HARVEST_HAVE_AVX2_KERNEL 1
// pshufb control gathering channel `c` (0 B, 1 G, 2 R) of 16 packed BGR pixels
// from the 16-byte block `part` (0..2) of their 48 bytes; -1 zeroes a byte.
__m128i gather_mask(int c, int part) {
  alignas(16) int8_t idx[16];
  for (int pos = 0; pos < 16; ++pos) {
    const int byte = 3 * pos + c;
    idx[pos] = static_cast<int8_t>(byte / 16 == part ? byte % 16 : -1);
  }
  return _mm_load_si128(reinterpret_cast<const __m128i*>(idx));
}

// A 32-bit lane holding the 16-bit pair (lo, hi) for _mm256_madd_epi16.
constexpr int32_t pair16(int lo, int hi) {
  return static_cast<int32_t>(static_cast<uint32_t>(static_cast<uint16_t>(lo)) |
                              (static_cast<uint32_t>(static_cast<uint16_t>(hi)) << 16));
}

// All-ones lanes where lo <= krg . (R, G) + kb . (B, 0) <= lo + w (unsigned w).
__attribute__((target("avx2"))) inline __m256i inside(__m256i rg, __m256i b0, __m256i krg, __m256i kb, __m256i lo,
                                                      __m256i w) {
  const __m256i d = _mm256_sub_epi32(_mm256_add_epi32(_mm256_madd_epi16(rg, krg), _mm256_madd_epi16(b0, kb)), lo);
  return _mm256_cmpeq_epi32(_mm256_min_epu32(d, w), d);
}

// The same test as threshold_row, 16 pixels at a time with AVX2: the three
// channels are gathered with pshufb, widened to 16 bits and paired, so each
// colour difference is two pmaddwd (R, G and B, 0 pairs) in exact 32-bit
// integers; the unsigned range test is min_epu32 + cmpeq.
// kBits: `m` is the row of a packed mask (words as bytes, little-endian), each
// block of 16 pixels two bytes of it (pmovmskb), the tail bits set one by one.
template <bool kBits>
__attribute__((target("avx2"))) void threshold_row_avx2(const uint8_t* p, uint8_t* m, int width,
                                                        const IntThresholds& it) {
  static const __m128i kB0 = gather_mask(0, 0), kB1 = gather_mask(0, 1), kB2 = gather_mask(0, 2);
  static const __m128i kG0 = gather_mask(1, 0), kG1 = gather_mask(1, 1), kG2 = gather_mask(1, 2);
  static const __m128i kR0 = gather_mask(2, 0), kR1 = gather_mask(2, 1), kR2 = gather_mask(2, 2);
  const __m256i rg_cr = _mm256_set1_epi32(pair16(721, -587)), b_cr = _mm256_set1_epi32(pair16(-114, 0));
  const __m256i rg_cg = _mm256_set1_epi32(pair16(-299, 413)), b_cg = _mm256_set1_epi32(pair16(-114, 0));
  const __m256i rg_cb = _mm256_set1_epi32(pair16(-299, -587)), b_cb = _mm256_set1_epi32(pair16(886, 0));
  const __m256i lo0 = _mm256_set1_epi32(it.lo[0]), lo1 = _mm256_set1_epi32(it.lo[1]), lo2 = _mm256_set1_epi32(it.lo[2]);
  const __m256i w0 = _mm256_set1_epi32(static_cast<int32_t>(static_cast<int64_t>(it.hi[0]) - it.lo[0])),
                w1 = _mm256_set1_epi32(static_cast<int32_t>(static_cast<int64_t>(it.hi[1]) - it.lo[1])),
                w2 = _mm256_set1_epi32(static_cast<int32_t>(static_cast<int64_t>(it.hi[2]) - it.lo[2]));
  const __m256i zero = _mm256_setzero_si256();
  int x = 0;
  for (; x + 16 <= width; x += 16) {
    const uint8_t* q = p + 3 * x;
    const __m128i v0 = _mm_loadu_si128(reinterpret_cast<const __m128i*>(q));
    const __m128i v1 = _mm_loadu_si128(reinterpret_cast<const __m128i*>(q + 16));
    const __m128i v2 = _mm_loadu_si128(reinterpret_cast<const __m128i*>(q + 32));
    const __m128i b =
        _mm_or_si128(_mm_or_si128(_mm_shuffle_epi8(v0, kB0), _mm_shuffle_epi8(v1, kB1)), _mm_shuffle_epi8(v2, kB2));
    const __m128i g =
        _mm_or_si128(_mm_or_si128(_mm_shuffle_epi8(v0, kG0), _mm_shuffle_epi8(v1, kG1)), _mm_shuffle_epi8(v2, kG2));
    const __m128i r =
        _mm_or_si128(_mm_or_si128(_mm_shuffle_epi8(v0, kR0), _mm_shuffle_epi8(v1, kR1)), _mm_shuffle_epi8(v2, kR2));
    const __m256i b16 = _mm256_cvtepu8_epi16(b), g16 = _mm256_cvtepu8_epi16(g), r16 = _mm256_cvtepu8_epi16(r);
    // In-lane interleave: "lo" holds pixels 0-3 and 8-11, "hi" 4-7 and 12-15.
    const __m256i rg_lo = _mm256_unpacklo_epi16(r16, g16), rg_hi = _mm256_unpackhi_epi16(r16, g16);
    const __m256i b_lo = _mm256_unpacklo_epi16(b16, zero), b_hi = _mm256_unpackhi_epi16(b16, zero);
    // Cr first: leaves, bark and sky fail it, and a block where every pixel
    // does is outside whatever Cg and Cb say (the mask is already clear
    // there when packed; the byte mask gets its zeros).
    const __m256i cr_lo = inside(rg_lo, b_lo, rg_cr, b_cr, lo0, w0), cr_hi = inside(rg_hi, b_hi, rg_cr, b_cr, lo0, w0);
    if (_mm256_testz_si256(_mm256_or_si256(cr_lo, cr_hi), _mm256_or_si256(cr_lo, cr_hi))) {
      if constexpr (!kBits) _mm_storeu_si128(reinterpret_cast<__m128i*>(m + x), _mm_setzero_si128());
      continue;
    }
    const __m256i in_lo = _mm256_and_si256(_mm256_and_si256(cr_lo, inside(rg_lo, b_lo, rg_cg, b_cg, lo1, w1)),
                                           inside(rg_lo, b_lo, rg_cb, b_cb, lo2, w2));
    const __m256i in_hi = _mm256_and_si256(_mm256_and_si256(cr_hi, inside(rg_hi, b_hi, rg_cg, b_cg, lo1, w1)),
                                           inside(rg_hi, b_hi, rg_cb, b_cb, lo2, w2));
    // packs restores pixel order within each lane: lane 0 = 0-7, lane 1 = 8-15.
    const __m256i in16 = _mm256_packs_epi32(in_lo, in_hi);
    const __m128i in8 = _mm_packs_epi16(_mm256_castsi256_si128(in16), _mm256_extracti128_si256(in16, 1));
    if constexpr (kBits) {
      const auto bits = static_cast<uint16_t>(_mm_movemask_epi8(in8));
      std::memcpy(m + x / 8, &bits, 2);
    } else {
      _mm_storeu_si128(reinterpret_cast<__m128i*>(m + x), in8);
    }
  }
  if (x < width) {
    if constexpr (kBits) {
      uint8_t tail[16];
      threshold_row(p + 3 * x, tail, width - x, it);
      for (int i = 0; x + i < width; ++i)
        if (tail[i]) m[(x + i) / 8] |= static_cast<uint8_t>(1U << ((x + i) % 8));
    } else {
      threshold_row(p + 3 * x, m + x, width - x, it);
    }
  }
}

bool have_avx2() {
  static const bool yes = __builtin_cpu_supports("avx2");
  return yes;
}
#endif

// The AVX2 kernel when it is allowed and the CPU has it.
bool use_avx2(bool allow_simd) {
#ifdef HARVEST_HAVE_AVX2_KERNEL
  return allow_simd && have_avx2();
#else
  (void)allow_simd;
  return false;
#endif
}

// An empty range (lo > hi) rejects everything.
bool empty_range(const IntThresholds& it) { return it.lo[0] > it.hi[0] || it.lo[1] > it.hi[1] || it.lo[2] > it.hi[2]; }

void threshold_image(const uint8_t* bgr, int width, int height, std::size_t stride, const ColorThresholds& t,
                     uint8_t* mask, std::size_t mask_stride, bool allow_simd) {
  const IntThresholds it = IntThresholds::from(t);
  const bool empty = empty_range(it);
  [[maybe_unused]] const bool simd = use_avx2(allow_simd);
  for (int y = 0; y < height; ++y) {
    uint8_t* m = mask + static_cast<std::size_t>(y) * mask_stride;
    const uint8_t* p = bgr + static_cast<std::size_t>(y) * stride;
    if (empty) std::memset(m, 0, static_cast<std::size_t>(width));
#ifdef HARVEST_HAVE_AVX2_KERNEL
    else if (simd)
      threshold_row_avx2<false>(p, m, width, it);
#endif
    else
      threshold_row(p, m, width, it);
  }
}
}  // namespace

void threshold_crcgcb(const uint8_t* bgr, int width, int height, std::size_t stride, const ColorThresholds& t,
                      uint8_t* mask, std::size_t mask_stride) {
  threshold_image(bgr, width, height, stride, t, mask, mask_stride, true);
}

void threshold_crcgcb_portable(const uint8_t* bgr, int width, int height, std::size_t stride, const ColorThresholds& t,
                               uint8_t* mask, std::size_t mask_stride) {
  threshold_image(bgr, width, height, stride, t, mask, mask_stride, false);
}

namespace {
void threshold_bits(const cv::Mat3b& bgr, const ColorThresholds& t, BitMask& mask, bool allow_simd) {
  mask.create(bgr.cols, bgr.rows);
  const IntThresholds it = IntThresholds::from(t);
  if (empty_range(it)) return;  // nothing inside
  [[maybe_unused]] const bool simd = use_avx2(allow_simd);
  const int width = bgr.cols;
  for (int y = 0; y < bgr.rows; ++y) {
    const uint8_t* p = bgr.ptr<uint8_t>(y);
    uint64_t* words = mask.row(y);
#ifdef HARVEST_HAVE_AVX2_KERNEL
    if (simd) {
      threshold_row_avx2<true>(p, reinterpret_cast<uint8_t*>(words), width, it);
      continue;
    }
#endif
    // 64 pixels at a time through the byte kernel, then packed.
    uint8_t bytes[64];
    for (int x = 0; x < width; x += 64) {
      const int n = std::min(64, width - x);
      threshold_row(p + 3 * x, bytes, n, it);
      uint64_t bits = 0;
      for (int i = 0; i < n; ++i) bits |= static_cast<uint64_t>(bytes[i] & 1U) << i;
      words[x / 64] = bits;
    }
  }
}
}  // namespace

void threshold_crcgcb(const cv::Mat3b& bgr, const ColorThresholds& t, BitMask& mask) {
  threshold_bits(bgr, t, mask, true);
}

void threshold_crcgcb_portable(const cv::Mat3b& bgr, const ColorThresholds& t, BitMask& mask) {
  threshold_bits(bgr, t, mask, false);
}

cv::Mat1b threshold_crcgcb(const cv::Mat3b& bgr, const ColorThresholds& t) {
  cv::Mat1b mask(bgr.size());
  threshold_crcgcb(bgr.data, bgr.cols, bgr.rows, bgr.step, t, mask.data, mask.step);
  return mask;
}

int32_t RegionLabeler::find(int32_t i) {
  while (parent_[i] != i) {
    parent_[i] = parent_[parent_[i]];  // path halving
    i = parent_[i];
  }
  return i;
}

template <typename RowBits>
const std::vector<Region>& RegionLabeler::label_rows(int width, int height, int64_t min_area, RowBits row_bits) {
  runs_.clear();
  parent_.clear();
  regions_.clear();
  int32_t prev_begin = 0, prev_end = 0;
  for (int y = 0; y < height; ++y) {
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
    for (int x = 0; x < width; x += 64) {
      const int n = std::min(64, width - x);
      const uint64_t bits = row_bits(y, x, n);
      if (bits != 0 || in_run) scan(bits, x, n == 64 ? ~uint64_t{0} : (uint64_t{1} << n) - 1);
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
  std::vector<Region>& acc = acc_;  // buffers kept across calls: no allocation per frame
  acc.assign(static_cast<std::size_t>(n), Region{});
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
  std::vector<int32_t>& index_of_root = index_of_root_;
  index_of_root.assign(static_cast<std::size_t>(n), -1);
  region_first_run_.clear();
  next_run_.assign(static_cast<std::size_t>(n), -1);
  std::vector<int32_t>& last_run = last_run_;
  last_run.clear();
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

const std::vector<Region>& RegionLabeler::label(const cv::Mat1b& mask, int64_t min_area) {
  return label_rows(mask.cols, mask.rows, min_area, [&mask](int y, int x, int n) {
    const uint8_t* row = mask.ptr<uint8_t>(y) + x;
    uint64_t bits = 0;
    if (n == 64) {
      bits = pack64(row);
    } else {
      for (int i = 0; i < n; ++i) bits |= static_cast<uint64_t>(row[i] != 0) << i;
    }
    return bits;
  });
}

const std::vector<Region>& RegionLabeler::label(const BitMask& mask, int64_t min_area) {
  return label_rows(mask.width(), mask.height(), min_area,
                    [&mask](int y, int x, int) { return mask.row(y)[static_cast<std::size_t>(x) >> 6]; });
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
