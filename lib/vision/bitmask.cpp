#include "vision/bitmask.hpp"

#include <algorithm>
#include <bit>
#include <cassert>
#include <cstring>
#include <opencv2/imgproc.hpp>
#include <stdexcept>

namespace harvest::vision {

void BitMask::create(int width, int height) {
  if (width < 0 || height < 0) throw std::invalid_argument("BitMask: negative size");
  width_ = width;
  height_ = height;
  words_ = (width + 63) / 64;
  data_.assign(static_cast<std::size_t>(words_) * static_cast<std::size_t>(height), 0);
}

void BitMask::pack(const cv::Mat1b& mask) {
  create(mask.cols, mask.rows);
  for (int y = 0; y < height_; ++y) {
    const uint8_t* in = mask.ptr<uint8_t>(y);
    uint64_t* out = row(y);
    int x = 0;
    for (; x + 64 <= width_; x += 64) out[x >> 6] = pack64(in + x);
    if (x < width_) {
      uint64_t bits = 0;
      for (int i = 0; x + i < width_; ++i) bits |= static_cast<uint64_t>(in[x + i] != 0) << i;
      out[x >> 6] = bits;
    }
  }
}

void BitMask::unpack(cv::Mat1b& mask) const {
  mask.create(height_, width_);
  for (int y = 0; y < height_; ++y) {
    const uint64_t* in = row(y);
    uint8_t* out = mask.ptr<uint8_t>(y);
    for (int x = 0; x < width_; ++x) out[x] = ((in[x >> 6] >> (x & 63)) & 1U) ? 255 : 0;
  }
}

int64_t BitMask::count() const {
  int64_t n = 0;
  for (const uint64_t w : data_) n += std::popcount(w);
  return n;
}

bool BitMask::operator==(const BitMask& o) const {
  return width_ == o.width_ && height_ == o.height_ && data_ == o.data_;
}

StructuringElement::StructuringElement(const cv::Mat& kernel, cv::Point anchor) {
  if (kernel.type() != CV_8UC1) throw std::invalid_argument("StructuringElement: kernel must be CV_8UC1");
  if (anchor.x < 0) anchor.x = kernel.cols / 2;  // OpenCV's normalizeAnchor
  if (anchor.y < 0) anchor.y = kernel.rows / 2;
  for (int i = 0; i < kernel.rows; ++i) {
    const uint8_t* k = kernel.ptr<uint8_t>(i);
    Row row{i - anchor.y, {}};
    for (int j = 0; j < kernel.cols;) {
      if (!k[j]) {
        ++j;
        continue;
      }
      const int j0 = j;
      while (j < kernel.cols && k[j]) ++j;
      const std::pair<int, int> run{j0 - anchor.x, j - 1 - anchor.x};
      auto it = std::find(runs_.begin(), runs_.end(), run);
      if (it == runs_.end()) it = runs_.insert(runs_.end(), run);
      row.runs.push_back(static_cast<int>(it - runs_.begin()));
      reach_ = std::max({reach_, std::abs(run.first), std::abs(run.second)});
    }
    if (!row.runs.empty()) rows_.push_back(std::move(row));
  }
  run_rows_.resize(runs_.size());
  for (const Row& row : rows_)
    for (const int r : row.runs) run_rows_[static_cast<std::size_t>(r)].push_back(row.dy);
}

StructuringElement StructuringElement::disc(int radius) {
  return StructuringElement(cv::getStructuringElement(cv::MORPH_ELLIPSE, cv::Size(2 * radius + 1, 2 * radius + 1)));
}

namespace {
// dst = src read d pixels to the right (bit x of a row = bit x + d of the
// same row; outside the row: `fill`), for every row of a mask stored as
// `rows` rows of `nw` words. One pass over the whole array, so the loop is
// long and vectorises, then the words whose sources leave their row again.
void shift_rows(const uint64_t* src, uint64_t* dst, int rows, int nw, int d, uint64_t fill) {
  const int q = d >= 0 ? d / 64 : -((-d + 63) / 64), s = d - 64 * q;  // d = 64 q + s, 0 <= s < 64
  const auto n = static_cast<std::ptrdiff_t>(rows) * nw;
  const auto get = [&](const uint64_t* row, int i) { return i >= 0 && i < nw ? row[i] : fill; };
  // Word j takes src[j + q] (and src[j + q + 1] when s > 0): in the array for lo <= j < hi.
  const std::ptrdiff_t lo = std::max<std::ptrdiff_t>(0, -q), hi = std::min<std::ptrdiff_t>(n, n - q - (s != 0));
  if (s == 0) {
    for (std::ptrdiff_t j = lo; j < hi; ++j) dst[j] = src[j + q];
  } else {
    for (std::ptrdiff_t j = lo; j < hi; ++j) dst[j] = (src[j + q] >> s) | (src[j + q + 1] << (64 - s));
  }
  // Each row's words with a source outside the row (the carries of the bulk
  // pass came from the neighbouring row, or were not computed).
  // Those are the words i < -q and i >= nw - q - (s > 0) (at most one per
  // row for a shift under 64 pixels).
  const int first_ok = std::clamp(-q, 0, nw), last_ok = std::clamp(nw - q - (s != 0), first_ok, nw);
  for (int y = 0; y < rows; ++y) {
    const uint64_t* in = src + static_cast<std::ptrdiff_t>(y) * nw;
    uint64_t* out = dst + static_cast<std::ptrdiff_t>(y) * nw;
    const auto fix = [&](int i) {
      out[i] = s == 0 ? get(in, i + q) : (get(in, i + q) >> s) | (get(in, i + q + 1) << (64 - s));
    };
    for (int i = 0; i < first_ok; ++i) fix(i);
    for (int i = last_ok; i < nw; ++i) fix(i);
  }
}

struct And {
  static constexpr uint64_t kIdentity = ~uint64_t{0};
  static uint64_t op(uint64_t a, uint64_t b) { return a & b; }
};
struct Or {
  static constexpr uint64_t kIdentity = 0;
  static uint64_t op(uint64_t a, uint64_t b) { return a | b; }
};

template <typename Op>
void combine(uint64_t* out, const uint64_t* in, std::ptrdiff_t n) {
  for (std::ptrdiff_t j = 0; j < n; ++j) out[j] = Op::op(out[j], in[j]);
}
}  // namespace

// Two passes over the whole mask, each a few long loops: every distinct run
// of the element applied along the rows (the AND, for an erosion, or OR of
// the mask read at each of its offsets), then per element row the run's
// result read dy rows down, combined into the output. Pixels outside the
// image are the operation's identity, which is OpenCV's default border:
// the rows read are padded with identity bits (a row's tail bits set for an
// erosion), and element rows outside the image are left out.
template <typename Op>
void BinaryMorphology::apply(const BitMask& src, const StructuringElement& se, BitMask& dst) {
  assert(&src != &dst);
  const int width = src.width(), height = src.height(), nw = src.words();
  dst.create(width, height);
  if (src.empty() || se.empty()) return;
  constexpr uint64_t fill = Op::kIdentity;
  const auto n = static_cast<std::ptrdiff_t>(height) * nw;
  // The source with identity tail bits.
  source_.assign(src.row(0), src.row(0) + n);
  if (const uint64_t tail_fill = fill & ~src.tail_mask(); tail_fill != 0)
    for (int y = 0; y < height; ++y) source_[static_cast<std::size_t>(y) * nw + nw - 1] |= tail_fill;
  const std::size_t nruns = se.runs().size();
  horizontal_.resize(nruns * static_cast<std::size_t>(n));
  shifted_.resize(static_cast<std::size_t>(n));
  for (std::size_t r = 0; r < nruns; ++r) {
    uint64_t* h = horizontal_.data() + r * static_cast<std::size_t>(n);
    const auto [d0, d1] = se.runs()[r];
    std::fill(h, h + n, fill);
    for (int d = d0; d <= d1; ++d) {
      if (d == 0) {
        combine<Op>(h, source_.data(), n);
      } else {
        shift_rows(source_.data(), shifted_.data(), height, nw, d, fill);
        combine<Op>(h, shifted_.data(), n);
      }
    }
  }
  uint64_t* out = dst.row(0);
  std::fill(out, out + n, fill);
  for (const StructuringElement::Row& row : se.rows()) {
    // Output rows y with y + dy inside the image.
    const int y0 = std::max(0, -row.dy), y1 = std::min(height, height - row.dy);
    if (y0 >= y1) continue;
    for (const int r : row.runs) {
      const uint64_t* h = horizontal_.data() + static_cast<std::size_t>(r) * static_cast<std::size_t>(n);
      combine<Op>(out + static_cast<std::ptrdiff_t>(y0) * nw, h + static_cast<std::ptrdiff_t>(y0 + row.dy) * nw,
                  static_cast<std::ptrdiff_t>(y1 - y0) * nw);
    }
  }
  for (int y = 0; y < height; ++y) dst.row(y)[nw - 1] &= src.tail_mask();
}

void BinaryMorphology::erode(const BitMask& src, const StructuringElement& se, BitMask& dst) {
  apply<And>(src, se, dst);
}

void BinaryMorphology::dilate(const BitMask& src, const StructuringElement& se, BitMask& dst) {
  apply<Or>(src, se, dst);
}

void BinaryMorphology::open(BitMask& mask, const StructuringElement& se) {
  erode(mask, se, tmp_);
  dilate(tmp_, se, mask);
}

void BinaryMorphology::close(BitMask& mask, const StructuringElement& se) {
  dilate(mask, se, tmp_);
  erode(tmp_, se, mask);
}

}  // namespace harvest::vision
