// The thesis detection core (CrCgCb threshold + 4-connected regions with
// area, centroid, bounding box) on a 640x480 frame: ours against the obvious
// OpenCV pipeline producing the same mask, and the whole detector per mode.
#include <benchmark/benchmark.h>

#include <opencv2/imgproc.hpp>
#include <random>

#include "../../unit/vision/opencv_reference.hpp"
#include "vision/fruit_detector.hpp"
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

}  // namespace

BENCHMARK_MAIN();
