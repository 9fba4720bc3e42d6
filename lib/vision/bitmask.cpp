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
struct And {
  static constexpr uint64_t kIdentity = ~uint64_t{0};
  static uint64_t op(uint64_t a, uint64_t b) { return a & b; }
};
struct Or {
  static constexpr uint64_t kIdentity = 0;
  static uint64_t op(uint64_t a, uint64_t b) { return a | b; }
};

// dst = Op(dst, src read d pixels to the right) over n words of rows laid
// out with guard words of Op's identity between them (at least |d| / 64 + 1
// before and after each row): bit x of a row meets bit x + d of the same
// row, or a guard's identity bit past its ends. One long loop over the
// array, so it vectorises; what it writes into the guards is not used.
template <typename Op>
void combine_shifted(const uint64_t* src, uint64_t* dst, std::ptrdiff_t begin, std::ptrdiff_t end, int d) {
  const int q = d >= 0 ? d / 64 : -((-d + 63) / 64), s = d - 64 * q;  // d = 64 q + s, 0 <= s < 64
  if (s == 0) {
    for (std::ptrdiff_t j = begin; j < end; ++j) dst[j] = Op::op(dst[j], src[j + q]);
  } else {
    for (std::ptrdiff_t j = begin; j < end; ++j)
      dst[j] = Op::op(dst[j], (src[j + q] >> s) | (src[j + q + 1] << (64 - s)));
  }
}

}  // namespace

// Two passes over the whole mask, each a few long loops: every distinct run
// of the element applied along the rows (the AND, for an erosion, or OR of
// the mask read at each of its offsets), then per element row the run's
// result read dy rows down, combined into the output. Pixels outside the
// image are the operation's identity, which is OpenCV's default border: the
// rows are copied with identity guard words between them (and a row's tail
// bits set, for an erosion), and element rows outside the image are left out.
template <typename Op>
void BinaryMorphology::apply(const BitMask& src, const StructuringElement& se, BitMask& dst) {
  assert(&src != &dst);
  const int width = src.width(), height = src.height(), nw = src.words();
  dst.create(width, height);
  if (src.empty() || se.empty()) return;
  constexpr uint64_t fill = Op::kIdentity;
  const int guard = se.reach() / 64 + 1;
  const std::ptrdiff_t stride = nw + guard;  // row y's words start at guard + y * stride
  const std::ptrdiff_t n = guard + height * stride;
  const auto at = [&](int y) { return guard + y * stride; };
  // The source with guards and identity tail bits.
  source_.assign(static_cast<std::size_t>(n), fill);
  const uint64_t tail_fill = fill & ~src.tail_mask();
  for (int y = 0; y < height; ++y) {
    std::copy(src.row(y), src.row(y) + nw, source_.data() + at(y));
    source_[static_cast<std::size_t>(at(y) + nw - 1)] |= tail_fill;
  }
  // Each run of the element along the rows (words of rows and guards between).
  const std::size_t nruns = se.runs().size();
  horizontal_.resize(nruns * static_cast<std::size_t>(n));
  runs_.assign(nruns, nullptr);
  const std::ptrdiff_t first = at(0), last = at(height - 1) + nw;
  for (std::size_t r = 0; r < nruns; ++r) {
    const auto [d0, d1] = se.runs()[r];
    if (d0 == 0 && d1 == 0) {  // the source itself
      runs_[r] = source_.data();
      continue;
    }
    uint64_t* h = horizontal_.data() + r * static_cast<std::size_t>(n);
    runs_[r] = h;
    std::fill(h, h + n, fill);
    for (int d = d0; d <= d1; ++d) combine_shifted<Op>(source_.data(), h, first, last, d);
  }
  // Each element row: its run's rows dy below, for output rows y with y + dy inside the image.
  result_.assign(static_cast<std::size_t>(n), fill);
  for (const StructuringElement::Row& row : se.rows()) {
    const int y0 = std::max(0, -row.dy), y1 = std::min(height, height - row.dy);
    if (y0 >= y1) continue;
    for (const int r : row.runs) {
      const uint64_t* h = runs_[static_cast<std::size_t>(r)] + static_cast<std::ptrdiff_t>(row.dy) * stride;
      uint64_t* out = result_.data();
      for (std::ptrdiff_t j = at(y0), end = at(y1 - 1) + nw; j < end; ++j) out[j] = Op::op(out[j], h[j]);
    }
  }
  for (int y = 0; y < height; ++y) {
    std::copy(result_.data() + at(y), result_.data() + at(y) + nw, dst.row(y));
    dst.row(y)[nw - 1] &= src.tail_mask();
  }
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
