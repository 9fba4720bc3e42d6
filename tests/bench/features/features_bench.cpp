// Our Shi-Tomasi detector and pyramidal Lucas-Kanade against OpenCV's
// goodFeaturesToTrack and calcOpticalFlowPyrLK on 640x480 frames, and the
// desired <-> current matcher. Run: build-*/bench/features_bench
#include <benchmark/benchmark.h>

#include <opencv2/core/utility.hpp>
#include <opencv2/video/tracking.hpp>

#include "features/corners.hpp"
#include "features/lucas_kanade.hpp"
#include "features/matcher.hpp"
#include "synthetic.hpp"

namespace f = harvest::features;
namespace ft = harvest::features::testing;

namespace {

const cv::Size kSize(640, 480);

struct Frames {
  cv::Mat1b a, b;
  std::vector<cv::Point2f> pts;
  Frames() {
    const ft::WaveTexture tex(3);
    a = tex.render(kSize);
    b = tex.render(kSize, 1.7, -2.3);
    f::CornerParams p;
    p.quality_level = 0.01;
    p.max_corners = 200;
    for (const auto& c : f::detect_corners(a, p)) pts.push_back(c.pt);
  }
};
const Frames& frames() {
  static const Frames fr;
  return fr;
}

f::CornerParams corner_params() {
  f::CornerParams p;
  p.window = 7;
  p.min_eigenvalue = 0;
  p.quality_level = 0.01;
  p.min_distance = 10;
  p.max_corners = 200;
  return p;
}

void BM_OursShiTomasi(benchmark::State& st) {
  const auto& fr = frames();
  for (auto _ : st) benchmark::DoNotOptimize(f::detect_corners(fr.a, corner_params()));
}
BENCHMARK(BM_OursShiTomasi)->Unit(benchmark::kMillisecond);

void BM_OpenCVGoodFeaturesToTrack(benchmark::State& st) {
  const auto& fr = frames();
  const auto p = corner_params();
  std::vector<cv::Point2f> out;
  for (auto _ : st) {
    cv::goodFeaturesToTrack(fr.a, out, p.max_corners, p.quality_level, p.min_distance, cv::noArray(), p.window, false);
    benchmark::DoNotOptimize(out);
  }
}
BENCHMARK(BM_OpenCVGoodFeaturesToTrack)->Unit(benchmark::kMillisecond);

// Pyramid construction of the new frame plus tracking st.range(0) points,
// window st.range(1), three levels, epsilon 0.1 px (thesis) as in the node.
void BM_OursPyrLK(benchmark::State& st) {
  const auto& fr = frames();
  const std::vector<cv::Point2f> pts(fr.pts.begin(), fr.pts.begin() + std::min<long>(st.range(0), fr.pts.size()));
  f::LkParams lp;
  lp.window = static_cast<int>(st.range(1));
  const f::Pyramid pa(fr.a, 3);
  for (auto _ : st) {
    const f::Pyramid pb(fr.b, 3);
    benchmark::DoNotOptimize(f::track_lk(pa, pb, pts, lp));
  }
  st.counters["points"] = static_cast<double>(pts.size());
}
BENCHMARK(BM_OursPyrLK)->Args({100, 7})->Args({200, 7})->Args({200, 21})->Unit(benchmark::kMillisecond);

void BM_OpenCVPyrLK(benchmark::State& st) {
  const auto& fr = frames();
  const std::vector<cv::Point2f> pts(fr.pts.begin(), fr.pts.begin() + std::min<long>(st.range(0), fr.pts.size()));
  const int w = static_cast<int>(st.range(1));
  std::vector<cv::Mat> pa;
  cv::buildOpticalFlowPyramid(fr.a, pa, cv::Size(w, w), 2);
  std::vector<cv::Point2f> out;
  std::vector<uint8_t> status;
  std::vector<float> err;
  for (auto _ : st) {
    std::vector<cv::Mat> pb;
    cv::buildOpticalFlowPyramid(fr.b, pb, cv::Size(w, w), 2);
    cv::calcOpticalFlowPyrLK(pa, pb, pts, out, status, err, cv::Size(w, w), 2,
                             cv::TermCriteria(cv::TermCriteria::COUNT | cv::TermCriteria::EPS, 30, 0.1));
    benchmark::DoNotOptimize(out);
  }
  st.counters["points"] = static_cast<double>(pts.size());
}
BENCHMARK(BM_OpenCVPyrLK)->Args({100, 7})->Args({200, 7})->Args({200, 21})->Unit(benchmark::kMillisecond);

void BM_MatchDesiredToCurrent(benchmark::State& st) {
  const cv::Mat1b tex = ft::sticker_texture(800, 4);
  const cv::Matx33d Hd(0.7, 0, 40, 0, 0.7, 0, 0, 0, 1), Hc(0.65, -0.1, 80, 0.1, 0.65, 10, 0, 0, 1);
  f::MatcherParams p;
  p.refine = st.range(0) != 0;
  f::DesiredImageMatcher m(p);
  m.set_desired(ft::render_plane(tex, Hd, kSize));
  const cv::Mat1b cur = ft::render_plane(tex, Hc, kSize, 90, 1.0, 1);
  for (auto _ : st) benchmark::DoNotOptimize(m.match(cur));
}
BENCHMARK(BM_MatchDesiredToCurrent)->Arg(0)->Arg(1)->Unit(benchmark::kMillisecond);

}  // namespace

// Ours is single-threaded: compare with OpenCV on one thread too (its
// worker threads' time would not show in the CPU column).
int main(int argc, char** argv) {
  cv::setNumThreads(1);
  benchmark::Initialize(&argc, argv);
  if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1;
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return 0;
}
