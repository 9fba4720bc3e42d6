// Homography from point correspondences, robust to outliers, and its
// decomposition into rotation, scaled translation and normal (thesis eq.
// 2-17, 2-18, appendix C): ours (lib/geometry) against OpenCV (findHomography
// RANSAC + decomposeHomographyMat + filterHomographyDecompByVisibleRefpoints)
// and ViSP (vpHomography::ransac + computeDisplacement), on the same scenes:
// a plane seen from two poses, 0.5 px noise, a quarter gross outliers, the
// same 2 px threshold and 0.995 confidence. Names BM_<job>_<impl>: `tools/harvest bench`
// prints ours / theirs per job; `target_ratio` is the largest ratio we accept.
#include <benchmark/benchmark.h>
#include <visp3/vision/vpHomography.h>

#include <Eigen/Dense>
#include <map>
#include <opencv2/calib3d.hpp>
#include <opencv2/core/eigen.hpp>
#include <opencv2/core/utility.hpp>
#include <random>

#include "geometry/homography.hpp"

namespace g = harvest::geometry;
using Eigen::Matrix3d;
using Eigen::Vector3d;

namespace {

constexpr double kThresholdPx = 2.0, kConfidence = 0.995, kNoisePx = 0.5;
constexpr int kScenes = 64;

struct Scene {
  g::Points2 ref, cur;  // pixels
  std::vector<cv::Point2f> cv_ref, cv_cur;
  std::vector<double> xb, yb, xa, ya;  // normalised coordinates (ViSP: a = current, b = reference)
};

const Matrix3d& intrinsics() {
  static const Matrix3d A = g::intrinsics(500, 480, M_PI / 2, 320, 240);
  return A;
}

std::vector<Scene> make_scenes(int n) {
  std::mt19937_64 rng(static_cast<uint64_t>(n) * 7919);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  std::normal_distribution<double> noise(0.0, kNoisePx);
  const Matrix3d& A = intrinsics();
  const Matrix3d Ainv = A.inverse();
  const int outliers = n / 4;
  std::vector<Scene> out;
  while (static_cast<int>(out.size()) < kScenes) {
    const Matrix3d R = g::rotation_from_vector(Vector3d(u(rng), u(rng), u(rng)) * 0.25);
    const Vector3d t = Vector3d(u(rng), u(rng), u(rng)) * 0.2;
    const Vector3d nrm = Vector3d(0.2 * u(rng), 0.2 * u(rng), 1.0).normalized();
    const double d = 1.0 + 0.3 * u(rng);
    Scene s;
    while (static_cast<int>(s.ref.size()) < n) {
      const Vector3d ray(0.4 * u(rng), 0.3 * u(rng), 1.0);
      const Vector3d X = ray * (d / nrm.dot(ray));
      const Vector3d Xc = R * X + t;
      if (Xc.z() < 0.1) continue;
      Eigen::Vector2d p = (A * X).hnormalized(), q = (A * Xc).hnormalized();
      if (static_cast<int>(s.ref.size()) < outliers) {
        q = Eigen::Vector2d(320 + 300 * u(rng), 240 + 220 * u(rng));  // gross outlier
      } else {
        q += Eigen::Vector2d(noise(rng), noise(rng));
      }
      s.ref.push_back(p);
      s.cur.push_back(q);
    }
    for (int i = 0; i < n; ++i) {
      s.cv_ref.emplace_back(static_cast<float>(s.ref[i].x()), static_cast<float>(s.ref[i].y()));
      s.cv_cur.emplace_back(static_cast<float>(s.cur[i].x()), static_cast<float>(s.cur[i].y()));
      const Vector3d mb = Ainv * s.ref[i].homogeneous(), ma = Ainv * s.cur[i].homogeneous();
      s.xb.push_back(mb.x());
      s.yb.push_back(mb.y());
      s.xa.push_back(ma.x());
      s.ya.push_back(ma.y());
    }
    out.push_back(std::move(s));
  }
  return out;
}

const std::vector<Scene>& scenes(int n) {
  static std::map<int, std::vector<Scene>> cache;
  auto it = cache.find(n);
  if (it == cache.end()) it = cache.emplace(n, make_scenes(n)).first;
  return it->second;
}

void BM_Homography_Ours(benchmark::State& st) {
  const auto& sc = scenes(static_cast<int>(st.range(0)));
  const Matrix3d& A = intrinsics();
  g::RansacParams rp;
  rp.threshold_px = kThresholdPx;
  rp.confidence = kConfidence;
  std::size_t k = 0, solved = 0;
  for (auto _ : st) {
    const Scene& s = sc[k++ % sc.size()];
    const auto fit = g::fit_homography_robust(s.ref, s.cur, rp);
    if (!fit.ok()) continue;
    g::Points2 in_ref, in_cur;
    for (std::size_t i = 0; i < s.ref.size(); ++i)
      if (fit.inliers[i]) {
        in_ref.push_back(s.ref[i]);
        in_cur.push_back(s.cur[i]);
      }
    const auto m_ref = g::normalise(A, in_ref), m_cur = g::normalise(A, in_cur);
    const auto H = g::euclidean_homography(fit.G, A, A, m_ref);
    if (!H) continue;
    const auto dec = g::decompose_homography(*H, m_ref, m_cur);
    benchmark::DoNotOptimize(dec);
    solved += dec.status == g::Status::kOk || dec.status == g::Status::kAmbiguous;
  }
  st.counters["solved"] = static_cast<double>(solved) / static_cast<double>(st.iterations());
  st.counters["target_ratio"] = 1.0;
}

void BM_Homography_OpenCV(benchmark::State& st) {
  const auto& sc = scenes(static_cast<int>(st.range(0)));
  cv::Mat K;
  cv::eigen2cv(intrinsics(), K);
  std::size_t k = 0, solved = 0;
  for (auto _ : st) {
    const Scene& s = sc[k++ % sc.size()];
    cv::Mat mask;
    const cv::Mat G = cv::findHomography(s.cv_ref, s.cv_cur, cv::RANSAC, kThresholdPx, mask, 2000, kConfidence);
    if (G.empty()) continue;
    std::vector<cv::Mat> Rs, ts, ns;
    cv::decomposeHomographyMat(G, K, Rs, ts, ns);
    std::vector<int> good;
    cv::filterHomographyDecompByVisibleRefpoints(Rs, ns, s.cv_ref, s.cv_cur, good, mask);
    benchmark::DoNotOptimize(good);
    solved += !good.empty();
  }
  st.counters["solved"] = static_cast<double>(solved) / static_cast<double>(st.iterations());
}

void BM_Homography_ViSP(benchmark::State& st) {
  const auto& sc = scenes(static_cast<int>(st.range(0)));
  const double threshold = kThresholdPx / intrinsics()(0, 0);  // ViSP works in normalised coordinates
  std::size_t k = 0, solved = 0;
  for (auto _ : st) {
    const Scene& s = sc[k++ % sc.size()];
    vpHomography aHb;
    std::vector<bool> inliers;
    double residual = 0;
    const auto consensus = static_cast<unsigned>(std::max<std::size_t>(4, s.xb.size() * 6 / 10));
    bool ok = false;
    try {
      ok = vpHomography::ransac(s.xb, s.yb, s.xa, s.ya, aHb, inliers, residual, consensus, threshold, true);
    } catch (const vpException&) {
      ok = false;
    }
    if (!ok) continue;
    vpRotationMatrix R;
    vpTranslationVector t;
    vpColVector n;
    aHb.computeDisplacement(R, t, n);
    benchmark::DoNotOptimize(R);
    ++solved;
  }
  st.counters["solved"] = static_cast<double>(solved) / static_cast<double>(st.iterations());
}

BENCHMARK(BM_Homography_Ours)->Arg(8)->Arg(100)->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_Homography_OpenCV)->Arg(8)->Arg(100)->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_Homography_ViSP)->Arg(8)->Arg(100)->Unit(benchmark::kMicrosecond);

}  // namespace

int main(int argc, char** argv) {
  cv::setNumThreads(1);  // ours is single-threaded: compare CPU time on one thread
  benchmark::Initialize(&argc, argv);
  if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1;
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return 0;
}
