// Shi-Tomasi corners (eq. 2-2, 2-3) against OpenCV's cornerMinEigenVal and
// goodFeaturesToTrack on random textures.
#include <gtest/gtest.h>

#include <opencv2/imgproc.hpp>

#include "features/corners.hpp"
#include "synthetic.hpp"

namespace f = harvest::features;
namespace ft = harvest::features::testing;

namespace {
cv::Mat1b texture(uint64_t seed, cv::Size size = {320, 240}) {
  cv::Mat1b img = ft::sticker_texture(std::max(size.width, size.height), seed);
  return img(cv::Rect(cv::Point(0, 0), size)).clone();
}

// Fraction of points in `a` with a point of `b` within `tol` pixels.
double covered(const std::vector<cv::Point2f>& a, const std::vector<cv::Point2f>& b, double tol) {
  if (a.empty()) return 1.0;
  int hit = 0;
  for (const auto& p : a)
    for (const auto& q : b)
      if (cv::norm(p - q) <= tol) {
        ++hit;
        break;
      }
  return static_cast<double>(hit) / static_cast<double>(a.size());
}
}  // namespace

TEST(Corners, EigenvalueMapEqualsOpenCVUpToItsScale) {
  for (uint64_t seed : {1u, 2u, 3u}) {
    const cv::Mat1b img = texture(seed);
    const int W = 7;
    const cv::Mat1f ours = f::min_eigenvalue_map(img, W);
    cv::Mat1f cv_eig;
    cv::cornerMinEigenVal(img, cv_eig, W, 3);
    // OpenCV scales Sobel by 1 / (4 W 255); ours are Sobel / 8.
    const double s = 1.0 / (4.0 * W * 255.0);
    const double k = 64.0 * s * s;
    double max_rel = 0, max_cv = 0;
    const int lo = W / 2 + 1;
    for (int y = lo; y < img.rows - lo; ++y)
      for (int x = lo; x < img.cols - lo; ++x) max_cv = std::max<double>(max_cv, cv_eig(y, x));
    for (int y = lo; y < img.rows - lo; ++y)
      for (int x = lo; x < img.cols - lo; ++x)
        max_rel = std::max(max_rel, std::abs(ours(y, x) * k - cv_eig(y, x)) / max_cv);
    std::printf("seed %d: max |ours - OpenCV| / max eigenvalue = %.2e\n", static_cast<int>(seed), max_rel);
    EXPECT_LT(max_rel, 1e-4);
  }
}

TEST(Corners, SameCornersAsGoodFeaturesToTrack) {
  for (uint64_t seed : {4u, 5u, 6u}) {
    const cv::Mat1b img = texture(seed);
    f::CornerParams p;
    p.window = 7;
    p.min_eigenvalue = 0;
    p.quality_level = 0.05;
    p.min_distance = 8;
    p.max_corners = 150;
    p.border = 10;
    std::vector<cv::Point2f> ours;
    for (const auto& c : f::detect_corners(img, p)) ours.push_back(c.pt);
    cv::Mat1b mask(img.size(), uint8_t(0));
    mask(cv::Rect(p.border, p.border, img.cols - 2 * p.border, img.rows - 2 * p.border)).setTo(255);
    std::vector<cv::Point2f> theirs;
    cv::goodFeaturesToTrack(img, theirs, p.max_corners, p.quality_level, p.min_distance, mask, p.window, false);
    const double a = covered(theirs, ours, 0.5), b = covered(ours, theirs, 0.5);
    std::printf("seed %d: %zu ours, %zu OpenCV; OpenCV corners found by us %.1f %%, ours found by OpenCV %.1f %%\n",
                static_cast<int>(seed), ours.size(), theirs.size(), 100 * a, 100 * b);
    EXPECT_GT(ours.size(), 50u);
    EXPECT_NEAR(static_cast<double>(ours.size()), static_cast<double>(theirs.size()), 0.05 * theirs.size() + 1);
    EXPECT_GT(a, 0.95);
    EXPECT_GT(b, 0.95);
  }
}

TEST(Corners, ThresholdSpacingRegionAndMask) {
  const cv::Mat1b img = texture(7);
  f::CornerParams p;
  p.min_distance = 12;
  p.max_corners = 0;
  const auto all = f::detect_corners(img, p);
  ASSERT_GT(all.size(), 20u);
  for (std::size_t i = 1; i < all.size(); ++i) EXPECT_GE(all[i - 1].min_eigenvalue, all[i].min_eigenvalue);
  for (std::size_t i = 0; i < all.size(); ++i) {
    EXPECT_GT(all[i].min_eigenvalue, p.min_eigenvalue);
    for (std::size_t j = i + 1; j < all.size(); ++j) EXPECT_GE(cv::norm(all[i].pt - all[j].pt), 12.0);
  }
  // Region: only inside.
  const cv::Rect region(100, 60, 120, 100);
  const auto in = f::detect_corners(img, p, region);
  ASSERT_FALSE(in.empty());
  for (const auto& c : in) EXPECT_TRUE(region.contains(cv::Point(c.pt)));
  // Mask: the left half is forbidden.
  cv::Mat1b mask(img.size(), uint8_t(255));
  mask(cv::Rect(0, 0, img.cols / 2, img.rows)).setTo(0);
  for (const auto& c : f::detect_corners(img, p, {}, mask)) EXPECT_GE(c.pt.x, img.cols / 2);
  // Existing features keep new ones at a distance.
  const std::vector<cv::Point2f> existing{all[0].pt};
  for (const auto& c : f::detect_corners(img, p, {}, {}, existing)) EXPECT_GE(cv::norm(c.pt - all[0].pt), 12.0);
  // A raised threshold keeps fewer; a flat or one-directional image has none.
  p.min_eigenvalue = all[all.size() / 2].min_eigenvalue;
  EXPECT_LT(f::detect_corners(img, p).size(), all.size());
  EXPECT_TRUE(f::detect_corners(cv::Mat1b(240, 320, uint8_t(128)), p).empty());
  cv::Mat1b stripes(240, 320);
  for (int y = 0; y < 240; ++y)
    for (int x = 0; x < 320; ++x) stripes(y, x) = static_cast<uint8_t>(128 + 100 * std::sin(0.4 * x));
  p.min_eigenvalue = 1.0;
  EXPECT_TRUE(f::detect_corners(stripes, p).empty());  // one large, one zero eigenvalue
}
