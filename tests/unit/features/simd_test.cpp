// The AVX2 and the portable builds of the feature kernels (lib/features/simd.hpp)
// must give bit-identical results, so a log replays identically on any
// x86-64 machine; and the kernels' guards.
#include <gtest/gtest.h>

#include <cstring>

#include "features/corners.hpp"
#include "features/lucas_kanade.hpp"
#include "features/matcher.hpp"
#include "features/simd.hpp"
#include "synthetic.hpp"

namespace f = harvest::features;
namespace ft = harvest::features::testing;

namespace {
bool same_bits(const cv::Mat1f& a, const cv::Mat1f& b) {
  if (a.size() != b.size()) return false;
  for (int y = 0; y < a.rows; ++y)
    if (std::memcmp(a[y], b[y], sizeof(float) * static_cast<std::size_t>(a.cols)) != 0) return false;
  return true;
}
}  // namespace

TEST(SimdKernels, Avx2AndPortableBuildsAreBitIdentical) {
  if (!f::simd::have_avx2()) GTEST_SKIP() << "this CPU has no AVX2: only the portable build runs";
  const ft::WaveTexture tex(11);
  // Odd sizes: vector tails and the reflected pyramid edges are exercised.
  const cv::Mat1b a = tex.render({333, 251}), b = tex.render({333, 251}, 1.3, -0.7);
  for (int w : {3, 7, 21}) {
    EXPECT_TRUE(same_bits(f::min_eigenvalue_map(a, w, true), f::min_eigenvalue_map(a, w, false))) << "window " << w;
  }
  f::CornerParams cp;
  cp.quality_level = 0.01;
  cp.max_corners = 150;
  const auto c1 = f::detect_corners(a, cp);
  cp.allow_simd = false;
  const auto c0 = f::detect_corners(a, cp);
  ASSERT_EQ(c1.size(), c0.size());
  ASSERT_GT(c1.size(), 100u);
  for (std::size_t i = 0; i < c1.size(); ++i) {
    EXPECT_EQ(c1[i].pt, c0[i].pt);
    EXPECT_EQ(c1[i].min_eigenvalue, c0[i].min_eigenvalue);
  }
  const f::Pyramid pa1(a, 3, true), pa0(a, 3, false), pb1(b, 3, true), pb0(b, 3, false);
  for (int l = 0; l < 3; ++l) EXPECT_TRUE(same_bits(pb1.level(l), pb0.level(l))) << "level " << l;
  std::vector<cv::Point2f> pts;
  for (const auto& c : c1) pts.push_back(c.pt);
  for (int w : {7, 21}) {
    f::LkParams lp;
    lp.window = w;
    const auto r1 = f::track_lk(pa1, pb1, pts, lp);
    lp.allow_simd = false;
    const auto r0 = f::track_lk(pa0, pb0, pts, lp);
    int found = 0;
    for (std::size_t i = 0; i < pts.size(); ++i) {
      EXPECT_EQ(r1[i].found, r0[i].found);
      EXPECT_EQ(r1[i].pt, r0[i].pt) << "window " << w << " point " << i;
      EXPECT_EQ(r1[i].error, r0[i].error);
      EXPECT_EQ(r1[i].iterations, r0[i].iterations);
      found += r1[i].found;
    }
    EXPECT_GT(found, static_cast<int>(pts.size()) * 9 / 10);
  }
}

TEST(SimdKernels, ShiTomasiWindowBeyondExactIntegerSumsIsRefused) {
  const cv::Mat1b img = ft::WaveTexture(3).render({120, 100});
  EXPECT_NO_THROW(f::min_eigenvalue_map(img, 45));
  EXPECT_THROW(f::min_eigenvalue_map(img, 47), cv::Exception);
}

TEST(SimdKernels, WindowsAtTheLastValidPixelReadOnlyTheImage) {
  // A window touching the right and bottom image edges: the kernels read past
  // it into the padding with weight zero. With no motion every point must
  // stay exactly where it is (a stray read would move it).
  const ft::WaveTexture tex(21);
  const cv::Mat1b a = tex.render({97, 83});
  const f::Pyramid p(a, 1);
  f::LkParams lp;
  lp.levels = 1;
  lp.window = 7;
  const int h = lp.window / 2 + 1;
  const std::vector<cv::Point2f> pts{{static_cast<float>(a.cols - 1 - h), static_cast<float>(a.rows - 1 - h)},
                                     {static_cast<float>(h), static_cast<float>(h)},
                                     {static_cast<float>(a.cols - 1 - h), 40.5f},
                                     {50.25f, static_cast<float>(a.rows - 1 - h)}};
  for (bool s : {true, false}) {
    lp.allow_simd = s;
    const auto r = f::track_lk(p, p, pts, lp);
    for (std::size_t i = 0; i < pts.size(); ++i) {
      EXPECT_TRUE(r[i].found) << i;
      EXPECT_EQ(r[i].pt, pts[i]) << i;
      EXPECT_EQ(r[i].error, 0.f) << i;
    }
  }
}

// Descriptor matching: the AVX-512 VPOPCNTDQ / AVX2 build against the
// portable one, with near and exact duplicates (ties) among the descriptors.
TEST(SimdKernels, HammingMatchingIsTheSameInEveryBuild) {
  cv::RNG rng(5);
  for (int trial = 0; trial < 20; ++trial) {
    const int nd = rng.uniform(1, 1200), nc = rng.uniform(1, 700);
    cv::Mat1b d(nd, 32), c(nc, 32);
    rng.fill(d, cv::RNG::UNIFORM, 0, 256);
    rng.fill(c, cv::RNG::UNIFORM, 0, 256);
    for (int j = 0; j < nc; j += 3) {
      d.row(rng.uniform(0, nd)).copyTo(c.row(j));
      c(j, rng.uniform(0, 32)) ^= static_cast<uint8_t>(1 << rng.uniform(0, 8));
    }
    for (int j = 1; j < nc; j += 7) c.row(j - 1).copyTo(c.row(j));
    f::detail::Nearest fast, portable;
    f::detail::hamming_nearest(true, d.ptr<uint8_t>(), nd, c.ptr<uint8_t>(), nc, fast);
    f::detail::hamming_nearest(false, d.ptr<uint8_t>(), nd, c.ptr<uint8_t>(), nc, portable);
    EXPECT_EQ(fast.best, portable.best) << trial;
    EXPECT_EQ(fast.best_dist, portable.best_dist) << trial;
    EXPECT_EQ(fast.second_dist, portable.second_dist) << trial;
    EXPECT_EQ(fast.back, portable.back) << trial;
  }
}
