// Learned detector mode: the committed ONNX model loads in OpenCV dnn, gives
// the PyTorch output on the same input, detects rendered fruit where they
// are, repeats itself exactly, and a bad model file is refused at start with
// an error naming it.
#include "vision/learned_detector.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cstring>
#include <fstream>
#include <opencv2/imgcodecs.hpp>

#include "config/config.hpp"
#include "synthetic_scene.hpp"
#include "test_support.hpp"
#include "vision/fruit_detector.hpp"

namespace ht = harvest::testing;

namespace harvest::vision {
namespace {

const char* kModel = "config/vision/models/fruit_net.onnx";
const char* kData = "tests/unit/vision/data/";
constexpr double kFx = 833.57, kFy = 767.02;  // config/cameras/fixed.yaml at 640x480

LearnedConfig model(const std::filesystem::path& file) {
  LearnedConfig c;
  c.model = file;
  return c;
}

std::string load_error(const std::filesystem::path& file) {
  try {
    LearnedDetector d(model(file));
  } catch (const std::exception& e) {
    return e.what();
  }
  return "";
}

// A leafy frame with shaded oranges (light from the upper left) at known places.
struct Truth {
  double u, v, d;
};
cv::Mat3b orchard_frame(const std::vector<Truth>& fruits, int width = 640, int height = 480) {
  cv::Mat3b img(height, width);
  cv::RNG rng(19);
  rng.fill(img, cv::RNG::UNIFORM, cv::Scalar(20, 70, 30), cv::Scalar(70, 150, 90));
  cv::GaussianBlur(img, img, {7, 7}, 2);
  for (const Truth& f : fruits) {
    const double r = f.d / 2;
    for (int y = std::max(0, int(f.v - r)); y < std::min(height, int(f.v + r) + 1); ++y)
      for (int x = std::max(0, int(f.u - r)); x < std::min(width, int(f.u + r) + 1); ++x) {
        const double dx = (x - f.u) / r, dy = (y - f.v) / r;
        if (dx * dx + dy * dy > 1) continue;
        const double shade = 0.65 + 0.35 * std::max(0.0, 1 - std::hypot(dx + 0.4, dy + 0.4));
        img(y, x) = cv::Vec3b(cv::saturate_cast<uchar>(20 * shade), cv::saturate_cast<uchar>(140 * shade),
                              cv::saturate_cast<uchar>(250 * shade));
      }
  }
  return img;
}

TEST(LearnedDetector, CommittedModelLoadsAndGivesQuarterResolutionMaps) {
  LearnedDetector det(model(kModel));
  const cv::Mat maps = det.forward(cv::Mat3b(240, 320, cv::Vec3b(50, 100, 60)));
  ASSERT_EQ(maps.dims, 4);
  EXPECT_EQ(maps.size[1], 3);
  EXPECT_EQ(maps.size[2], 60);
  EXPECT_EQ(maps.size[3], 80);
}

// tools/fruit_net_parity.py ran the same ONNX weights in PyTorch on fruit_net_parity.png into `expected`.
void expect_pytorch_parity(const char* model_file, const std::string& expected) {
  const cv::Mat3b img = cv::imread(std::string(kData) + "fruit_net_parity.png", cv::IMREAD_COLOR);
  ASSERT_FALSE(img.empty());
  std::ifstream in(std::string(kData) + expected);
  int n, c, h, w;
  ASSERT_TRUE(in >> n >> c >> h >> w);
  LearnedDetector det(model(model_file));
  const cv::Mat maps = det.forward(img);
  ASSERT_EQ(maps.total(), static_cast<std::size_t>(n) * c * h * w);
  ASSERT_EQ(maps.size[2], h);
  ASSERT_EQ(maps.size[3], w);
  const float* got = maps.ptr<float>();
  double worst = 0;
  for (std::size_t i = 0; i < maps.total(); ++i) {
    double want;
    ASSERT_TRUE(in >> want) << i;
    worst = std::max(worst, std::abs(got[i] - want));
  }
  EXPECT_LT(worst, 1e-4) << model_file;
  // The test can fail: a one-cell shift of the image changes the output far beyond it.
  cv::Mat3b shifted;
  cv::copyMakeBorder(img.colRange(0, img.cols - 4), shifted, 0, 0, 4, 0, cv::BORDER_REPLICATE);
  const cv::Mat other = det.forward(shifted);
  EXPECT_GT(cv::norm(other, maps, cv::NORM_INF), 1e-2) << model_file;
}

TEST(LearnedDetector, OutputEqualsPyTorchWithin1e4) { expect_pytorch_parity(kModel, "fruit_net_parity.txt"); }

// The photo configuration's four-model ensemble (tools/merge_models.py): grouped convolutions, which OpenCV
// must run as PyTorch does; the merge itself checks that the network gives its members' mean.
TEST(LearnedDetector, MergedEnsembleOutputEqualsPyTorchWithin1e4) {
  expect_pytorch_parity("config/vision/models/fruit_net_x4.onnx", "fruit_net_x4_parity.txt");
}

// Fruit at the training scale (55..70 px once the frame is scaled to 320
// wide). The synthetic leaf noise draws weak answers (measured <= 0.35 with
// the committed model) that a threshold of 0.35 or less lets through; the fruit are
// the two most confident detections.
TEST(LearnedDetector, FindsRenderedFruitWithDiameterAndDepth) {
  const std::vector<Truth> truth{{200, 200, 140}, {450, 300, 110}};
  FruitDetector det(DetectorConfig::learned_mode(kModel), kFx, kFy);
  Detections d = det.detect(orchard_frame(truth));
  ASSERT_GE(d.fruits.size(), 2u);
  std::sort(d.fruits.begin(), d.fruits.end(),
            [](const Fruit& a, const Fruit& b) { return a.confidence > b.confidence; });
  EXPECT_GT(d.fruits[1].confidence, 0.4);
  if (d.fruits.size() > 2) {
    EXPECT_LT(d.fruits[2].confidence, 0.4);
  }
  d.fruits.resize(2);
  for (const Truth& t : truth) {
    const Fruit* best = nullptr;
    for (const Fruit& f : d.fruits)
      if (!best || std::hypot(f.u - t.u, f.v - t.v) < std::hypot(best->u - t.u, best->v - t.v)) best = &f;
    ASSERT_NE(best, nullptr);
    EXPECT_LT(std::hypot(best->u - t.u, best->v - t.v), 0.2 * t.d) << t.u << "," << t.v;
    EXPECT_NEAR(best->diameter_px, t.d, 0.3 * t.d) << t.u << "," << t.v;
    EXPECT_NEAR(best->depth_m, 0.5 * (kFx + kFy) * 0.0725 / best->diameter_px, 1e-9);
    EXPECT_GT(best->visible_fraction, 0.3);
  }
  EXPECT_GE(d.selected, 0);
}

// A fruit near the camera in the hand, far wider than the 160 px training crops at the network's scale: the
// diameter map alone reads it small (the field look: 374 px read as 0.83 of true, a depth 17 % too far); measured
// again at half the scale it is within the sizes learnt.
TEST(LearnedDetector, AFruitBeyondTheLearntSizesIsMeasuredAtACoarserScale) {
  LearnedConfig once = model(kModel);
  once.rescale_above = 0;
  // Measured with the committed model (diameter once / rescaled): 300 px 352 / 344, 380 px 394 / 427, 440 px
  // 374 / 461, 500 px 376 / 472 (the synthetic disc reads 5-15 % large at any size).
  for (const double d : {300.0, 380.0, 440.0, 500.0}) {
    const Truth t{330, 250, d};
    const cv::Mat3b img = orchard_frame({t});
    const auto strongest = [](const std::vector<Fruit>& fruits) {
      const Fruit* best = nullptr;
      for (const Fruit& f : fruits)
        if (!best || f.confidence > best->confidence) best = &f;
      return best;
    };
    LearnedDetector det(model(kModel)), plain(once);
    const std::vector<Fruit> twice = det.detect(img), single = plain.detect(img);
    const Fruit* f = strongest(twice);
    const Fruit* g = strongest(single);
    ASSERT_NE(f, nullptr) << d;
    ASSERT_NE(g, nullptr) << d;
    EXPECT_NEAR(f->diameter_px, d, 0.16 * d) << d;
    if (d >= 440) {
      EXPECT_LT(g->diameter_px, 0.86 * d) << d << ": the single pass reads a fruit this large small";
    }
    EXPECT_EQ(f->u, g->u);  // centre and confidence stay the finer pass's
    EXPECT_EQ(f->confidence, g->confidence);
  }
}

// A photo of a whole tree from afar: 2560 px wide, its fruit 120 px there, 15 px once the frame is scaled to 320
// (beneath what the network finds). The finer passes (640 and 1280 wide: 30 and 60 px) find them; a frame 640 wide
// (a camera's) has none. Off (finer_above 0), with finer_below under their size at 320 or finer_threshold over
// their peaks, only the first pass counts.
TEST(LearnedDetector, SmallFruitOfAWideFrameAreFoundByFinerPasses) {
  std::vector<Truth> truth;
  for (int i = 0; i < 4; ++i) truth.push_back({400.0 + 550 * i, 500.0 + 600 * (i % 2), 120});
  const cv::Mat3b wide = orchard_frame(truth, 2560, 1920);
  LearnedConfig off = model(kModel);
  off.finer_above = 0;
  const auto near_truth = [&](const std::vector<Fruit>& fruits) {
    int n = 0;
    for (const Truth& t : truth)
      n += std::any_of(fruits.begin(), fruits.end(), [&](const Fruit& f) {
        return std::hypot(f.u - t.u, f.v - t.v) < 0.3 * t.d && std::abs(f.diameter_px - t.d) < 0.4 * t.d;
      });
    return n;
  };
  const std::vector<Fruit> single = LearnedDetector(off).detect(wide);
  const std::vector<Fruit> finer = LearnedDetector(model(kModel)).detect(wide);
  EXPECT_EQ(near_truth(single), 0);
  EXPECT_EQ(near_truth(finer), 4);
  // Nothing else added by the finer passes on this frame (leaf noise).
  EXPECT_LE(finer.size(), single.size() + truth.size());
  // finer_below 14 px (at 320): the 15 px fruit are not small enough to be the finer passes' to add.
  LearnedConfig strict = model(kModel);
  strict.finer_below = 14;
  EXPECT_EQ(near_truth(LearnedDetector(strict).detect(wide)), 0);
  // Nor with finer_threshold above their peaks.
  LearnedConfig sure = model(kModel);
  sure.finer_threshold = 0.99;
  EXPECT_EQ(near_truth(LearnedDetector(sure).detect(wide)), 0);
  // A camera frame (640 wide, twice input_width) runs once: the same detections with the passes on or off.
  const cv::Mat3b frame = orchard_frame({{200, 200, 140}, {450, 300, 110}});
  const std::vector<Fruit> a = LearnedDetector(model(kModel)).detect(frame), b = LearnedDetector(off).detect(frame);
  ASSERT_EQ(a.size(), b.size());
  for (std::size_t i = 0; i < a.size(); ++i) EXPECT_EQ(a[i].u, b[i].u);
}

// Raw maps (1x3x16x16) by hand: heatmap logits 0 (p 0.5) at the given cells,
// -10 elsewhere, log diameter log(d / 32) (a peak's own if given), mask 0.
cv::Mat hand_maps(const std::vector<std::pair<int, int>>& peaks, const std::vector<float>& logits, double d,
                  const std::vector<double>& peak_d = {}) {
  const int size[] = {1, 3, 16, 16};
  cv::Mat maps(4, size, CV_32F);
  for (int y = 0; y < 16; ++y)
    for (int x = 0; x < 16; ++x) {
      maps.ptr<float>(0, 0, y)[x] = -10;
      maps.ptr<float>(0, 1, y)[x] = static_cast<float>(std::log(d / LearnedDetector::kDiameterScale));
      maps.ptr<float>(0, 2, y)[x] = 0;
    }
  for (std::size_t i = 0; i < peaks.size(); ++i) {
    maps.ptr<float>(0, 0, peaks[i].second)[peaks[i].first] = logits[i];
    if (i < peak_d.size())
      maps.ptr<float>(0, 1, peaks[i].second)[peaks[i].first] =
          static_cast<float>(std::log(peak_d[i] / LearnedDetector::kDiameterScale));
  }
  return maps;
}

// Two peaks of one large fruit are one fruit (the stronger); two fruit side by
// side stay two. Diameter 40 px, radius 20 px, merge_within 0.75: peaks 3
// cells (12 px) apart merge (12 < 15); 4 cells (16 px) apart do not.
TEST(LearnedDetector, AWeakerPeakInsideAStrongerFruitIsTheSameFruit) {
  LearnedDetector det(model(kModel));
  const std::vector<Fruit> one = det.decode(hand_maps({{5, 5}, {8, 5}}, {-0.5f, 1.0f}, 40));
  ASSERT_EQ(one.size(), 1u);
  EXPECT_NEAR(one[0].u, 8.5 * 4, 1e-4);  // the stronger, at its cell centre (neighbours ~0)
  EXPECT_NEAR(one[0].confidence, 1 / (1 + std::exp(-1.0)), 1e-6);
  const std::vector<Fruit> two = det.decode(hand_maps({{5, 5}, {9, 5}}, {-0.5f, 1.0f}, 40));
  ASSERT_EQ(two.size(), 2u);
  EXPECT_GT(two[0].confidence, two[1].confidence);  // strongest first
  EXPECT_NEAR(two[1].u, 5.5 * 4, 1e-4);
  LearnedConfig off = model(kModel);
  off.merge_within = 0;
  EXPECT_EQ(LearnedDetector(off).decode(hand_maps({{5, 5}, {8, 5}}, {-0.5f, 1.0f}, 40)).size(), 2u);
  // The larger radius counts: a weaker 16 px fruit 12 px from a stronger 40 px one is inside it, and so is
  // a weaker 40 px one 12 px from a stronger 16 px one.
  EXPECT_EQ(det.decode(hand_maps({{5, 5}, {8, 5}}, {-0.5f, 1.0f}, 40, {16, 40})).size(), 1u);
  EXPECT_EQ(det.decode(hand_maps({{5, 5}, {8, 5}}, {-0.5f, 1.0f}, 40, {40, 16})).size(), 1u);
}

// score_visible: the confidence is sqrt(peak x visible fraction) and the threshold applies to it. Mask
// logits 0: every disc is half visible, so at threshold 0.35 a peak of 0.31 passes (sqrt(0.155) = 0.394),
// one of 0.18 does not (0.302); without the option only the peak of 0.73 passes.
TEST(LearnedDetector, ScoreVisibleRanksByPeakAndVisibleFraction) {
  const cv::Mat maps = hand_maps({{2, 2}, {12, 2}, {2, 12}}, {1.0f, -0.8f, -1.5f}, 16);
  LearnedConfig plain = model(kModel);
  plain.threshold = 0.35;
  EXPECT_EQ(LearnedDetector(plain).decode(maps).size(), 1u);
  LearnedConfig sv = plain;
  sv.score_visible = true;
  const std::vector<Fruit> f = LearnedDetector(sv).decode(maps);
  ASSERT_EQ(f.size(), 2u);
  const auto sig = [](double x) { return 1 / (1 + std::exp(-x)); };
  EXPECT_NEAR(f[0].visible_fraction, 0.5, 1e-9);
  EXPECT_NEAR(f[0].confidence, std::sqrt(sig(1.0) * 0.5), 1e-6);
  EXPECT_NEAR(f[1].confidence, std::sqrt(sig(-0.8) * 0.5), 1e-6);
  EXPECT_NEAR(f[1].u, 12.5 * 4, 1e-4);
}

TEST(LearnedDetector, NoConfidentFruitOnPlainLeaves) {
  FruitDetector det(DetectorConfig::learned_mode(kModel), kFx, kFy);
  for (const Fruit& f : det.detect(orchard_frame({})).fruits) EXPECT_LT(f.confidence, 0.4) << f.u << "," << f.v;
  DetectorConfig strict = DetectorConfig::learned_mode(kModel);
  strict.learned.threshold = 0.4;
  FruitDetector det2(strict, kFx, kFy);
  EXPECT_TRUE(det2.detect(orchard_frame({})).fruits.empty());
}

// Replay depends on it: two detectors on one frame give the same bytes.
TEST(LearnedDetector, RepeatsItselfExactly) {
  const cv::Mat3b img = orchard_frame({{200, 200, 110}, {450, 300, 80}, {600, 50, 60}});
  FruitDetector a(DetectorConfig::learned_mode(kModel), kFx, kFy);
  FruitDetector b(DetectorConfig::learned_mode(kModel), kFx, kFy);
  const Detections da = a.detect(img), db = b.detect(img), da2 = a.detect(img);
  ASSERT_EQ(da.fruits.size(), db.fruits.size());
  ASSERT_EQ(da.fruits.size(), da2.fruits.size());
  for (std::size_t i = 0; i < da.fruits.size(); ++i)
    for (const auto* o : {&db.fruits[i], &da2.fruits[i]}) {
      EXPECT_EQ(std::memcmp(&da.fruits[i].u, &o->u, sizeof(double)), 0);
      EXPECT_EQ(std::memcmp(&da.fruits[i].v, &o->v, sizeof(double)), 0);
      EXPECT_EQ(std::memcmp(&da.fruits[i].diameter_px, &o->diameter_px, sizeof(double)), 0);
      EXPECT_EQ(std::memcmp(&da.fruits[i].visible_fraction, &o->visible_fraction, sizeof(double)), 0);
    }
}

TEST(LearnedDetector, BadModelFilesAreRefusedNamingTheFile) {
  ht::TempDir tmp;
  const auto missing = tmp / "nothere.onnx";
  std::string e = load_error(missing);
  EXPECT_NE(e.find(missing.string()), std::string::npos) << e;
  EXPECT_NE(e.find("no such file"), std::string::npos) << e;

  const auto corrupt = tmp / "corrupt.onnx";
  {
    std::ifstream good(kModel, std::ios::binary);
    std::string bytes((std::istreambuf_iterator<char>(good)), {});
    ASSERT_GT(bytes.size(), 1000u);
    std::ofstream(corrupt, std::ios::binary) << bytes.substr(0, bytes.size() / 3);  // cut off mid-weights
  }
  e = load_error(corrupt);
  EXPECT_NE(e.find(corrupt.string()), std::string::npos) << e;
  EXPECT_NE(e.find("not a model OpenCV can load"), std::string::npos) << e;

  const auto text = tmp / "text.onnx";
  std::ofstream(text) << "this is not a network\n";
  e = load_error(text);
  EXPECT_NE(e.find(text.string()), std::string::npos) << e;

  const std::string wrong = std::string(kData) + "wrong_shape.onnx";
  e = load_error(wrong);
  EXPECT_NE(e.find(wrong), std::string::npos) << e;
  EXPECT_NE(e.find("wrong output shape 1x2x64x64"), std::string::npos) << e;
}

// The configuration loads the model, so --check-config and a start fail on a bad file (exit 2).
TEST(LearnedDetector, ConfigurationRefusesBadModelNamingKeyAndFile) {
  ht::TempDir tmp;
  const auto yaml = tmp / "detector.yaml";
  std::ofstream(yaml) << "mode: learned\nmodel: missing.onnx\n";
  auto doc = config::Document::load_file(yaml);
  try {
    DetectorConfig::from_yaml(doc.root());
    FAIL() << "accepted a missing model";
  } catch (const config::Error& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("model"), std::string::npos) << what;
    EXPECT_NE(what.find((tmp / "missing.onnx").string()), std::string::npos) << what;
  }
  std::ofstream(yaml) << "mode: learned\nmodel: " << std::filesystem::absolute(kModel).string()
                      << "\ninput_width: 320\nthreshold: 0.3\n";
  auto good = config::Document::load_file(yaml);
  const DetectorConfig c = DetectorConfig::from_yaml(good.root());
  EXPECT_EQ(c.mode, DetectorConfig::Mode::learned);
  EXPECT_EQ(c.learned.input_width, 320);
}

}  // namespace
}  // namespace harvest::vision
