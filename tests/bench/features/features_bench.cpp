// Our Shi-Tomasi detector and pyramidal Lucas-Kanade against OpenCV's
// goodFeaturesToTrack and calcOpticalFlowPyrLK on 640x480 frames, and the
// desired <-> current matcher. Names BM_<job>_<impl>: `tools/harvest bench`
// prints ours / theirs per job and args; counter `target_ratio` is the
// largest ratio we accept, `target_ms` an absolute target.
#include <benchmark/benchmark.h>

#include <cmath>
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

void BM_ShiTomasi_Ours(benchmark::State& st) {
  const auto& fr = frames();
  for (auto _ : st) benchmark::DoNotOptimize(f::detect_corners(fr.a, corner_params()));
  st.counters["target_ratio"] = 1.0;
}
BENCHMARK(BM_ShiTomasi_Ours)->Unit(benchmark::kMillisecond);

void BM_ShiTomasi_OpenCV(benchmark::State& st) {
  const auto& fr = frames();
  const auto p = corner_params();
  std::vector<cv::Point2f> out;
  for (auto _ : st) {
    cv::goodFeaturesToTrack(fr.a, out, p.max_corners, p.quality_level, p.min_distance, cv::noArray(), p.window, false);
    benchmark::DoNotOptimize(out);
  }
}
BENCHMARK(BM_ShiTomasi_OpenCV)->Unit(benchmark::kMillisecond);

// Pyramid construction of the new frame plus tracking st.range(0) points,
// window st.range(1), three levels, epsilon 0.1 px (thesis) as in the node.
void BM_PyrLK_Ours(benchmark::State& st) {
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
  st.counters["target_ratio"] = 1.0;
}
BENCHMARK(BM_PyrLK_Ours)->Args({100, 7})->Args({200, 7})->Args({200, 21})->Unit(benchmark::kMillisecond);

void BM_PyrLK_OpenCV(benchmark::State& st) {
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
BENCHMARK(BM_PyrLK_OpenCV)->Args({100, 7})->Args({200, 7})->Args({200, 21})->Unit(benchmark::kMillisecond);

// Desired <-> current matching over an approach: 60 frames at 30 Hz (2 s)
// of the camera-in-hand closing on a textured sticker (scale 0.50 -> 0.68,
// turning 0.2 rad, drifting), sigma 1 noise. Arg 1: as the feature tracker
// runs (the first frame detected with ORB, the others followed from the
// previous homography, step 4 of matcher.hpp), per frame on average.
// Arg 0: every frame detected afresh (the cost of the first frame, or of one
// after the target was lost). Both also report their accuracy: verified
// matches (inliers) per frame and the homography transfer RMS against the
// true one (desired -> current, over a 40 px grid of the image), mean and
// worst over the frames.
struct Approach {
  cv::Mat1b desired;
  std::vector<cv::Mat1b> frames;
  std::vector<cv::Matx33d> truth;  // desired px -> current px
  Approach() {
    const cv::Mat1b tex = ft::sticker_texture(800, 4);
    const cv::Matx33d Hd(0.7, 0, 40, 0, 0.7, 0, 0, 0, 1);
    desired = ft::render_plane(tex, Hd, kSize);
    for (int k = 0; k < 60; ++k) {
      const double t = k / 59.0, sc = 0.50 + 0.18 * t, a = 0.2 * (1 - t);
      const cv::Matx33d H(sc * std::cos(a), -sc * std::sin(a), 80 - 30 * t, sc * std::sin(a), sc * std::cos(a),
                          10 + 15 * t, 1e-5 * (1 - t), 0, 1);
      frames.push_back(ft::render_plane(tex, H, kSize, 90, 1.0, static_cast<uint64_t>(k + 1)));
      truth.push_back(H * Hd.inv());
    }
  }
};

double transfer_rms(const cv::Matx33d& G, const cv::Matx33d& truth) {
  double sum = 0;
  int n = 0;
  for (int y = 20; y < kSize.height; y += 40)
    for (int x = 20; x < kSize.width; x += 40) {
      const cv::Vec3d a = G * cv::Vec3d(x, y, 1), b = truth * cv::Vec3d(x, y, 1);
      sum += std::pow(a[0] / a[2] - b[0] / b[2], 2) + std::pow(a[1] / a[2] - b[1] / b[2], 2);
      ++n;
    }
  return std::sqrt(sum / n);
}
const Approach& approach() {
  static const Approach a;
  return a;
}

void BM_Match_Ours(benchmark::State& st) {
  const auto& ap = approach();
  f::MatcherParams p;
  p.track = st.range(0) != 0;
  f::DesiredImageMatcher m(p);
  m.set_desired(ap.desired);
  std::size_t k = 0, ok = 0, tracked = 0;
  double inliers = 0, rms = 0, worst = 0;
  for (auto _ : st) {
    if (k > 0 && k % ap.frames.size() == 0) m.reset_tracking();  // a new approach
    const std::size_t i = k++ % ap.frames.size();
    const auto r = m.match(ap.frames[i]);
    st.PauseTiming();
    ok += r.ok();
    tracked += r.tracked;
    inliers += r.num_inliers;
    const double e = r.ok() ? transfer_rms(r.G, ap.truth[i]) : 1e3;
    rms += e;
    worst = std::max(worst, e);
    st.ResumeTiming();
  }
  const auto n = static_cast<double>(k);
  st.counters["ok"] = static_cast<double>(ok) / n;
  st.counters["tracked"] = static_cast<double>(tracked) / n;
  st.counters["inliers"] = inliers / n;
  st.counters["rms_px"] = rms / n;
  st.counters["worst_rms_px"] = worst;
  st.counters["target_ms"] = 5.0;
}
BENCHMARK(BM_Match_Ours)->Arg(0)->Arg(1)->Unit(benchmark::kMillisecond);

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
