// Pyramidal Lucas-Kanade (appendix B.2) against the truth and against OpenCV's
// calcOpticalFlowPyrLK on band-limited textures shifted by known sub-pixel
// amounts.
#include <gtest/gtest.h>

#include <opencv2/video/tracking.hpp>
#include <random>

#include "features/corners.hpp"
#include "features/lucas_kanade.hpp"
#include "synthetic.hpp"

namespace f = harvest::features;
namespace ft = harvest::features::testing;

namespace {

struct Stats {
  double mean = 0, max = 0;
  int lost = 0, n = 0;
};

struct Comparison {
  Stats ours, opencv;
};

// Points tracked from I(x) to I(x - d) must move by d.
Comparison compare(int window, double eps, double max_shift, uint64_t seed, int frames = 6) {
  const cv::Size size(320, 240);
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> shift(-max_shift, max_shift);
  Comparison c;
  double sum_ours = 0, sum_cv = 0;
  int n_ours = 0, n_cv = 0;
  for (int k = 0; k < frames; ++k) {
    const ft::WaveTexture tex(seed * 100 + static_cast<uint64_t>(k));
    const double dx = shift(rng), dy = shift(rng);
    const cv::Mat1b a = tex.render(size), b = tex.render(size, dx, dy);
    f::CornerParams cp;
    cp.quality_level = 0.05;
    cp.border = 30;
    cp.max_corners = 60;
    std::vector<cv::Point2f> pts;
    for (const auto& corner : f::detect_corners(a, cp)) pts.push_back(corner.pt);

    f::LkParams lp;
    lp.window = window;
    lp.levels = 3;
    lp.epsilon_px = eps;
    lp.max_iterations = 30;
    const auto res = f::track_lk(f::Pyramid(a, 3), f::Pyramid(b, 3), pts, lp);

    std::vector<cv::Point2f> cv_pts;
    std::vector<uint8_t> status;
    std::vector<float> err;
    cv::calcOpticalFlowPyrLK(a, b, pts, cv_pts, status, err, cv::Size(window, window), 2,
                             cv::TermCriteria(cv::TermCriteria::COUNT | cv::TermCriteria::EPS, 30, eps));
    for (std::size_t i = 0; i < pts.size(); ++i) {
      const cv::Point2f truth(pts[i].x + static_cast<float>(dx), pts[i].y + static_cast<float>(dy));
      if (res[i].found) {
        const double e = cv::norm(res[i].pt - truth);
        sum_ours += e;
        c.ours.max = std::max(c.ours.max, e);
        ++n_ours;
      } else {
        ++c.ours.lost;
      }
      if (status[i]) {
        const double e = cv::norm(cv_pts[i] - truth);
        sum_cv += e;
        c.opencv.max = std::max(c.opencv.max, e);
        ++n_cv;
      } else {
        ++c.opencv.lost;
      }
    }
  }
  c.ours.n = n_ours;
  c.opencv.n = n_cv;
  c.ours.mean = n_ours ? sum_ours / n_ours : 1e9;
  c.opencv.mean = n_cv ? sum_cv / n_cv : 1e9;
  return c;
}

void print(const char* what, const Comparison& c) {
  std::printf("%s: ours mean %.4f max %.4f px (%d tracked, %d lost); OpenCV mean %.4f max %.4f px (%d, %d lost)\n",
              what, c.ours.mean, c.ours.max, c.ours.n, c.ours.lost, c.opencv.mean, c.opencv.max, c.opencv.n,
              c.opencv.lost);
}

}  // namespace

TEST(LucasKanade, SubPixelShiftsAsAccurateAsOpenCV) {
  // 21 x 21 window, tight convergence: the accuracy limit of both.
  const auto c = compare(21, 0.01, 2.5, 1);
  print("window 21, eps 0.01, shifts <= 2.5 px", c);
  EXPECT_EQ(c.ours.lost, 0);
  EXPECT_LT(c.ours.mean, 0.05);
  EXPECT_LT(c.ours.max, 0.3);
  EXPECT_LT(c.ours.mean, 1.5 * c.opencv.mean + 0.01);
}

TEST(LucasKanade, ThesisSettingsSevenPixelWindowPointOnePixel) {
  // Thesis settings: 7 x 7 window, three levels, stop at 0.1 px.
  const auto c = compare(7, 0.1, 2.5, 2);
  print("window 7, eps 0.1, shifts <= 2.5 px", c);
  EXPECT_LT(c.ours.lost, c.ours.n / 20 + 1);
  EXPECT_LT(c.ours.mean, 0.1);
  EXPECT_LT(c.ours.mean, 1.5 * c.opencv.mean + 0.02);
}

TEST(LucasKanade, PyramidCarriesLargeShifts) {
  // 8 px is beyond a 7 x 7 (and a 15 x 15) window at level 0: only the
  // pyramid brings the guess close enough.
  const auto c = compare(15, 0.01, 8.0, 3);
  print("window 15, eps 0.01, shifts <= 8 px", c);
  EXPECT_LT(c.ours.lost, c.ours.n / 20 + 1);
  EXPECT_LT(c.ours.mean, 0.05);
  EXPECT_LT(c.ours.mean, 1.5 * c.opencv.mean + 0.01);
  // With a single level the same shifts fail for many points.
  const ft::WaveTexture tex(77);
  const cv::Mat1b a = tex.render({320, 240}), b = tex.render({320, 240}, 7.5, -6.5);
  f::CornerParams cp;
  cp.border = 30;
  cp.quality_level = 0.05;
  std::vector<cv::Point2f> pts;
  for (const auto& corner : f::detect_corners(a, cp)) pts.push_back(corner.pt);
  f::LkParams one;
  one.window = 7;
  one.levels = 1;
  one.epsilon_px = 0.01;
  int bad = 0;
  const auto res = f::track_lk(f::Pyramid(a, 1), f::Pyramid(b, 1), pts, one);
  for (std::size_t i = 0; i < pts.size(); ++i)
    if (!res[i].found || cv::norm(res[i].pt - (pts[i] + cv::Point2f(7.5f, -6.5f))) > 0.5) ++bad;
  one.levels = 3;
  const auto three = f::track_lk(f::Pyramid(a, 3), f::Pyramid(b, 3), pts, one);
  int bad3 = 0;
  for (std::size_t i = 0; i < pts.size(); ++i)
    if (!three[i].found || cv::norm(three[i].pt - (pts[i] + cv::Point2f(7.5f, -6.5f))) > 0.5) ++bad3;
  std::printf("shift (7.5, -6.5) px, 7x7 window: %d of %zu failed with one level, %d with three\n", bad, pts.size(),
              bad3);
  EXPECT_GT(bad, static_cast<int>(pts.size()) / 5);
  EXPECT_LT(bad3, static_cast<int>(pts.size()) / 20 + 1);
}

TEST(LucasKanade, FlatRegionIsReportedLost) {
  cv::Mat1b flat(120, 160, uint8_t(100));
  const auto r = f::track_lk(f::Pyramid(flat, 3), f::Pyramid(flat, 3), {cv::Point2f(80, 60)}, {});
  ASSERT_EQ(r.size(), 1u);
  EXPECT_FALSE(r[0].found);
  // Leaving the image is lost too.
  const ft::WaveTexture tex(5);
  const cv::Mat1b a = tex.render({160, 120});
  const auto edge = f::track_lk(f::Pyramid(a, 3), f::Pyramid(a, 3), {cv::Point2f(1, 1)}, {});
  EXPECT_FALSE(edge[0].found);
}

TEST(LucasKanade, PyramidDownMatchesOpenCV) {
  const ft::WaveTexture tex(9);
  const cv::Mat1b a = tex.render({321, 241});
  cv::Mat1f af;
  a.convertTo(af, CV_32F);
  const cv::Mat1f ours = f::pyramid_down(af);
  cv::Mat1f theirs;
  cv::pyrDown(af, theirs);
  ASSERT_EQ(ours.size(), theirs.size());
  double max_diff = 0;
  for (int y = 0; y < ours.rows; ++y)
    for (int x = 0; x < ours.cols; ++x) max_diff = std::max<double>(max_diff, std::abs(ours(y, x) - theirs(y, x)));
  EXPECT_LT(max_diff, 1e-3);
}
