// The packed-mask routines against the obvious OpenCV way on byte masks:
// cv::erode / cv::dilate / cv::morphologyEx with the default border, the
// byte threshold, and the labeller on the byte mask. Random and edge-case
// masks: empty, full, set border pixels, widths around multiples of 64.
#include "vision/bitmask.hpp"

#include <gtest/gtest.h>

#include <opencv2/imgproc.hpp>
#include <random>

#include "synthetic_scene.hpp"
#include "vision/segmentation.hpp"

namespace harvest::vision {
namespace {

const int kWidths[] = {1, 2, 5, 63, 64, 65, 127, 128, 129, 200, 320, 333};
const int kHeights[] = {1, 2, 3, 7, 40};

// Masks of one size: random with several densities, empty, full, only the
// border set, blobs, and nonzero values other than 255.
std::vector<cv::Mat1b> masks(int width, int height, std::mt19937& rng) {
  std::vector<cv::Mat1b> out;
  out.push_back(cv::Mat1b::zeros(height, width));
  out.push_back(cv::Mat1b(height, width, uchar{255}));
  cv::Mat1b border = cv::Mat1b::zeros(height, width);
  cv::rectangle(border, cv::Rect(0, 0, width, height), 255, 1);
  out.push_back(border);
  cv::Mat1b inner(height, width, uchar{255});
  cv::rectangle(inner, cv::Rect(0, 0, width, height), 0, 1);
  out.push_back(inner);
  for (const double density : {0.1, 0.5, 0.9, 0.97, 0.995}) {  // dense: erosion keeps some pixels
    cv::Mat1b m(height, width);
    std::bernoulli_distribution on(density);
    std::uniform_int_distribution<int> value(1, 255);
    for (int y = 0; y < height; ++y)
      for (int x = 0; x < width; ++x) m(y, x) = on(rng) ? static_cast<uchar>(value(rng)) : 0;
    out.push_back(m);
  }
  cv::Mat1b blobs = cv::Mat1b::zeros(height, width);
  std::uniform_int_distribution<int> ux(0, width - 1), uy(0, height - 1), ur(1, 12);
  for (int i = 0; i < 6; ++i) cv::circle(blobs, {ux(rng), uy(rng)}, ur(rng), 255, -1);
  for (int i = 0; i < 3; ++i) cv::circle(blobs, {ux(rng), uy(rng)}, ur(rng) / 2, 0, -1);
  out.push_back(blobs);
  return out;
}

cv::Mat1b unpacked(const BitMask& b) {
  cv::Mat1b m;
  b.unpack(m);
  return m;
}

bool same(const cv::Mat1b& a, const cv::Mat1b& b) { return a.size() == b.size() && cv::countNonZero(a != b) == 0; }

TEST(BitMask, PackUnpackAndCountMatchTheByteMask) {
  std::mt19937 rng(1);
  for (const int w : kWidths)
    for (const int h : kHeights)
      for (const cv::Mat1b& m : masks(w, h, rng)) {
        BitMask b;
        b.pack(m);
        ASSERT_EQ(b.width(), w);
        ASSERT_EQ(b.height(), h);
        EXPECT_TRUE(same(unpacked(b), (m != 0))) << w << "x" << h;
        EXPECT_EQ(b.count(), cv::countNonZero(m)) << w << "x" << h;
        for (int y = 0; y < h; ++y) EXPECT_EQ(b.row(y)[b.words() - 1] & ~b.tail_mask(), 0u) << "tail bits clear";
        const int x = w - 1, y = h - 1;
        EXPECT_EQ(b.get(x, y), m(y, x) != 0);
        b.set(x, y, !b.get(x, y));
        EXPECT_EQ(b.get(x, y), m(y, x) == 0);
      }
  // A view into a larger image (rows not contiguous) packs the same.
  cv::Mat1b big(50, 200);
  cv::randu(big, 0, 2);
  BitMask a, b;
  a.pack(big(cv::Rect(3, 4, 130, 20)));
  b.pack(big(cv::Rect(3, 4, 130, 20)).clone());
  EXPECT_TRUE(a == b);
  BitMask empty;
  empty.pack(cv::Mat1b());
  EXPECT_TRUE(empty.empty());
}

std::vector<std::pair<std::string, cv::Mat>> kernels() {
  std::vector<std::pair<std::string, cv::Mat>> k;
  for (const int r : {0, 1, 2, 3, 5, 8})
    k.emplace_back("disc " + std::to_string(r),
                   cv::getStructuringElement(cv::MORPH_ELLIPSE, cv::Size(2 * r + 1, 2 * r + 1)));
  k.emplace_back("rect 3x3", cv::getStructuringElement(cv::MORPH_RECT, cv::Size(3, 3)));
  k.emplace_back("cross 5x5", cv::getStructuringElement(cv::MORPH_CROSS, cv::Size(5, 5)));
  k.emplace_back("row 1x7", cv::Mat1b(1, 7, uchar{1}));
  k.emplace_back("column 4x1", cv::Mat1b(4, 1, uchar{1}));                             // even size: anchor off-centre
  cv::Mat1b holes = (cv::Mat1b(3, 5) << 1, 0, 1, 0, 1, 0, 0, 0, 0, 0, 1, 1, 0, 1, 1);  // gaps, an empty row
  k.emplace_back("gappy 3x5", holes);
  return k;
}

void expect_morphology_equals_opencv(const cv::Mat1b& m, const cv::Mat& kernel, cv::Point anchor,
                                     const std::string& what, BinaryMorphology& morph) {
  const StructuringElement se(kernel, anchor);
  BitMask src, dst;
  src.pack(m);
  const cv::Mat1b bin = (m != 0);
  cv::Mat ref;
  cv::erode(bin, ref, kernel, anchor);
  morph.erode(src, se, dst);
  ASSERT_TRUE(same(unpacked(dst), ref)) << "erode " << what;
  cv::dilate(bin, ref, kernel, anchor);
  morph.dilate(src, se, dst);
  ASSERT_TRUE(same(unpacked(dst), ref)) << "dilate " << what;
  cv::morphologyEx(bin, ref, cv::MORPH_OPEN, kernel, anchor);
  dst = src;
  morph.open(dst, se);
  ASSERT_TRUE(same(unpacked(dst), ref)) << "open " << what;
  cv::morphologyEx(bin, ref, cv::MORPH_CLOSE, kernel, anchor);
  dst = src;
  morph.close(dst, se);
  ASSERT_TRUE(same(unpacked(dst), ref)) << "close " << what;
}

TEST(BinaryMorphology, ErodeDilateOpenCloseEqualOpenCv) {
  std::mt19937 rng(2);
  BinaryMorphology morph;  // one object throughout: its scratch is reused across sizes
  for (const auto& [name, kernel] : kernels())
    for (const int w : kWidths)
      for (const int h : kHeights) {
        int i = 0;
        for (const cv::Mat1b& m : masks(w, h, rng))
          expect_morphology_equals_opencv(
              m, kernel, {-1, -1},
              name + " on " + std::to_string(w) + "x" + std::to_string(h) + " mask " + std::to_string(i++), morph);
      }
}

TEST(BinaryMorphology, AnchorsAndKernelsWiderThanAWord) {
  std::mt19937 rng(3);
  BinaryMorphology morph;
  const cv::Mat wide = cv::getStructuringElement(cv::MORPH_ELLIPSE, cv::Size(141, 9));  // reaches 70 px
  const cv::Mat rect = cv::getStructuringElement(cv::MORPH_RECT, cv::Size(4, 3));
  for (const int w : {65, 150, 333})
    for (const cv::Mat1b& m : masks(w, 30, rng)) {
      expect_morphology_equals_opencv(m, wide, {-1, -1}, "wide " + std::to_string(w), morph);
      expect_morphology_equals_opencv(m, wide, {3, 1}, "wide, anchor (3, 1) " + std::to_string(w), morph);
      expect_morphology_equals_opencv(m, rect, {0, 2}, "rect 4x3, anchor (0, 2) " + std::to_string(w), morph);
    }
}

TEST(BinaryMorphology, DiscIsOpenCvsEllipse) {
  for (const int r : {1, 2, 4}) {
    const StructuringElement a = StructuringElement::disc(r);
    const StructuringElement b(cv::getStructuringElement(cv::MORPH_ELLIPSE, cv::Size(2 * r + 1, 2 * r + 1)));
    EXPECT_EQ(a.runs(), b.runs());
    EXPECT_EQ(a.reach(), r);
  }
  // Radius 2: three full rows and single pixels above and below.
  const StructuringElement d = StructuringElement::disc(2);
  ASSERT_EQ(d.rows().size(), 5u);
  EXPECT_EQ(d.runs()[d.rows()[0].runs[0]], std::make_pair(0, 0));
  EXPECT_EQ(d.runs()[d.rows()[2].runs[0]], std::make_pair(-2, 2));
}

TEST(ColorThreshold, PackedMaskIsTheByteMaskPacked) {
  std::mt19937 rng(7);
  for (const int width : {640, 333, 129, 64, 63, 17, 15, 1}) {
    cv::Mat3b img(9, width);
    cv::randu(img, cv::Scalar::all(0), cv::Scalar::all(256));
    for (int k = 0; k < 30; ++k) {
      const ColorThresholds t = test::random_thresholds(rng, k, 29);
      const cv::Mat1b bytes = threshold_crcgcb(img, t);
      BitMask fast, portable;
      fast.create(3, 3);  // a mask of another size is resized
      threshold_crcgcb(img, t, fast);
      threshold_crcgcb_portable(img, t, portable);
      ASSERT_TRUE(same(unpacked(fast), bytes)) << "width " << width << " case " << k;
      ASSERT_TRUE(same(unpacked(portable), bytes)) << "width " << width << " case " << k;
      for (int y = 0; y < img.rows; ++y) ASSERT_EQ(fast.row(y)[fast.words() - 1] & ~fast.tail_mask(), 0u);
    }
  }
}

TEST(RegionLabeler, PackedMaskGivesTheRegionsAndRunsOfTheByteMask) {
  std::mt19937 rng(5);
  RegionLabeler a, b;
  for (const int w : kWidths)
    for (const int h : kHeights)
      for (const cv::Mat1b& m : masks(w, h, rng)) {
        BitMask bits;
        bits.pack(m);
        const auto ra = a.label(m, 1);
        const auto& rb = b.label(bits, 1);
        ASSERT_EQ(ra.size(), rb.size());
        for (std::size_t i = 0; i < ra.size(); ++i) {
          EXPECT_EQ(ra[i].area, rb[i].area);
          EXPECT_EQ(ra[i].sum_x, rb[i].sum_x);
          EXPECT_EQ(ra[i].sum_y, rb[i].sum_y);
          EXPECT_EQ(ra[i].x0, rb[i].x0);
          EXPECT_EQ(ra[i].x1, rb[i].x1);
          EXPECT_EQ(ra[i].y0, rb[i].y0);
          EXPECT_EQ(ra[i].y1, rb[i].y1);
          EXPECT_TRUE(same(a.region_mask(i, 1), b.region_mask(i, 1)));
        }
        ASSERT_EQ(a.runs().size(), b.runs().size());
        EXPECT_TRUE(same(cv::Mat1b(a.label_image(w, h) != 0), cv::Mat1b(b.label_image(w, h) != 0)));
      }
}

}  // namespace
}  // namespace harvest::vision
