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
}

StructuringElement StructuringElement::disc(int radius) {
  return StructuringElement(cv::getStructuringElement(cv::MORPH_ELLIPSE, cv::Size(2 * radius + 1, 2 * radius + 1)));
}

// Two passes: each row's horizontal erosion (dilation) by every distinct run
// of the element, then per output row the AND (OR) of the rows the element
// covers. Pixels outside the image are the operation's identity, which is
// OpenCV's default border: a row outside is skipped, and a row is padded
// with identity words (and its tail bits set for an erosion).
void BinaryMorphology::apply(const BitMask& src, const StructuringElement& se, BitMask& dst, bool erode) {
  assert(&src != &dst);
  const int width = src.width(), height = src.height(), nw = src.words();
  dst.create(width, height);
  if (src.empty() || se.empty()) return;
  const uint64_t fill = erode ? ~uint64_t{0} : uint64_t{0};
  const uint64_t tail = src.tail_mask();
  const int pad = se.reach() / 64 + 1;
  const auto nruns = se.runs().size();
  padded_.resize(static_cast<std::size_t>(nw + 2 * pad));
  horizontal_.resize(nruns * static_cast<std::size_t>(height) * static_cast<std::size_t>(nw));
  const auto hrow = [&](std::size_t run, int y) {
    return horizontal_.data() + (run * static_cast<std::size_t>(height) + static_cast<std::size_t>(y)) * nw;
  };
  uint64_t* p = padded_.data();
  for (int y = 0; y < height; ++y) {
    std::fill(p, p + pad, fill);
    std::copy(src.row(y), src.row(y) + nw, p + pad);
    p[pad + nw - 1] |= fill & ~tail;
    std::fill(p + pad + nw, p + nw + 2 * pad, fill);
    for (std::size_t r = 0; r < nruns; ++r) {
      uint64_t* out = hrow(r, y);
      std::fill(out, out + nw, fill);
      const auto [d0, d1] = se.runs()[r];
      for (int d = d0; d <= d1; ++d) {
        // Word i of the row read d pixels to the right: bits from p[q + i] and p[q + i + 1].
        const int pos = pad * 64 + d;
        const int q = pos >> 6, s = pos & 63;
        if (s == 0) {
          for (int i = 0; i < nw; ++i) out[i] = erode ? (out[i] & p[q + i]) : (out[i] | p[q + i]);
        } else {
          for (int i = 0; i < nw; ++i) {
            const uint64_t v = (p[q + i] >> s) | (p[q + i + 1] << (64 - s));
            out[i] = erode ? (out[i] & v) : (out[i] | v);
          }
        }
      }
    }
  }
  for (int y = 0; y < height; ++y) {
    uint64_t* out = dst.row(y);
    std::fill(out, out + nw, fill);
    for (const StructuringElement::Row& row : se.rows()) {
      const int sy = y + row.dy;
      if (sy < 0 || sy >= height) continue;
      for (const int r : row.runs) {
        const uint64_t* h = hrow(static_cast<std::size_t>(r), sy);
        for (int i = 0; i < nw; ++i) out[i] = erode ? (out[i] & h[i]) : (out[i] | h[i]);
      }
    }
    out[nw - 1] &= tail;
  }
}

void BinaryMorphology::open(BitMask& mask, const StructuringElement& se) {
  apply(mask, se, tmp_, true);
  apply(tmp_, se, mask, false);
}

void BinaryMorphology::close(BitMask& mask, const StructuringElement& se) {
  apply(mask, se, tmp_, false);
  apply(tmp_, se, mask, true);
}

}  // namespace harvest::vision
