// The thesis detection core (CrCgCb threshold + 4-connected regions with
// area, centroid, bounding box) on a 640x480 frame: ours against the obvious
// OpenCV pipeline producing the same mask, and the whole detector per mode.
#include <benchmark/benchmark.h>

#include <opencv2/imgproc.hpp>
#include <random>

#include "../../unit/vision/opencv_reference.hpp"
#include "vision/bitmask.hpp"
#include "vision/fruit_detector.hpp"
#include "vision/outline_circle.hpp"
#include "vision/region_split.hpp"
#include "vision/segmentation.hpp"

namespace {

using namespace harvest::vision;

// A canopy-like frame: leaf-green noise with twelve oranges, some touching.
cv::Mat3b make_frame() {
  cv::Mat3b img(480, 640);
  cv::theRNG().state = 7;  // the same frame whichever benchmarks run before
  std::mt19937 rng(7);
  cv::randn(img, cv::Scalar(60, 120, 70), cv::Scalar(25, 30, 25));
  std::uniform_real_distribution<double> ux(40, 600), uy(40, 440), ur(12, 40);
  for (int i = 0; i < 12; ++i)
    cv::circle(img, cv::Point(static_cast<int>(ux(rng)), static_cast<int>(uy(rng))), static_cast<int>(ur(rng)),
               cv::Scalar(30, 140, 230), -1);
  return img;
}

void BM_OpenCvPipeline(benchmark::State& state) {
  const cv::Mat3b img = make_frame();
  test::OpenCvPipeline p;
  cv::setNumThreads(1);
  for (auto _ : state) benchmark::DoNotOptimize(p.run(img));
}
BENCHMARK(BM_OpenCvPipeline)->Unit(benchmark::kMicrosecond);

void BM_FusedThresholdAndRuns(benchmark::State& state) {
  const cv::Mat3b img = make_frame();
  cv::Mat1b mask(img.size());
  RegionLabeler labeler;
  const ColorThresholds t;
  for (auto _ : state) {
    threshold_crcgcb(img.data, img.cols, img.rows, img.step, t, mask.data, mask.step);
    benchmark::DoNotOptimize(labeler.label(mask, 0).size());
  }
  state.counters["runs"] = static_cast<double>(labeler.runs().size());
  state.counters["regions"] = static_cast<double>(labeler.regions().size());
  state.counters["fruit_px"] = cv::countNonZero(mask);
}
BENCHMARK(BM_FusedThresholdAndRuns)->Unit(benchmark::kMicrosecond);

void BM_ThresholdOnly(benchmark::State& state) {
  const cv::Mat3b img = make_frame();
  cv::Mat1b mask(img.size());
  const ColorThresholds t;
  for (auto _ : state) {
    threshold_crcgcb(img.data, img.cols, img.rows, img.step, t, mask.data, mask.step);
    benchmark::DoNotOptimize(mask.data);
  }
}
BENCHMARK(BM_ThresholdOnly)->Unit(benchmark::kMicrosecond);

void BM_ThresholdPortable(benchmark::State& state) {
  const cv::Mat3b img = make_frame();
  cv::Mat1b mask(img.size());
  const ColorThresholds t;
  for (auto _ : state) {
    threshold_crcgcb_portable(img.data, img.cols, img.rows, img.step, t, mask.data, mask.step);
    benchmark::DoNotOptimize(mask.data);
  }
}
BENCHMARK(BM_ThresholdPortable)->Unit(benchmark::kMicrosecond);

void BM_DetectorThesisMode(benchmark::State& state) {
  const cv::Mat3b img = make_frame();
  cv::setNumThreads(1);
  FruitDetector det(DetectorConfig::thesis(), 833.57, 767.02);
  for (auto _ : state) benchmark::DoNotOptimize(det.detect(img).fruits.size());
}
BENCHMARK(BM_DetectorThesisMode)->Unit(benchmark::kMicrosecond);

void BM_DetectorCanopyMode(benchmark::State& state) {
  const cv::Mat3b img = make_frame();
  cv::setNumThreads(1);
  FruitDetector det(DetectorConfig::canopy(), 833.57, 767.02);
  for (auto _ : state) benchmark::DoNotOptimize(det.detect(img).fruits.size());
}
BENCHMARK(BM_DetectorCanopyMode)->Unit(benchmark::kMicrosecond);

// A 320x240 frame like the simulated full tree's (the fixed camera binned):
// sky, 30 oranges of 14..22 px radius, many overlapping, and 70 leaves on
// top that cut them into fragments.
cv::Mat3b make_tree_frame() {
  cv::Mat3b img(240, 320, cv::Vec3b(235, 190, 150));
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> ux(0, 320), uy(0, 240), ur(14, 22), ua(0, 180), ul(8, 16);
  for (int i = 0; i < 30; ++i)
    cv::circle(img, cv::Point(static_cast<int>(ux(rng)), static_cast<int>(uy(rng))), static_cast<int>(ur(rng)),
               cv::Scalar(30, 140, 230), -1);
  for (int i = 0; i < 70; ++i) {
    const double length = ul(rng);
    cv::ellipse(img, cv::Point(static_cast<int>(ux(rng)), static_cast<int>(uy(rng))),
                cv::Size(static_cast<int>(length), static_cast<int>(0.4 * length)), ua(rng), 0, 360,
                cv::Scalar(40, 110, 50), -1);
  }
  return img;
}

// ---- the packed mask (bitmask.hpp) against OpenCV on byte masks ----

// The colour mask of frame `which` (0: the 320x240 tree frame, 1: the 640x480 frame).
cv::Mat1b colour_mask(int64_t which) {
  return threshold_crcgcb(which == 0 ? make_tree_frame() : make_frame(), ColorThresholds{});
}

// Erosion by a disc of radius Arg(0) of the 640x480 frame's mask.
void BM_Erode_Ours(benchmark::State& state) {
  BitMask src, dst;
  src.pack(colour_mask(1));
  const StructuringElement disc = StructuringElement::disc(static_cast<int>(state.range(0)));
  BinaryMorphology morph;
  for (auto _ : state) {
    morph.erode(src, disc, dst);
    benchmark::DoNotOptimize(dst.row(0));
  }
  // Radius 1 (a cross of 5 pixels) is OpenCV's cheapest: 0.5-0.67x measured.
  state.counters["target_ratio"] = 0.7;
}
BENCHMARK(BM_Erode_Ours)->Arg(1)->Arg(2)->Arg(5)->Unit(benchmark::kMicrosecond);

void BM_Erode_OpenCV(benchmark::State& state) {
  const cv::Mat1b src = colour_mask(1);
  const int r = static_cast<int>(state.range(0));
  const cv::Mat disc = cv::getStructuringElement(cv::MORPH_ELLIPSE, cv::Size(2 * r + 1, 2 * r + 1));
  cv::setNumThreads(1);
  cv::Mat1b dst;
  for (auto _ : state) {
    cv::erode(src, dst, disc);
    benchmark::DoNotOptimize(dst.data);
  }
}
BENCHMARK(BM_Erode_OpenCV)->Arg(1)->Arg(2)->Arg(5)->Unit(benchmark::kMicrosecond);

// The canopy clean-up: opening with a disc of radius 1, closing with radius 2
// (Arg: 0 the tree frame's mask, 1 the 640x480 frame's).
void BM_OpenClose_Ours(benchmark::State& state) {
  BitMask src, mask;
  src.pack(colour_mask(state.range(0)));
  const StructuringElement open = StructuringElement::disc(1), close = StructuringElement::disc(2);
  BinaryMorphology morph;
  for (auto _ : state) {
    mask = src;
    morph.open(mask, open);
    morph.close(mask, close);
    benchmark::DoNotOptimize(mask.row(0));
  }
  state.counters["target_ratio"] = 0.5;
}
BENCHMARK(BM_OpenClose_Ours)->Arg(0)->Arg(1)->Unit(benchmark::kMicrosecond);

void BM_OpenClose_OpenCV(benchmark::State& state) {
  const cv::Mat1b src = colour_mask(state.range(0));
  const cv::Mat open = cv::getStructuringElement(cv::MORPH_ELLIPSE, cv::Size(3, 3)),
                close = cv::getStructuringElement(cv::MORPH_ELLIPSE, cv::Size(5, 5));
  cv::setNumThreads(1);
  cv::Mat1b mask;
  for (auto _ : state) {
    cv::morphologyEx(src, mask, cv::MORPH_OPEN, open);
    cv::morphologyEx(mask, mask, cv::MORPH_CLOSE, close);
    benchmark::DoNotOptimize(mask.data);
  }
}
BENCHMARK(BM_OpenClose_OpenCV)->Arg(0)->Arg(1)->Unit(benchmark::kMicrosecond);

// The canopy detector's mask stage whole: threshold, opening, closing and
// labelling, on a packed mask against the OpenCV pipeline on bytes.
void BM_CanopyMask_Ours(benchmark::State& state) {
  const cv::Mat3b img = state.range(0) == 0 ? make_tree_frame() : make_frame();
  const StructuringElement open = StructuringElement::disc(1), close = StructuringElement::disc(2);
  BitMask mask;
  BinaryMorphology morph;
  RegionLabeler labeler;
  for (auto _ : state) {
    threshold_crcgcb(img, ColorThresholds{}, mask);
    morph.open(mask, open);
    morph.close(mask, close);
    benchmark::DoNotOptimize(labeler.label(mask, 0).size());
  }
  state.counters["target_ratio"] = 0.5;
}
BENCHMARK(BM_CanopyMask_Ours)->Arg(0)->Arg(1)->Unit(benchmark::kMicrosecond);

void BM_CanopyMask_OpenCV(benchmark::State& state) {
  const cv::Mat3b img = state.range(0) == 0 ? make_tree_frame() : make_frame();
  const cv::Mat open = cv::getStructuringElement(cv::MORPH_ELLIPSE, cv::Size(3, 3)),
                close = cv::getStructuringElement(cv::MORPH_ELLIPSE, cv::Size(5, 5));
  cv::setNumThreads(1);
  test::OpenCvPipeline p;
  cv::Mat labels, stats, centroids;
  for (auto _ : state) {
    p.run(img);
    cv::morphologyEx(p.mask, p.mask, cv::MORPH_OPEN, open);
    cv::morphologyEx(p.mask, p.mask, cv::MORPH_CLOSE, close);
    benchmark::DoNotOptimize(cv::connectedComponentsWithStats(p.mask, labels, stats, centroids, 4, CV_32S));
  }
}
BENCHMARK(BM_CanopyMask_OpenCV)->Arg(0)->Arg(1)->Unit(benchmark::kMicrosecond);

// ---- the splitter's and detector's geometry against OpenCV ----

// A region crop as the splitter gets one: two touching fruit of radius r
// with an empty frame.
cv::Mat1b two_fruit_crop(int r) {
  cv::Mat1b crop = cv::Mat1b::zeros(2 * r + 4, 4 * r);
  cv::circle(crop, {r + 1, r + 2}, r, 255, -1);
  cv::circle(crop, {3 * r - 2, r + 2}, r, 255, -1);
  return crop;
}

// The outline of the crop above (the largest outer contour).
std::vector<cv::Point> crop_outline(int r) {
  std::vector<std::vector<cv::Point>> contours;
  cv::findContours(two_fruit_crop(r), contours, cv::RETR_EXTERNAL, cv::CHAIN_APPROX_NONE);
  return contours.front();
}

void BM_HullArea_Ours(benchmark::State& state) {
  const auto outline = crop_outline(static_cast<int>(state.range(0)));
  for (auto _ : state) benchmark::DoNotOptimize(convex_hull_area(outline));
  state.counters["target_ratio"] = 0.5;
}
BENCHMARK(BM_HullArea_Ours)->Arg(12)->Arg(50)->Unit(benchmark::kMicrosecond);

void BM_HullArea_OpenCV(benchmark::State& state) {
  const auto outline = crop_outline(static_cast<int>(state.range(0)));
  std::vector<cv::Point> hull;
  for (auto _ : state) {
    cv::convexHull(outline, hull);
    benchmark::DoNotOptimize(cv::contourArea(hull));
  }
}
BENCHMARK(BM_HullArea_OpenCV)->Arg(12)->Arg(50)->Unit(benchmark::kMicrosecond);

// Zeroth and first moments of a crop (mask_moments against cv::moments, binary).
void BM_MaskMoments_Ours(benchmark::State& state) {
  const cv::Mat1b crop = two_fruit_crop(static_cast<int>(state.range(0)));
  for (auto _ : state) benchmark::DoNotOptimize(mask_moments(crop).m10);
  state.counters["target_ratio"] = 0.5;
}
BENCHMARK(BM_MaskMoments_Ours)->Arg(12)->Arg(50)->Unit(benchmark::kMicrosecond);

void BM_MaskMoments_OpenCV(benchmark::State& state) {
  const cv::Mat1b crop = two_fruit_crop(static_cast<int>(state.range(0)));
  for (auto _ : state) benchmark::DoNotOptimize(cv::moments(crop, true).m10);
}
BENCHMARK(BM_MaskMoments_OpenCV)->Arg(12)->Arg(50)->Unit(benchmark::kMicrosecond);

// Hole filling of the crop with leaf-shaped holes (fill_holes against
// flooding the outside with cv::floodFill).
cv::Mat1b crop_with_holes(int r) {
  cv::Mat1b crop = two_fruit_crop(r);
  cv::ellipse(crop, {r, r}, {r / 3, r / 8 + 1}, 30, 0, 360, 0, -1);
  cv::ellipse(crop, {3 * r, r + 3}, {r / 4, r / 8 + 1}, 100, 0, 360, 0, -1);
  return crop;
}

void BM_FillHoles_Ours(benchmark::State& state) {
  const cv::Mat1b crop = crop_with_holes(static_cast<int>(state.range(0)));
  cv::Mat1b m;
  for (auto _ : state) {
    crop.copyTo(m);
    fill_holes(m);
    benchmark::DoNotOptimize(m.data);
  }
  state.counters["target_ratio"] = 0.7;
}
BENCHMARK(BM_FillHoles_Ours)->Arg(12)->Arg(50)->Unit(benchmark::kMicrosecond);

void BM_FillHoles_OpenCV(benchmark::State& state) {
  const cv::Mat1b crop = crop_with_holes(static_cast<int>(state.range(0)));
  cv::Mat1b m;
  for (auto _ : state) {
    crop.copyTo(m);
    cv::Mat1b outside = m.clone();
    cv::floodFill(outside, cv::Point(0, 0), cv::Scalar(255));
    m |= ~outside;
    benchmark::DoNotOptimize(m.data);
  }
}
BENCHMARK(BM_FillHoles_OpenCV)->Arg(12)->Arg(50)->Unit(benchmark::kMicrosecond);

// Canopy mode on the tree-like frame, with (1) and without (0) the fragment
// steps (peel_to_circle, merge_fragments).
void BM_DetectorCanopyTreeFrame(benchmark::State& state) {
  const cv::Mat3b img = make_tree_frame();
  cv::setNumThreads(1);
  DetectorConfig cfg = DetectorConfig::canopy();
  cfg.merge_fragments = cfg.peel_to_circle = state.range(0) != 0;
  FruitDetector det(cfg, 833.57 / 2, 767.02 / 2);
  std::size_t fruits = 0;
  for (auto _ : state) benchmark::DoNotOptimize(fruits = det.detect(img).fruits.size());
  state.counters["fruits"] = static_cast<double>(fruits);
}
BENCHMARK(BM_DetectorCanopyTreeFrame)->Arg(0)->Arg(1)->Unit(benchmark::kMicrosecond);

// Mode learned (the committed network) beside thesis mode on the same frames:
// the 320x240 tree frame; a 640x480 frame run at full resolution
// (input_width 640) and scaled to the training width 320 first (the default).
DetectorConfig learned(int input_width) {
  DetectorConfig cfg = DetectorConfig::learned_mode(HARVEST_FRUIT_NET);
  cfg.learned.input_width = input_width;
  return cfg;
}

void BM_ThesisMode320x240(benchmark::State& state) {
  const cv::Mat3b img = make_tree_frame();
  cv::setNumThreads(1);
  FruitDetector det(DetectorConfig::thesis(), 833.57 / 2, 767.02 / 2);
  for (auto _ : state) benchmark::DoNotOptimize(det.detect(img).fruits.size());
}
BENCHMARK(BM_ThesisMode320x240)->Unit(benchmark::kMicrosecond);

void BM_LearnedMode320x240(benchmark::State& state) {
  const cv::Mat3b img = make_tree_frame();
  FruitDetector det(learned(320), 833.57 / 2, 767.02 / 2);
  std::size_t fruits = 0;
  for (auto _ : state) benchmark::DoNotOptimize(fruits = det.detect(img).fruits.size());
  state.counters["fruits"] = static_cast<double>(fruits);
}
BENCHMARK(BM_LearnedMode320x240)->Unit(benchmark::kMicrosecond);

// The photo configuration's merged four-network ensemble (tools/merge_models.py) on the same frame.
void BM_LearnedEnsemble320x240(benchmark::State& state) {
  const cv::Mat3b img = make_tree_frame();
  FruitDetector det(DetectorConfig::learned_mode(HARVEST_FRUIT_NET_X4), 833.57 / 2, 767.02 / 2);
  std::size_t fruits = 0;
  for (auto _ : state) benchmark::DoNotOptimize(fruits = det.detect(img).fruits.size());
  state.counters["fruits"] = static_cast<double>(fruits);
}
BENCHMARK(BM_LearnedEnsemble320x240)->Unit(benchmark::kMicrosecond);

// Arg: the width the network runs at.
void BM_LearnedMode640x480(benchmark::State& state) {
  const cv::Mat3b img = make_frame();
  FruitDetector det(learned(static_cast<int>(state.range(0))), 833.57, 767.02);
  for (auto _ : state) benchmark::DoNotOptimize(det.detect(img).fruits.size());
}
BENCHMARK(BM_LearnedMode640x480)->Arg(320)->Arg(640)->Unit(benchmark::kMicrosecond);

// A wide photo (the 640x480 frame scaled to 1280x960): input_width 320, with the finer pass at 640 (Arg 1,
// finer_above 2, the default) and without (Arg 0). Camera frames up to 640 wide never run it.
void BM_LearnedModeWideFrame(benchmark::State& state) {
  cv::Mat3b img;
  cv::resize(make_frame(), img, cv::Size(1280, 960), 0, 0, cv::INTER_LINEAR);
  DetectorConfig cfg = learned(320);
  if (state.range(0) == 0) cfg.learned.finer_above = 0;
  FruitDetector det(cfg, 2 * 833.57, 2 * 767.02);
  for (auto _ : state) benchmark::DoNotOptimize(det.detect(img).fruits.size());
}
BENCHMARK(BM_LearnedModeWideFrame)->Arg(0)->Arg(1)->Unit(benchmark::kMicrosecond);

}  // namespace

BENCHMARK_MAIN();
