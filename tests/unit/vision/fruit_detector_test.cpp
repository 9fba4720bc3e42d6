#include "vision/fruit_detector.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <opencv2/imgproc.hpp>
#include <random>

#include "config/config.hpp"
#include "opencv_reference.hpp"
#include "synthetic_scene.hpp"
#include "vision/depth.hpp"
#include "vision/region_split.hpp"
#include "vision/segmentation.hpp"

namespace harvest::vision {
namespace {

using test::draw_disc;
using test::kLeaf;
using test::kOrange;

// ---- depth from size: thesis table 6-2 ----

TEST(DepthFromSize, ReproducesThesisTable6_2) {
  // Image sizes (x, y) [px] and the thesis's estimated depths along x, y and mean [mm].
  struct Row {
    double sx, sy, zx, zy, mean;
  };
  const Row rows[] = {
      {334, 321, 187.15, 184.73, 185.94},  {218, 205, 286.73, 289.26, 288.00}, {161, 152, 388.25, 390.12, 389.18},
      {128, 119, 488.35, 498.30, 493.32},  {104, 98, 601.04, 605.08, 603.06},  {88, 83, 710.33, 714.44, 712.38},
      {78, 72, 801.39, 823.59, 812.49},    {69, 64, 905.92, 926.53, 916.23},   {63, 59, 992.20, 1005.05, 998.63},
      {56, 53, 1116.23, 1118.84, 1117.53}, {52, 50, 1202.09, 1185.97, 1194.03}};
  // The table's last digit is truncated and its fx*Dx product was 62508.5
  // rather than 833.57 * 74.99 = 62509.4, hence 0.015 mm (1.5e-5 relative).
  for (const Row& r : rows) {
    const DepthEstimate d = depth_from_size(833.57, 767.02, 74.99, 77.31, r.sx, r.sy);
    EXPECT_NEAR(d.along_x, r.zx, 0.015) << r.sx;
    EXPECT_NEAR(d.along_y, r.zy, 0.015) << r.sy;
    EXPECT_NEAR(d.mean, r.mean, 0.015) << r.sx;
  }
  // eq. 6-11 is the mean of eq. 6-10 for one diameter.
  EXPECT_DOUBLE_EQ(depth_from_diameter(833.57, 767.02, 75.0, 100.0), 0.5 * (833.57 + 767.02) * 0.75);
}

// ---- colour threshold and labelling ----

bool thesis_inside(uint8_t b, uint8_t g, uint8_t r, const ColorThresholds& t, bool* near_bound) {
  const CrCgCb c = crcgcb(b, g, r);
  const double v[3] = {c.cr, c.cg, c.cb}, lo[3] = {t.cr_min, t.cg_min, t.cb_min},
               hi[3] = {t.cr_max, t.cg_max, t.cb_max};
  *near_bound = false;
  bool in = true;
  for (int i = 0; i < 3; ++i) {
    if (std::abs(v[i] - lo[i]) < 1e-6 || std::abs(v[i] - hi[i]) < 1e-6) *near_bound = true;
    in = in && v[i] >= lo[i] && v[i] <= hi[i];
  }
  return in;
}

TEST(ColorThreshold, MatchesThesisFormulaOnRandomColours) {
  std::mt19937 rng(42);
  cv::Mat3b img(480, 640);
  cv::randu(img, cv::Scalar::all(0), cv::Scalar::all(256));
  const ColorThresholds t;
  const cv::Mat1b mask = threshold_crcgcb(img, t);
  int inside = 0, ties = 0;
  for (int y = 0; y < img.rows; ++y)
    for (int x = 0; x < img.cols; ++x) {
      const cv::Vec3b p = img(y, x);
      bool tie = false;
      const bool expected = thesis_inside(p[0], p[1], p[2], t, &tie);
      if (tie) {  // exactly on a bound: inclusive, as the thesis's (c < lo || c > hi) rejection
        ++ties;
        continue;
      }
      inside += expected;
      ASSERT_EQ(mask(y, x) != 0, expected) << "BGR " << p;
    }
  EXPECT_GT(inside, 1000);  // the test exercises both outcomes
  (void)ties;
}

TEST(ColorThreshold, BoundsAreInclusive) {
  // R=100, G=100, B=100: Cr = 2 exactly... use a colour with Cr exactly 22:
  // 0.721*R - 0.587*G - 0.114*B with R=G=B=v gives 0.02 v, so v=... instead
  // set the bound to the pixel's exact value.
  const CrCgCb c = crcgcb(30, 140, 230);  // Cr 80.234? computed exactly below
  ColorThresholds t;
  const int32_t cr_milli = 721 * 230 - 587 * 140 - 114 * 30;
  t.cr_min = cr_milli / 1000.0;
  t.cr_max = cr_milli / 1000.0;
  cv::Mat3b px(1, 1, cv::Vec3b(30, 140, 230));
  EXPECT_EQ(threshold_crcgcb(px, t)(0, 0), 255) << c.cr;
  t.cr_min += 0.001;
  EXPECT_EQ(threshold_crcgcb(px, t)(0, 0), 0);
  t.cr_min = 80;
  t.cr_max = 70;  // empty range
  EXPECT_EQ(threshold_crcgcb(px, t)(0, 0), 0);
}

TEST(ColorThreshold, SimdKernelEqualsPortableKernel) {
  // Odd widths exercise the scalar tail after the 16-pixel blocks; random
  // thresholds (including empty and extreme ranges) exercise the bounds.
  std::mt19937 rng(7);
  for (const int width : {640, 333, 17, 15, 1}) {
    cv::Mat3b img(37, width);
    cv::randu(img, cv::Scalar::all(0), cv::Scalar::all(256));
    for (int k = 0; k < 40; ++k) {
      const ColorThresholds t = test::random_thresholds(rng, k, 39);
      const cv::Mat1b fast = threshold_crcgcb(img, t);
      cv::Mat1b portable(img.size());
      threshold_crcgcb_portable(img.data, img.cols, img.rows, img.step, t, portable.data, portable.step);
      ASSERT_EQ(cv::countNonZero(fast != portable), 0) << "width " << width << " case " << k;
      if (k == 39) {
        EXPECT_EQ(cv::countNonZero(fast), img.rows * img.cols);
      }
    }
  }
}

TEST(RegionLabeler, AgreesWithOpenCvConnectedComponents) {
  cv::Mat1b mask(240, 320);
  cv::randu(mask, 0, 2);
  cv::Mat1b big;
  cv::resize(mask, big, {}, 1, 1, cv::INTER_NEAREST);
  mask = (mask > 0) * 255;
  // Add a few larger blobs so regions of many shapes occur.
  cv::circle(mask, {100, 100}, 40, 255, -1);
  cv::circle(mask, {200, 150}, 25, 0, -1);
  RegionLabeler labeler;
  const auto& regions = labeler.label(mask, 0);
  cv::Mat labels, stats, centroids;
  const int n = cv::connectedComponentsWithStats(mask, labels, stats, centroids, 4, CV_32S);
  ASSERT_EQ(static_cast<int>(regions.size()), n - 1);
  // Same partition: ours and OpenCV's label images map one-to-one.
  const cv::Mat1i ours = labeler.label_image(mask.cols, mask.rows);
  std::vector<int> map(static_cast<std::size_t>(n), -1);
  for (int y = 0; y < mask.rows; ++y)
    for (int x = 0; x < mask.cols; ++x) {
      const int cv_label = labels.at<int>(y, x);
      int& m = map[static_cast<std::size_t>(cv_label)];
      if (m < 0) m = ours(y, x);
      ASSERT_EQ(m, ours(y, x)) << x << "," << y;
    }
  for (int l = 1; l < n; ++l) {
    // In the same order too (raster order of the first pixel): the splitter's
    // peel relies on it, where it replaced cv::connectedComponentsWithStats.
    EXPECT_EQ(map[static_cast<std::size_t>(l)], l);
    const Region& r = regions[static_cast<std::size_t>(map[static_cast<std::size_t>(l)] - 1)];
    EXPECT_EQ(r.area, stats.at<int>(l, cv::CC_STAT_AREA));
    EXPECT_EQ(r.x0, stats.at<int>(l, cv::CC_STAT_LEFT));
    EXPECT_EQ(r.x1 - r.x0, stats.at<int>(l, cv::CC_STAT_WIDTH));
    EXPECT_NEAR(r.cx(), centroids.at<double>(l, 0), 1e-9);
    EXPECT_NEAR(r.cy(), centroids.at<double>(l, 1), 1e-9);
  }
}

TEST(MaskMoments, EqualOpenCvMomentsExactly) {
  std::mt19937 rng(7);
  for (const cv::Size size : {cv::Size(1, 1), cv::Size(17, 5), cv::Size(63, 4), cv::Size(64, 3), cv::Size(65, 6),
                              cv::Size(129, 2), cv::Size(320, 240), cv::Size(333, 257)}) {
    cv::Mat1b mask(size);
    cv::randu(mask, 0, 2);
    mask = mask * 200;  // nonzero counts as 1, whatever its value
    cv::circle(mask, {size.width / 2, size.height / 2}, size.width / 3, 255, -1);
    // A view into a larger image (rows not contiguous) as well as the whole.
    cv::Mat1b frame = cv::Mat1b::zeros(size.height + 4, size.width + 6);
    mask.copyTo(frame(cv::Rect(3, 2, size.width, size.height)));
    for (const cv::Mat1b& m : {mask, frame(cv::Rect(3, 2, size.width, size.height))}) {
      const cv::Moments ref = cv::moments(m, true);
      const MaskMoments ours = mask_moments(m);
      EXPECT_EQ(ours.m00, ref.m00) << size;
      EXPECT_EQ(ours.m10, ref.m10) << size;
      EXPECT_EQ(ours.m01, ref.m01) << size;
    }
  }
  EXPECT_EQ(mask_moments(cv::Mat1b::zeros(4, 4)).m00, 0.0);
}

TEST(ColorThreshold, SameMaskAndRegionsAsOpenCvPipeline) {
  // The benchmark baseline must do the same work: identical mask and regions.
  cv::Mat3b img(480, 640);
  cv::randn(img, cv::Scalar(60, 120, 70), cv::Scalar(40, 50, 40));
  draw_disc(img, 200, 200, 40);
  test::OpenCvPipeline ref;
  const int n = ref.run(img);
  const cv::Mat1b ours = threshold_crcgcb(img, ColorThresholds{});
  EXPECT_EQ(cv::countNonZero(ours != ref.mask), 0);
  EXPECT_GT(cv::countNonZero(ours), 5000);
  RegionLabeler labeler;
  EXPECT_EQ(static_cast<int>(labeler.label(ours, 0).size()), n - 1);
}

TEST(RegionLabeler, MinimumAreaIsStrict) {
  cv::Mat1b mask = cv::Mat1b::zeros(20, 20);
  mask(cv::Rect(1, 1, 5, 2)) = 255;    // 10 px
  mask(cv::Rect(5, 10, 11, 1)) = 255;  // 11 px
  RegionLabeler labeler;
  const auto& regions = labeler.label(mask, 10);  // thesis: count > MinRegionArea
  ASSERT_EQ(regions.size(), 1u);
  EXPECT_EQ(regions[0].area, 11);
}

// ---- detection ----

const double kFx = 833.57, kFy = 767.02;

TEST(FruitDetector, WholeFruitCentroidAndDiameter) {
  for (const bool canopy : {false, true}) {
    for (const double r : {12.0, 30.0, 75.0}) {
      cv::Mat3b img = test::background(640, 480);
      const double cx = 301.3, cy = 207.8;
      draw_disc(img, cx, cy, r);
      FruitDetector det(canopy ? DetectorConfig::canopy() : DetectorConfig::thesis(), kFx, kFy);
      const Detections d = det.detect(img);
      ASSERT_EQ(d.fruits.size(), 1u) << r;
      const Fruit& f = d.fruits[0];
      EXPECT_NEAR(f.u, cx, 0.5) << r;
      EXPECT_NEAR(f.v, cy, 0.5) << r;
      EXPECT_NEAR(f.diameter_px, 2 * r, 0.02 * 2 * r) << r << " canopy " << canopy;
      EXPECT_EQ(d.selected, 0);
      EXPECT_TRUE(f.selected);
      EXPECT_GT(f.visible_fraction, 0.95);
      EXPECT_GT(f.confidence, 0.8);
    }
  }
}

TEST(FruitDetector, DepthOfRenderedSpheres200To1200mm) {
  geometry::CameraModel cam =
      geometry::CameraModel::from_thesis(kFx, kFy, std::numbers::pi / 2, 319.5, 239.5, 640, 480);
  const double diameter = 0.0725;
  for (const bool canopy : {false, true}) {
    DetectorConfig cfg = canopy ? DetectorConfig::canopy() : DetectorConfig::thesis();
    cfg.fruit_diameter_m = diameter;
    FruitDetector det(cfg, cam.fx, cam.fy);
    for (double z = 0.2; z <= 1.2001; z += 0.1) {
      cv::Mat3b img = test::background(640, 480);
      test::render_sphere(img, cam, {0.01, -0.005, z}, diameter / 2);
      const Detections d = det.detect(img);
      ASSERT_EQ(d.fruits.size(), 1u) << z;
      // Depth of the sphere's centre along the optical axis.
      EXPECT_NEAR(d.fruits[0].depth_m, z, 0.02 * z) << "z " << z << " canopy " << canopy;
    }
  }
}

// A leaf (a rotated ellipse) hiding `share` of a disc.
cv::Mat3b occluded_fruit(double cx, double cy, double r, double* hidden) {
  cv::Mat3b img = test::background(640, 480);
  draw_disc(img, cx, cy, r);
  // A leaf lying across the lower right of the fruit, 0.75 r from its centre,
  // long axis across the radius: hides 30 %, leaving a concave cut.
  const double d = 0.75 * r / std::sqrt(2.0);
  cv::ellipse(img, cv::Point2d(cx + d, cy + d), cv::Size2d(1.1 * r, 0.5 * r), -45, 0, 360,
              cv::Scalar(kLeaf[0], kLeaf[1], kLeaf[2]), -1, cv::LINE_8);
  *hidden = 1.0 - test::visible_share(img, cx, cy, r);
  return img;
}

TEST(FruitDetector, DiameterSurvivesThirtyPercentOcclusion) {
  const double r = 60, cx = 320, cy = 240;
  double hidden = 0;
  const cv::Mat3b img = occluded_fruit(cx, cy, r, &hidden);
  ASSERT_NEAR(hidden, 0.30, 0.03);
  FruitDetector canopy(DetectorConfig::canopy(), kFx, kFy);
  const Detections d = canopy.detect(img);
  ASSERT_EQ(d.fruits.size(), 1u);
  EXPECT_NEAR(d.fruits[0].diameter_px, 2 * r, 0.05 * 2 * r);
  EXPECT_NEAR(d.fruits[0].u, cx, 3.0);
  EXPECT_NEAR(d.fruits[0].v, cy, 3.0);
  EXPECT_LT(d.fruits[0].visible_fraction, 0.85);
  // The area-based diameter of the thesis underestimates by about sqrt(0.7).
  FruitDetector thesis(DetectorConfig::thesis(), kFx, kFy);
  const Detections t = thesis.detect(img);
  ASSERT_EQ(t.fruits.size(), 1u);
  EXPECT_LT(t.fruits[0].diameter_px, 0.9 * 2 * r);
}

TEST(FruitDetector, StraightLeafEdgeIsNotFruitEdge) {
  // A leaf edge cutting a chord off the fruit: straight, so on the convex hull.
  const double r = 50, cx = 300, cy = 250;
  cv::Mat3b img = test::background(640, 480);
  draw_disc(img, cx, cy, r);
  img(cv::Rect(0, static_cast<int>(cy + 0.3 * r), 640, 480 - static_cast<int>(cy + 0.3 * r))) = kLeaf;
  FruitDetector det(DetectorConfig::canopy(), kFx, kFy);
  const Detections d = det.detect(img);
  ASSERT_EQ(d.fruits.size(), 1u);
  EXPECT_NEAR(d.fruits[0].diameter_px, 2 * r, 0.05 * 2 * r);
  EXPECT_NEAR(d.fruits[0].v, cy, 3.0);
}

TEST(FruitDetector, FruitCutByImageBorderKeepsItsDiameter) {
  const double r = 50;
  cv::Mat3b img = test::background(640, 480);
  draw_disc(img, 20, 240, r);  // 30 px of it outside the image
  FruitDetector det(DetectorConfig::canopy(), kFx, kFy);
  const Detections d = det.detect(img);
  ASSERT_EQ(d.fruits.size(), 1u);
  EXPECT_NEAR(d.fruits[0].diameter_px, 2 * r, 0.05 * 2 * r);
}

TEST(FruitDetector, TwoTouchingFruitAreTwo) {
  for (const double gap : {-3.0, -10.0, -20.0}) {  // touching and overlapping by up to 20 % of a diameter
    cv::Mat3b img = test::background(640, 480);
    const double r1 = 45, r2 = 38;
    draw_disc(img, 250, 240, r1);
    draw_disc(img, 250 + r1 + r2 + gap, 250, r2);
    FruitDetector canopy(DetectorConfig::canopy(), kFx, kFy);
    const Detections d = canopy.detect(img);
    ASSERT_EQ(d.fruits.size(), 2u) << gap;
    std::vector<double> diameters{d.fruits[0].diameter_px, d.fruits[1].diameter_px};
    std::sort(diameters.begin(), diameters.end());
    EXPECT_NEAR(diameters[0], 2 * r2, 0.06 * 2 * r2) << gap;
    EXPECT_NEAR(diameters[1], 2 * r1, 0.06 * 2 * r1) << gap;
    FruitDetector thesis(DetectorConfig::thesis(), kFx, kFy);
    EXPECT_EQ(thesis.detect(img).fruits.size(), 1u);  // the thesis method merges them
  }
}

TEST(FruitDetector, OneFruitIsNotSplit) {
  cv::Mat3b img = test::background(640, 480);
  cv::ellipse(img, cv::Point(320, 240), cv::Size(60, 50), 20, 0, 360, cv::Scalar(30, 140, 230), -1);
  FruitDetector det(DetectorConfig::canopy(), kFx, kFy);
  EXPECT_EQ(det.detect(img).fruits.size(), 1u);
}

TEST(FruitDetector, LeafAcrossOneFruitDoesNotSplitIt) {
  // A leaf across the lower half (as in the full-tree scenario) leaves a disc
  // and a crescent joined at one side; the distance-transform ridge of the
  // crescent has several peaks, which used to split it into small fragments
  // whose small diameters put them 2-3 times too deep.
  const double r = 40, cx = 320, cy = 240;
  for (const double angle : {0.0, 10.0, -15.0}) {
    cv::Mat3b img = test::background(640, 480);
    draw_disc(img, cx, cy, r);
    cv::ellipse(img, cv::Point2d(cx + 0.45 * r, cy + 0.25 * r), cv::Size2d(1.1 * r, 0.14 * r), angle, 0, 360,
                cv::Scalar(kLeaf[0], kLeaf[1], kLeaf[2]), -1, cv::LINE_8);
    FruitDetector det(DetectorConfig::canopy(), kFx, kFy);
    const Detections d = det.detect(img);
    ASSERT_EQ(d.fruits.size(), 1u) << angle;
    EXPECT_NEAR(d.fruits[0].diameter_px, 2 * r, 0.05 * 2 * r) << angle;
    EXPECT_NEAR(d.fruits[0].u, cx, 2.0) << angle;
    EXPECT_NEAR(d.fruits[0].v, cy, 2.0) << angle;
  }
}

// Canopy mode without the fragment steps (the detector before them).
DetectorConfig without_fragment_steps() {
  DetectorConfig c = DetectorConfig::canopy();
  c.merge_fragments = false;
  c.peel_to_circle = false;
  return c;
}

void draw_leaf_stripe(cv::Mat3b& img, cv::Point2d a, cv::Point2d b, int width) {
  cv::line(img, a, b, cv::Scalar(kLeaf[0], kLeaf[1], kLeaf[2]), width, cv::LINE_8);
}

TEST(FruitDetector, LeafStripeAcrossFruitGivesOneDetection) {
  // The full-tree scenario: a leaf lying across a fruit cuts its mask into
  // two regions; each alone has a small diameter and lands 2-3 times too deep.
  for (const double r : {18.0, 40.0}) {
    for (const double angle_deg : {0.0, 35.0, 80.0}) {
      for (const double shift : {0.0, 0.3}) {
        cv::Mat3b img = test::background(640, 480);
        const double cx = 300.4, cy = 211.7;
        draw_disc(img, cx, cy, r);
        const double a = angle_deg * std::numbers::pi / 180, nx = -std::sin(a), ny = std::cos(a);
        const cv::Point2d mid(cx + shift * r * nx, cy + shift * r * ny), dir(std::cos(a), std::sin(a));
        draw_leaf_stripe(img, mid - 2 * r * dir, mid + 2 * r * dir, static_cast<int>(0.3 * r));
        const std::string what =
            "r " + std::to_string(r) + " angle " + std::to_string(angle_deg) + " shift " + std::to_string(shift);
        FruitDetector before(without_fragment_steps(), kFx, kFy);
        EXPECT_GE(before.detect(img).fruits.size(), 2u) << what;
        FruitDetector det(DetectorConfig::canopy(), kFx, kFy);
        const Detections d = det.detect(img);
        ASSERT_EQ(d.fruits.size(), 1u) << what;
        EXPECT_NEAR(d.fruits[0].diameter_px, 2 * r, 0.05 * 2 * r) << what;
        EXPECT_NEAR(d.fruits[0].u, cx, 0.1 * r) << what;
        EXPECT_NEAR(d.fruits[0].v, cy, 0.1 * r) << what;
      }
    }
  }
}

TEST(FruitDetector, FruitInThreeFragmentsGivesOneDetection) {
  // Two leaves across one fruit (about 60 % of it visible).
  for (const double r : {20.0, 40.0}) {
    cv::Mat3b img = test::background(640, 480);
    const double cx = 320, cy = 240;
    draw_disc(img, cx, cy, r);
    draw_leaf_stripe(img, {cx - 2 * r, cy - 0.35 * r}, {cx + 2 * r, cy - 0.15 * r}, static_cast<int>(0.3 * r));
    draw_leaf_stripe(img, {cx - 0.2 * r, cy - 2 * r}, {cx + 0.3 * r, cy + 2 * r}, static_cast<int>(0.3 * r));
    FruitDetector before(without_fragment_steps(), kFx, kFy);
    EXPECT_GE(before.detect(img).fruits.size(), 3u) << r;
    FruitDetector det(DetectorConfig::canopy(), kFx, kFy);
    const Detections d = det.detect(img);
    ASSERT_EQ(d.fruits.size(), 1u) << r;
    EXPECT_NEAR(d.fruits[0].diameter_px, 2 * r, 0.06 * 2 * r) << r;
  }
}

TEST(FruitDetector, SliverOfAFruitBehindIsCutOff) {
  // A fruit with the visible crescent of one behind it attached. Before,
  // the region was not split (one distance-transform peak), its hull took
  // in the crescent's tips and the shape tests rejected it: no fruit at all.
  const double r = 40, cx = 300, cy = 240;
  cv::Mat3b img = test::background(640, 480);
  draw_disc(img, cx + 30, cy - 45, r);               // behind
  draw_disc(img, cx + 40, cy - 55, 0.8 * r, kLeaf);  // a leaf hides most of it
  draw_disc(img, cx, cy, r);                         // in front
  const auto front_found = [&](const Detections& d) {
    return std::any_of(d.fruits.begin(), d.fruits.end(), [&](const Fruit& f) {
      return std::hypot(f.u - cx, f.v - cy) < 2.0 && std::fabs(f.diameter_px - 2 * r) < 0.05 * 2 * r;
    });
  };
  FruitDetector before(without_fragment_steps(), kFx, kFy);
  EXPECT_FALSE(front_found(before.detect(img)));
  FruitDetector det(DetectorConfig::canopy(), kFx, kFy);
  const Detections d = det.detect(img);
  EXPECT_TRUE(front_found(d));
  // The crescent goes on alone; its outline is the fruit behind's.
  ASSERT_EQ(d.fruits.size(), 2u);
  for (const Fruit& f : d.fruits) EXPECT_NEAR(f.diameter_px, 2 * r, 0.05 * 2 * r);
}

TEST(FruitDetector, HalvesOfTwoFruitAreNotMerged) {
  // The outer halves of two fruit (inner halves behind a leaf, sky around):
  // two fruit, each with its own circle.
  cv::Mat3b img(480, 640, test::kSky);
  draw_disc(img, 280, 240, 28);
  draw_disc(img, 360, 240, 28);
  img(cv::Rect(280, 200, 81, 81)) = kLeaf;
  img(cv::Rect(300, 226, 40, 28)) = test::kSky;
  FruitDetector det(DetectorConfig::canopy(), kFx, kFy);
  const Detections d = det.detect(img);
  ASSERT_EQ(d.fruits.size(), 2u);
  for (const Fruit& f : d.fruits) EXPECT_NEAR(f.diameter_px, 56, 0.08 * 56);
}

TEST(FruitDetector, ShadedSideOfASunlitFruitPassesTheThesisThresholds) {
  // Lambertian shading as in the simulator's tree scene (sun [-0.6, -0.5,
  // 0.4], ambient 0.45): the dark side is still fruit-coloured (Cr about 36
  // at ambient alone), so the whole disc is found.
  const double r = 40, cx = 320, cy = 240;
  cv::Mat3b img = test::background(640, 480);
  const cv::Vec3d sun = cv::normalize(cv::Vec3d(-0.6, -0.5, 0.4));
  for (int y = 0; y < img.rows; ++y)
    for (int x = 0; x < img.cols; ++x) {
      const double dx = (x - cx) / r, dy = (y - cy) / r, d2 = dx * dx + dy * dy;
      if (d2 > 1) continue;
      const cv::Vec3d n(dx, dy, -std::sqrt(1 - d2));  // towards the camera
      const double light = 0.45 + 0.55 * std::max(0.0, n.dot(sun));
      for (int k = 0; k < 3; ++k) img(y, x)[k] = cv::saturate_cast<uchar>(kOrange[k] * light);
    }
  for (const bool canopy : {false, true}) {
    FruitDetector det(canopy ? DetectorConfig::canopy() : DetectorConfig::thesis(), kFx, kFy);
    const Detections d = det.detect(img);
    ASSERT_EQ(d.fruits.size(), 1u);
    EXPECT_NEAR(d.fruits[0].diameter_px, 2 * r, 0.03 * 2 * r) << canopy;
  }
}

TEST(FruitDetector, HolesAreFilled) {
  cv::Mat3b img = test::background(640, 480);
  draw_disc(img, 320, 240, 50);
  draw_disc(img, 305, 225, 10, cv::Vec3b(250, 250, 250));  // specular highlight
  DetectorConfig cfg = DetectorConfig::thesis();
  FruitDetector plain(cfg, kFx, kFy);
  cfg.fill_holes = true;
  FruitDetector filled(cfg, kFx, kFy);
  const double full_area = std::numbers::pi * 50 * 50;
  EXPECT_LT(plain.detect(img).fruits.at(0).area_px, full_area - 250);
  EXPECT_NEAR(filled.detect(img).fruits.at(0).area_px, full_area, 0.01 * full_area);
}

TEST(FruitDetector, OpeningRemovesThinAttachments) {
  cv::Mat3b img = test::background(640, 480);
  draw_disc(img, 320, 240, 40);
  cv::line(img, {360, 240}, {450, 240}, cv::Scalar(30, 140, 230), 1);  // a 1-px orange twig
  DetectorConfig cfg = DetectorConfig::thesis();
  FruitDetector plain(cfg, kFx, kFy);
  cfg.open_radius_px = 1;
  FruitDetector opened(cfg, kFx, kFy);
  EXPECT_GT(plain.detect(img).fruits.at(0).diameter_x_px, 120);
  EXPECT_NEAR(opened.detect(img).fruits.at(0).diameter_x_px, 81, 2);
}

TEST(FruitDetector, ShapesThatAreNotFruitAreRejected) {
  cv::Mat3b img = test::background(640, 480);
  cv::rectangle(img, cv::Rect(100, 100, 200, 12), cv::Scalar(30, 140, 230), -1);  // orange stick
  // An L-shaped orange patch (a label, a crate edge): not convex.
  cv::rectangle(img, cv::Rect(400, 300, 100, 20), cv::Scalar(30, 140, 230), -1);
  cv::rectangle(img, cv::Rect(400, 300, 20, 100), cv::Scalar(30, 140, 230), -1);
  draw_disc(img, 320, 380, 30);
  DetectorConfig cfg = DetectorConfig::thesis();
  FruitDetector thesis(cfg, kFx, kFy);
  EXPECT_EQ(thesis.detect(img).fruits.size(), 3u);
  cfg.reject_shapes = true;
  FruitDetector strict(cfg, kFx, kFy);
  const Detections d = strict.detect(img);
  ASSERT_EQ(d.fruits.size(), 1u);
  EXPECT_NEAR(d.fruits[0].u, 320, 0.5);
}

TEST(FruitDetector, SelectionCostOfAppendixB1) {
  // 320x240 image as in the thesis: cost = Kr (320 / r - 1) + Kd Z[mm].
  cv::Mat3b img = test::background(320, 240);
  draw_disc(img, 80, 120, 30);   // big and near
  draw_disc(img, 240, 120, 15);  // small and far
  FruitDetector det(DetectorConfig::thesis(), kFx, kFy);
  const Detections d = det.detect(img);
  ASSERT_EQ(d.fruits.size(), 2u);
  for (const Fruit& f : d.fruits) {
    const double r = std::sqrt(f.area_px / std::numbers::pi);
    const double z_mm = (kFx + kFy) * 72.5 / (2 * 2 * r);
    EXPECT_NEAR(f.depth_m * 1000, z_mm, 1e-6);
    EXPECT_NEAR(f.cost, 1.0 * (320 / r - 1) + 0.025 * z_mm, 1e-6);
  }
  EXPECT_EQ(d.selected, 0);
  EXPECT_LT(d.fruits[0].u, 160);
  // The same scene at twice the resolution costs the same (normalised), so it
  // does not depend on image size; depth is the same fruit, so cost is equal.
  cv::Mat3b big = test::background(640, 480);
  draw_disc(big, 160, 240, 60);
  FruitDetector det2(DetectorConfig::thesis(), 2 * kFx, 2 * kFy);
  const Detections d2 = det2.detect(big);
  ASSERT_EQ(d2.fruits.size(), 1u);
  EXPECT_NEAR(d2.fruits[0].cost, d.fruits[0].cost, 0.02 * d.fruits[0].cost);
}

TEST(FruitDetector, EmptyImageHasNoTarget) {
  FruitDetector det(DetectorConfig::canopy(), kFx, kFy);
  const Detections d = det.detect(test::background(64, 48));
  EXPECT_TRUE(d.fruits.empty());
  EXPECT_EQ(d.selected, -1);
}

TEST(DetectorConfig, FromYaml) {
  auto doc = config::Document::load_string("mode: thesis\ncr_min: 30\nmin_area_px: 20\n");
  const DetectorConfig c = DetectorConfig::from_yaml(doc.root());
  doc.check_unused();
  EXPECT_FALSE(c.circle_fit);
  EXPECT_FALSE(c.split_touching);
  EXPECT_EQ(c.thresholds.cr_min, 30);
  EXPECT_EQ(c.thresholds.cr_max, 90);
  EXPECT_EQ(c.min_area_px, 20);
  EXPECT_FALSE(c.merge_fragments);
  EXPECT_FALSE(c.peel_to_circle);
  auto canopy = config::Document::load_string("{}");
  EXPECT_TRUE(DetectorConfig::from_yaml(canopy.root()).circle_fit);
  EXPECT_TRUE(DetectorConfig::from_yaml(canopy.root()).merge_fragments);
  EXPECT_TRUE(DetectorConfig::from_yaml(canopy.root()).peel_to_circle);

  auto bad = config::Document::load_string("mode: magic\n");
  EXPECT_THROW(DetectorConfig::from_yaml(bad.root()), config::Error);
  auto inverted = config::Document::load_string("cg_min: 10\ncg_max: 5\n");
  EXPECT_THROW(DetectorConfig::from_yaml(inverted.root()), config::Error);
  auto typo = config::Document::load_string("circle_fitt: true\n");
  DetectorConfig::from_yaml(typo.root());
  EXPECT_THROW(typo.check_unused(), config::Error);
}

}  // namespace
}  // namespace harvest::vision

namespace harvest::vision {
namespace {

// A leaf lying on the fruit from its side (an upright ellipse centred half a radius off the centre, 0.6 r by 0.6 r
// half axes) bites 35 % out of it: the piece's solidity is 0.66, under min_solidity (0.75), while its remaining rim
// lies on one circle. Canopy mode keeps it (min_solidity_fitted 0.6) at its true centre and size; with the fitted
// threshold at 0.75, as before the key, it is dropped.
TEST(FruitDetector, AFruitWithALeafBitingIntoItsSideIsKept) {
  const double r = 50, cx = 320, cy = 240;
  cv::Mat3b img = test::background(640, 480);
  draw_disc(img, cx, cy, r);
  cv::ellipse(img, cv::Point2d(cx + 0.5 * r, cy), cv::Size2d(0.6 * r, 0.6 * r), 0, 0, 360,
              cv::Scalar(kLeaf[0], kLeaf[1], kLeaf[2]), -1, cv::LINE_8);
  ASSERT_NEAR(test::visible_share(img, cx, cy, r), 0.65, 0.02);
  DetectorConfig cfg = DetectorConfig::canopy();
  FruitDetector det(cfg, kFx, kFy);
  const Detections d = det.detect(img);
  ASSERT_EQ(d.fruits.size(), 1u);
  EXPECT_TRUE(d.fruits[0].circle_fitted);
  EXPECT_LT(d.fruits[0].solidity, 0.7);
  EXPECT_NEAR(d.fruits[0].diameter_px, 2 * r, 0.03 * 2 * r);
  EXPECT_NEAR(d.fruits[0].u, cx, 2.0);
  EXPECT_NEAR(d.fruits[0].v, cy, 2.0);
  cfg.min_solidity_fitted = 0.75;
  EXPECT_TRUE(FruitDetector(cfg, kFx, kFy).detect(img).fruits.empty());
}

}  // namespace
}  // namespace harvest::vision
