// Colour segmentation and connected regions: the hot path of the fruit
// detector (thesis section 2.2, appendix B.1).
//
// threshold_crcgcb() applies the CrCgCb colour-difference transform of eq. 2-1
//   Cr =  0.721 R - 0.587 G - 0.114 B
//   Cg = -0.299 R + 0.413 G - 0.114 B
//   Cb = -0.299 R - 0.587 G + 0.886 B
// and keeps pixels with all three inside their closed ranges, in one pass. The
// coefficients have three decimals, so the test runs in exact integer
// arithmetic (1000 C compared with the rounded-inward 1000 bounds) and gives
// the same mask as a floating-point evaluation of the thesis formula.
//
// RegionLabeler finds 4-connected regions of a mask by run-length encoding
// and union-find over runs, accumulating area, centroid and bounding box.
#pragma once

#include <cstddef>
#include <cstdint>
#include <opencv2/core.hpp>
#include <vector>

#include "config/key.hpp"
#include "vision/bitmask.hpp"

namespace harvest::vision {

// The detector's colour-threshold keys: closed ranges, thesis defaults
// (appendix B.1, "1/15/04").
namespace threshold_keys {
using config::Key;
inline constexpr Key<double> cr_min{
    "cr_min", 22, {-1000, 1000}, "", "lowest Cr of a fruit pixel (thesis appendix B.1)"};
inline constexpr Key<double> cr_max{"cr_max", 90, {-1000, 1000}, "", "highest Cr (at least cr_min)"};
inline constexpr Key<double> cg_min{"cg_min", -25, {-1000, 1000}, "", "lowest Cg"};
inline constexpr Key<double> cg_max{"cg_max", 25, {-1000, 1000}, "", "highest Cg (at least cg_min)"};
inline constexpr Key<double> cb_min{"cb_min", -220, {-1000, 1000}, "", "lowest Cb"};
inline constexpr Key<double> cb_max{"cb_max", -5, {-1000, 1000}, "", "highest Cb (at least cb_min)"};
}  // namespace threshold_keys

struct ColorThresholds {  // closed ranges
  double cr_min = threshold_keys::cr_min.fallback, cr_max = threshold_keys::cr_max.fallback;
  double cg_min = threshold_keys::cg_min.fallback, cg_max = threshold_keys::cg_max.fallback;
  double cb_min = threshold_keys::cb_min.fallback, cb_max = threshold_keys::cb_max.fallback;
};

// Integer form of the thresholds (bounds on 1000 C); exact for any double bounds.
struct IntThresholds {
  int32_t lo[3];
  int32_t hi[3];
  static IntThresholds from(const ColorThresholds& t);
};

// bgr: 8-bit B,G,R pixels, `stride` bytes per row. mask: 255 inside, 0 outside.
void threshold_crcgcb(const uint8_t* bgr, int width, int height, std::size_t stride, const ColorThresholds& t,
                      uint8_t* mask, std::size_t mask_stride);
cv::Mat1b threshold_crcgcb(const cv::Mat3b& bgr, const ColorThresholds& t);
// The same without the AVX2 kernel (threshold_crcgcb uses it when the CPU has
// AVX2); for tests comparing the two and for benchmarks.
void threshold_crcgcb_portable(const uint8_t* bgr, int width, int height, std::size_t stride, const ColorThresholds& t,
                               uint8_t* mask, std::size_t mask_stride);

// The same test straight into a packed mask (bit set inside), AVX2 when the
// CPU has it, and the portable form of it.
void threshold_crcgcb(const cv::Mat3b& bgr, const ColorThresholds& t, BitMask& mask);
void threshold_crcgcb_portable(const cv::Mat3b& bgr, const ColorThresholds& t, BitMask& mask);

// The thesis colour-difference values of one pixel (for tests and tools).
struct CrCgCb {
  double cr, cg, cb;
};
CrCgCb crcgcb(uint8_t b, uint8_t g, uint8_t r);

struct Run {
  int32_t y, x0, x1;  // pixels x0 .. x1-1 of row y
  int32_t label;      // index into the region list after labelling, -1 if dropped
};

struct Region {
  int64_t area = 0;
  double sum_x = 0, sum_y = 0;             // sums of pixel coordinates
  int32_t x0 = 0, y0 = 0, x1 = 0, y1 = 0;  // bounding box, x1/y1 exclusive
  double cx() const { return sum_x / static_cast<double>(area); }
  double cy() const { return sum_y / static_cast<double>(area); }
};

class RegionLabeler {
 public:
  // Labels the 4-connected regions of nonzero pixels. Regions with area <=
  // min_area are dropped (the thesis keeps count > MinRegionArea). Regions
  // are ordered by their first pixel in raster order.
  const std::vector<Region>& label(const cv::Mat1b& mask, int64_t min_area);
  // The same from a packed mask (no bytes to pack first).
  const std::vector<Region>& label(const BitMask& mask, int64_t min_area);

  const std::vector<Region>& regions() const { return regions_; }
  const std::vector<Run>& runs() const { return runs_; }
  // Paints region `index` into a crop of its bounding box (255 inside).
  cv::Mat1b region_mask(std::size_t index, int pad = 0) const;
  // A label image (region index + 1, 0 background), mainly for tests.
  cv::Mat1i label_image(int width, int height) const;

 private:
  int32_t find(int32_t i);
  // label()'s body; row_bits(y, base) gives the 64 pixels from x = base of row y as bits.
  template <typename RowBits>
  const std::vector<Region>& label_rows(int width, int height, int64_t min_area, RowBits row_bits);
  std::vector<Run> runs_;
  std::vector<int32_t> parent_;
  std::vector<Region> regions_;
  std::vector<int32_t> region_first_run_;  // runs of one region are chained through next_run_
  std::vector<int32_t> next_run_;
  std::vector<Region> acc_;  // scratch of label()
  std::vector<int32_t> index_of_root_, last_run_;
};

}  // namespace harvest::vision
