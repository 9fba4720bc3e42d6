// Binary masks packed 64 pixels to a word, and the detector's morphology on
// them: erosion and dilation by any structuring element, word by word, with
// exactly the pixels cv::erode / cv::dilate / cv::morphologyEx give on a byte
// mask (0 / 255) with their default border (pixels outside the image do not
// count: erosion sees them set, dilation clear). A 320 x 240 mask is 1,200
// words, so an opening or closing with a small disc is a few thousand word
// operations where OpenCV touches every byte once per kernel element.
#pragma once

#include <bit>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <opencv2/core.hpp>
#include <utility>
#include <vector>

namespace harvest::vision {

// 64 bytes as 64 bits, bit i set iff bytes[i] is nonzero. Per word of eight
// bytes: the first line sets each byte's top bit iff the byte is nonzero,
// without carries between bytes; the multiply gathers the eight top bits.
inline uint64_t pack64(const uint8_t* bytes) {
  static_assert(std::endian::native == std::endian::little, "pack64 assumes a little-endian machine");
  uint64_t bits = 0;
  for (int k = 0; k < 8; ++k) {
    uint64_t w;
    std::memcpy(&w, bytes + 8 * k, 8);
    const uint64_t t = (((w & 0x7F7F7F7F7F7F7F7FULL) + 0x7F7F7F7F7F7F7F7FULL) | w) & 0x8080808080808080ULL;
    bits |= (((t >> 7) * 0x0102040810204080ULL) >> 56) << (8 * k);
  }
  return bits;
}

// n <= 64 bytes as bits (bit i set iff bytes[i] is nonzero), eight at a time.
inline uint64_t pack_bytes(const uint8_t* bytes, int n) {
  if (n == 64) return pack64(bytes);
  uint64_t bits = 0;
  int i = 0;
  for (; i + 8 <= n; i += 8) {
    uint64_t w;
    std::memcpy(&w, bytes + i, 8);
    const uint64_t t = (((w & 0x7F7F7F7F7F7F7F7FULL) + 0x7F7F7F7F7F7F7F7FULL) | w) & 0x8080808080808080ULL;
    bits |= (((t >> 7) * 0x0102040810204080ULL) >> 56) << i;
  }
  for (; i < n; ++i) bits |= static_cast<uint64_t>(bytes[i] != 0) << i;
  return bits;
}

// The sum of the indices of the set bits, exactly: bit k of an index is
// set in the positions the mask M_k holds, so it adds 2^k per set bit there.
inline int64_t bit_index_sum(uint64_t bits) {
  constexpr uint64_t kM[6] = {0xAAAAAAAAAAAAAAAAULL, 0xCCCCCCCCCCCCCCCCULL, 0xF0F0F0F0F0F0F0F0ULL,
                              0xFF00FF00FF00FF00ULL, 0xFFFF0000FFFF0000ULL, 0xFFFFFFFF00000000ULL};
  int64_t sum = 0;
  for (int k = 0; k < 6; ++k) sum += static_cast<int64_t>(std::popcount(bits & kM[k])) << k;
  return sum;
}

// Pixel (x, y) is bit x % 64 of word x / 64 of row y. The bits past the width
// in a row's last word are always zero.
class BitMask {
 public:
  BitMask() = default;
  BitMask(int width, int height) { create(width, height); }

  // Sets the size with every pixel clear; keeps the storage when it is large enough.
  void create(int width, int height);
  int width() const { return width_; }
  int height() const { return height_; }
  int words() const { return words_; }  // per row
  bool empty() const { return width_ == 0 || height_ == 0; }
  // Valid bits of a row's last word.
  uint64_t tail_mask() const { return width_ % 64 == 0 ? ~uint64_t{0} : (uint64_t{1} << (width_ % 64)) - 1; }

  uint64_t* row(int y) { return data_.data() + static_cast<std::size_t>(y) * static_cast<std::size_t>(words_); }
  const uint64_t* row(int y) const {
    return data_.data() + static_cast<std::size_t>(y) * static_cast<std::size_t>(words_);
  }
  bool get(int x, int y) const { return (row(y)[x >> 6] >> (x & 63)) & 1U; }
  void set(int x, int y, bool value) {
    const uint64_t bit = uint64_t{1} << (x & 63);
    uint64_t& w = row(y)[x >> 6];
    w = value ? (w | bit) : (w & ~bit);
  }

  // From a byte mask (nonzero = set) and back (255 set, 0 clear).
  void pack(const cv::Mat1b& mask);
  void unpack(cv::Mat1b& mask) const;
  int64_t count() const;

  bool operator==(const BitMask& o) const;

 private:
  int width_ = 0, height_ = 0, words_ = 0;
  std::vector<uint64_t> data_;
};

// A structuring element as runs of columns per row (offsets from the anchor).
// From a kernel as cv::getStructuringElement makes it (nonzero = in), with
// OpenCV's anchor convention ((-1, -1) = the centre).
class StructuringElement {
 public:
  StructuringElement() = default;
  explicit StructuringElement(const cv::Mat& kernel, cv::Point anchor = {-1, -1});
  // cv::getStructuringElement(cv::MORPH_ELLIPSE, 2 r + 1 square), as the detector uses.
  static StructuringElement disc(int radius);

  struct Row {
    int dy;
    std::vector<int> runs;  // indices into runs()
  };
  const std::vector<std::pair<int, int>>& runs() const { return runs_; }  // distinct [dx0, dx1], inclusive
  const std::vector<Row>& rows() const { return rows_; }                  // rows with at least one element
  // Per run, the dy of the rows holding it.
  const std::vector<std::vector<int>>& run_rows() const { return run_rows_; }
  bool empty() const { return rows_.empty(); }
  int reach() const { return reach_; }  // largest |dx|

 private:
  std::vector<std::pair<int, int>> runs_;
  std::vector<Row> rows_;
  std::vector<std::vector<int>> run_rows_;
  int reach_ = 0;
};

// Erosion, dilation, opening and closing of packed masks. Holds its scratch
// buffers, so one object per caller and no allocation per frame.
class BinaryMorphology {
 public:
  void erode(const BitMask& src, const StructuringElement& se, BitMask& dst);
  void dilate(const BitMask& src, const StructuringElement& se, BitMask& dst);
  // cv::morphologyEx MORPH_OPEN (erode, then dilate) and MORPH_CLOSE (dilate, then erode), in place.
  void open(BitMask& mask, const StructuringElement& se);
  void close(BitMask& mask, const StructuringElement& se);

 private:
  template <typename Op>
  void apply(const BitMask& src, const StructuringElement& se, BitMask& dst);
  std::vector<uint64_t> source_, horizontal_, result_;
  std::vector<const uint64_t*> runs_;  // per run of the element, its rows' result
  BitMask tmp_;
};

}  // namespace harvest::vision
