// The detector's fast geometry against the obvious way: the convex hull's
// area against cv::convexHull + cv::contourArea, fit_circle against its
// former Eigen form (outer products per point), mask moments against
// cv::moments; all exactly (the replayed detections must not change a bit).
#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <cmath>
#include <opencv2/imgproc.hpp>
#include <random>

#include "vision/circle_fit.hpp"
#include "vision/outline_circle.hpp"
#include "vision/region_split.hpp"

namespace harvest::vision {
namespace {

double opencv_hull_area(const std::vector<cv::Point>& points) {
  if (points.empty()) return 0.0;
  std::vector<cv::Point> hull;
  cv::convexHull(points, hull);
  return cv::contourArea(hull);
}

TEST(ConvexHullArea, EqualsOpenCvsHullAreaExactly) {
  std::mt19937 rng(11);
  // Degenerate sets: none, one, two, duplicates, collinear (a row, a column, a diagonal).
  EXPECT_EQ(convex_hull_area({}), 0.0);
  EXPECT_EQ(convex_hull_area({{3, 4}}), 0.0);
  EXPECT_EQ(convex_hull_area({{3, 4}, {7, 1}}), 0.0);
  EXPECT_EQ(convex_hull_area({{3, 4}, {3, 4}, {3, 4}}), 0.0);
  EXPECT_EQ(convex_hull_area({{1, 5}, {9, 5}, {4, 5}}), 0.0);
  EXPECT_EQ(convex_hull_area({{2, 1}, {2, 9}, {2, 4}}), 0.0);
  EXPECT_EQ(convex_hull_area({{0, 0}, {5, 5}, {2, 2}, {9, 9}}), 0.0);
  EXPECT_EQ(convex_hull_area({{0, 0}, {4, 0}, {4, 3}, {0, 3}, {2, 0}, {2, 3}}), 12.0);
  // Random point sets, small and large ranges, negative coordinates.
  for (int k = 0; k < 300; ++k) {
    const int range = k % 3 == 0 ? 4 : (k % 3 == 1 ? 60 : 2000);
    std::uniform_int_distribution<int> coord(-range / 2, range);
    std::vector<cv::Point> pts(static_cast<std::size_t>(3 + k % 50));
    for (auto& p : pts) p = {coord(rng), coord(rng)};
    ASSERT_EQ(convex_hull_area(pts), opencv_hull_area(pts)) << "set " << k;
  }
  // Outlines of random blobs, as the detector has them.
  for (int k = 0; k < 100; ++k) {
    cv::Mat1b m = cv::Mat1b::zeros(80, 97);
    std::uniform_int_distribution<int> ux(0, 96), uy(0, 79), ur(1, 25);
    for (int i = 0; i < 4; ++i) cv::circle(m, {ux(rng), uy(rng)}, ur(rng), 255, -1);
    for (int i = 0; i < 3; ++i) cv::ellipse(m, {ux(rng), uy(rng)}, {ur(rng), 2}, 30.0 * i, 0, 360, 0, -1);
    std::vector<std::vector<cv::Point>> contours;
    cv::findContours(m, contours, cv::RETR_EXTERNAL, cv::CHAIN_APPROX_NONE);
    for (const auto& c : contours) ASSERT_EQ(convex_hull_area(c), opencv_hull_area(c)) << "blob " << k;
  }
}

TEST(FillHoles, SamePixelsAsFloodingTheOutside) {
  std::mt19937 rng(19);
  const auto flood = [](cv::Mat1b crop) {
    cv::Mat1b outside = crop.clone();
    cv::floodFill(outside, cv::Point(0, 0), cv::Scalar(255));
    crop |= ~outside;
    return crop;
  };
  for (int k = 0; k < 300; ++k) {
    std::uniform_int_distribution<int> side(1, k < 250 ? 90 : 200);
    const int w = side(rng), h = side(rng);
    cv::Mat1b m = cv::Mat1b::zeros(h, w);
    std::uniform_int_distribution<int> ux(0, w - 1), uy(0, h - 1), ur(1, std::max(1, std::min(w, h) / 2));
    for (int i = 0; i < 4; ++i) cv::circle(m, {ux(rng), uy(rng)}, ur(rng), 255, -1);
    for (int i = 0; i < 4; ++i) cv::circle(m, {ux(rng), uy(rng)}, ur(rng) / 2, 0, -1);  // holes, some open
    if (k % 3 == 0) {  // speckle: holes of one pixel, diagonal gaps (4- vs 8-connected)
      std::bernoulli_distribution on(0.6);
      for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) m(y, x) = on(rng) ? 255 : 0;
    }
    if (k % 2 == 0) cv::rectangle(m, cv::Rect(0, 0, w, h), 0, 1);  // the splitter's empty frame
    if (k % 5 == 0) m(0, 0) = 255;                                 // and without: the flooding fallback
    cv::Mat1b ours = m.clone();
    fill_holes(ours);
    ASSERT_EQ(cv::countNonZero(ours != flood(m)), 0) << "mask " << k << " (" << w << "x" << h << ")";
  }
  cv::Mat1b ring = cv::Mat1b::zeros(9, 70);  // a ring across the 64-pixel word boundary
  cv::rectangle(ring, cv::Rect(55, 2, 12, 5), 255, 1);
  cv::Mat1b filled = ring.clone();
  fill_holes(filled);
  EXPECT_EQ(cv::countNonZero(filled), cv::countNonZero(ring) + 10 * 3);
  cv::Mat1b none;
  fill_holes(none);
  EXPECT_TRUE(none.empty());
}

// fit_circle as it was: Eigen outer products per point.
std::optional<Circle> fit_circle_eigen(const std::vector<cv::Point2d>& points, int iterations = 10) {
  const auto n = static_cast<Eigen::Index>(points.size());
  if (n < 3) return std::nullopt;
  // Centre the data for conditioning.
  cv::Point2d mean(0, 0);
  for (const auto& p : points) mean += p;
  mean *= 1.0 / static_cast<double>(n);

  // Kasa: x^2 + y^2 + a x + b y + c = 0, linear least squares through the
  // 3x3 normal equations (the data are centred, so they are well
  // conditioned; no per-call allocation, the detector fits many circles).
  Eigen::Matrix3d ata = Eigen::Matrix3d::Zero();
  Eigen::Vector3d atb = Eigen::Vector3d::Zero();
  for (Eigen::Index i = 0; i < n; ++i) {
    const double x = points[i].x - mean.x, y = points[i].y - mean.y;
    const Eigen::Vector3d row(x, y, 1.0);
    ata += row * row.transpose();
    atb -= row * (x * x + y * y);
  }
  const Eigen::FullPivLU<Eigen::Matrix3d> lu(ata);
  if (lu.rank() < 3) return std::nullopt;
  const Eigen::Vector3d s = lu.solve(atb);
  double cx = -s(0) / 2, cy = -s(1) / 2;
  const double r2 = cx * cx + cy * cy - s(2);
  if (!(r2 > 0)) return std::nullopt;
  double r = std::sqrt(r2);

  // Gauss-Newton on residuals d_i = |p_i - c| - r.
  for (int it = 0; it < iterations; ++it) {
    Eigen::Matrix3d jtj = Eigen::Matrix3d::Zero();
    Eigen::Vector3d jtr = Eigen::Vector3d::Zero();
    for (const auto& p : points) {
      const double dx = p.x - mean.x - cx, dy = p.y - mean.y - cy;
      const double dist = std::sqrt(dx * dx + dy * dy);
      if (dist < 1e-12) continue;
      const Eigen::Vector3d j(-dx / dist, -dy / dist, -1.0);
      const double res = dist - r;
      jtj += j * j.transpose();
      jtr += j * res;
    }
    const Eigen::Vector3d step = jtj.ldlt().solve(-jtr);
    if (!step.allFinite()) break;
    cx += step(0);
    cy += step(1);
    r += step(2);
    if (step.norm() < 1e-6) break;  // pixels: far below what matters
  }
  if (!(r > 0) || !std::isfinite(r)) return std::nullopt;
  double ss = 0;
  for (const auto& p : points) {
    const double ex = p.x - mean.x - cx, ey = p.y - mean.y - cy;
    const double res = std::sqrt(ex * ex + ey * ey) - r;
    ss += res * res;
  }
  return Circle{cx + mean.x, cy + mean.y, r, std::sqrt(ss / static_cast<double>(n))};
}

void expect_same_fit(const std::vector<cv::Point2d>& pts, const std::string& what) {
  const auto a = fit_circle(pts), b = fit_circle_eigen(pts);
  ASSERT_EQ(a.has_value(), b.has_value()) << what;
  if (!a) return;
  EXPECT_EQ(a->cx, b->cx) << what;
  EXPECT_EQ(a->cy, b->cy) << what;
  EXPECT_EQ(a->r, b->r) << what;
  EXPECT_EQ(a->rms, b->rms) << what;
}

TEST(FitCircle, SameBitsAsTheEigenForm) {
  std::mt19937 rng(13);
  std::normal_distribution<double> noise(0, 0.7);
  std::uniform_real_distribution<double> u(0, 1);
  for (int k = 0; k < 400; ++k) {
    const double cx = 300 * u(rng), cy = 200 * u(rng), r = 2 + 60 * u(rng);
    const double from = 2 * M_PI * u(rng), span = 2 * M_PI * (0.1 + 0.9 * u(rng));
    std::vector<cv::Point2d> pts(static_cast<std::size_t>(3 + k % 200));
    for (auto& p : pts) {
      const double a = from + span * u(rng);
      p = {cx + r * std::cos(a) + noise(rng), cy + r * std::sin(a) + noise(rng)};
      if (k % 4 == 0) p = {std::round(p.x), std::round(p.y)};  // pixel outlines
    }
    expect_same_fit(pts, "arc " + std::to_string(k));
  }
  expect_same_fit({{0, 0}, {1, 1}, {2, 2}, {3, 3}}, "collinear");
  expect_same_fit({{5, 5}, {5, 5}, {5, 5}}, "one point");
  expect_same_fit({{0, 0}, {1, 0}}, "two points");
}

}  // namespace
}  // namespace harvest::vision
