#include "vision/learned_detector.hpp"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <iterator>
#include <numbers>
#include <opencv2/imgproc.hpp>
#include <stdexcept>

#include "vision/fruit_detector.hpp"

namespace harvest::vision {

namespace {

std::runtime_error model_error(const std::filesystem::path& file, const std::string& what) {
  return std::runtime_error("learned detector model " + file.string() + ": " + what);
}

float at(const cv::Mat& maps, int c, int y, int x) { return maps.ptr<float>(0, c, y)[x]; }

double sigmoid(double x) { return 1.0 / (1.0 + std::exp(-x)); }

// Two detections of one fruit: centres nearer than `within` of the larger of the two radii.
bool same_fruit(const Fruit& a, const Fruit& b, double within) {
  return std::hypot(a.u - b.u, a.v - b.v) < within * 0.5 * std::max(a.diameter_px, b.diameter_px);
}

// A fruit's size in the frame's pixels, from its x and y diameters: the mean diameter, the disc's area, the box.
void set_size(Fruit& f, double diameter_x, double diameter_y) {
  f.diameter_x_px = diameter_x;
  f.diameter_y_px = diameter_y;
  f.diameter_px = 0.5 * (diameter_x + diameter_y);
  f.area_px = std::numbers::pi * 0.25 * diameter_x * diameter_y;
  f.bbox = cv::Rect(cv::Point(cvRound(f.u - 0.5 * diameter_x), cvRound(f.v - 0.5 * diameter_y)),
                    cv::Size(cvRound(diameter_x), cvRound(diameter_y)));
}

}  // namespace

LearnedDetector::LearnedDetector(const LearnedConfig& config) : config_(config) {
  const auto& file = config_.model;
  std::error_code ec;
  if (!std::filesystem::is_regular_file(file, ec)) throw model_error(file, "no such file");
  {
    std::ifstream in(file, std::ios::binary);
    model_bytes_.assign(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
  }
  try {
    net_for(64);
  } catch (const cv::Exception& e) {
    throw model_error(file, std::string("not a model OpenCV can load (") + e.err + ")");
  }
  // One thread: the same sums in the same order every run, so a replayed log
  // gives byte-identical detections (and one core is what a camera gets).
  cv::setNumThreads(1);
  cv::Mat maps;
  try {
    maps = forward(cv::Mat3b(64, 64, cv::Vec3b(0, 0, 0)));
  } catch (const cv::Exception& e) {
    throw model_error(file, std::string("fails on a 64x64 image (") + e.err + ")");
  }
  if (maps.dims != 4 || maps.size[0] != 1 || maps.size[1] != 3 || maps.size[2] != 64 / kStride ||
      maps.size[3] != 64 / kStride) {
    std::string shape;
    for (int i = 0; i < maps.dims; ++i) {
      if (i > 0) shape += 'x';
      shape += std::to_string(maps.size[i]);
    }
    throw model_error(file, "wrong output shape " + shape + " for a 64x64 image, expected 1x3x16x16");
  }
}

cv::dnn::Net& LearnedDetector::net_for(int width) {
  // One network per input width: OpenCV re-allocates a network's layers whenever the input shape changes, which
  // cost more than a pass at twice input_width itself when the passes alternate (87 against 58 ms on 1280x960).
  auto it = nets_.find(width);
  if (it != nets_.end()) return it->second;
  cv::dnn::Net net = cv::dnn::readNetFromONNX(model_bytes_.data(), model_bytes_.size());
  if (net.empty()) throw model_error(config_.model, "not a model OpenCV can load (empty network)");
  net.setPreferableBackend(cv::dnn::DNN_BACKEND_OPENCV);
  net.setPreferableTarget(cv::dnn::DNN_TARGET_CPU);
  return nets_.emplace(width, std::move(net)).first->second;
}

cv::Mat LearnedDetector::forward(const cv::Mat3b& bgr) {
  // RGB scaled to [-1, 1], as tools/train_detector.py normalise().
  const cv::Mat blob = cv::dnn::blobFromImage(bgr, 1.0 / 127.5, cv::Size(), cv::Scalar(127.5, 127.5, 127.5), true);
  cv::dnn::Net& net = net_for(bgr.cols);
  net.setInput(blob);
  return net.forward().clone();
}

std::vector<Fruit> LearnedDetector::decode(const cv::Mat& maps) const {
  const int h = maps.size[2], w = maps.size[3];
  cv::Mat1f heat(h, w);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) heat(y, x) = static_cast<float>(sigmoid(at(maps, 0, y, x)));
  // With score_visible the confidence is sqrt(peak x visible fraction) <= sqrt(peak): a peak under
  // threshold^2 cannot reach the threshold.
  const double floor = config_.score_visible ? config_.threshold * config_.threshold : config_.threshold;
  std::vector<Fruit> out;
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      const float p = heat(y, x);
      if (p < floor) continue;
      bool peak = true;  // a 3x3 maximum (ties keep both, as max_pool == value does)
      for (int dy = -1; dy <= 1 && peak; ++dy)
        for (int dx = -1; dx <= 1; ++dx) {
          const int yy = y + dy, xx = x + dx;
          if (yy >= 0 && yy < h && xx >= 0 && xx < w && heat(yy, xx) > p) {
            peak = false;
            break;
          }
        }
      if (!peak) continue;
      // Sub-cell centre: heat-weighted mean of the 3x3 neighbourhood.
      double sw = 0, su = 0, sv = 0;
      for (int yy = std::max(y - 1, 0); yy <= std::min(y + 1, h - 1); ++yy)
        for (int xx = std::max(x - 1, 0); xx <= std::min(x + 1, w - 1); ++xx) {
          sw += heat(yy, xx);
          su += heat(yy, xx) * xx;
          sv += heat(yy, xx) * yy;
        }
      Fruit f;
      f.u = (su / sw + 0.5) * kStride;
      f.v = (sv / sw + 0.5) * kStride;
      f.diameter_px = kDiameterScale * std::exp(static_cast<double>(at(maps, 1, y, x)));
      f.confidence = p;
      // Visible fraction: mean mask probability over the cells of the fruit's disc.
      const double r = 0.5 * f.diameter_px / kStride;
      double in = 0, n = 0;
      for (int yy = std::max(0, int(std::floor(y - r))); yy <= std::min(h - 1, int(std::ceil(y + r))); ++yy)
        for (int xx = std::max(0, int(std::floor(x - r))); xx <= std::min(w - 1, int(std::ceil(x + r))); ++xx)
          if ((xx - x) * (xx - x) + (yy - y) * (yy - y) <= r * r) {
            in += sigmoid(at(maps, 2, yy, xx));
            n += 1;
          }
      f.visible_fraction = n > 0 ? in / n : 0.0;
      if (config_.score_visible) {
        f.confidence = std::sqrt(p * f.visible_fraction);
        if (f.confidence < config_.threshold) continue;
      }
      out.push_back(f);
    }
  // A large fruit, wider than the net's receptive field, can peak more than
  // once. Two fruit centres closer than ~0.9 of the larger radius do not occur
  // among the 930 pairs of boxed fruit in the DeepFruits photos (a fruit that
  // far behind another is mostly hidden), so a weaker peak that close to a
  // kept one is the same fruit. Ties go by position: the order is total.
  std::stable_sort(out.begin(), out.end(), [](const Fruit& a, const Fruit& b) { return a.confidence > b.confidence; });
  if (config_.merge_within > 0) {
    std::vector<Fruit> kept;
    for (const Fruit& f : out) {
      const bool same =
          std::any_of(kept.begin(), kept.end(), [&](const Fruit& k) { return same_fruit(k, f, config_.merge_within); });
      if (!same) kept.push_back(f);
    }
    out = std::move(kept);
  }
  return out;
}

std::vector<Fruit> LearnedDetector::detect(const cv::Mat3b& bgr) {
  std::vector<Fruit> fruits = detect_at(bgr, config_.input_width);
  if (bgr.cols <= 0) return fruits;
  measure_large_again(bgr, fruits);
  add_small_from_finer(bgr, fruits);
  return fruits;
}

void LearnedDetector::add_small_from_finer(const cv::Mat3b& bgr, std::vector<Fruit>& fruits) {
  // A frame far wider than input_width (a whole tree, a canopy from above) shows far fruit a few pixels wide at
  // that scale: the frame at twice the width (and twice again while it is still that much wider) finds them.
  // Only what the first pass could not: small at input_width, and not a fruit found already (merge_within, as in
  // decode, its default when that merge is off). Never beyond twice the frame's own width (finer_above under 1).
  if (config_.finer_above <= 0.0) return;
  const double to_first = static_cast<double>(config_.input_width) / bgr.cols;
  const double same = config_.merge_within > 0.0 ? config_.merge_within : learned_keys::merge_within.fallback;
  for (int coarse = config_.input_width; bgr.cols > config_.finer_above * coarse && coarse < bgr.cols; coarse *= 2) {
    for (const Fruit& f : detect_at(bgr, 2 * coarse)) {
      if (f.diameter_px * to_first >= config_.finer_below || f.confidence < config_.finer_threshold) continue;
      const bool found =
          std::any_of(fruits.begin(), fruits.end(), [&](const Fruit& k) { return same_fruit(k, f, same); });
      if (!found) fruits.push_back(f);
    }
  }
}

void LearnedDetector::measure_large_again(const cv::Mat3b& bgr, std::vector<Fruit>& fruits) {
  // A fruit beyond the sizes the network learnt reads small (near the camera
  // in the hand: depth from size up to 17 % too far): measured again on the
  // frame at half the scale, and half again while still too large, its
  // diameter is the coarser pass's. Centre, confidence and visible fraction
  // stay the finer pass's.
  if (config_.rescale_above <= 0.0) return;
  for (int width = config_.input_width / 2; width >= 8 * kStride; width /= 2) {
    // Too large at the scale the last pass ran at (twice this one).
    const double limit = config_.rescale_above * bgr.cols / (2.0 * width);
    std::vector<Fruit*> large;
    for (Fruit& f : fruits)
      if (f.diameter_px > limit) large.push_back(&f);
    if (large.empty()) break;
    const std::vector<Fruit> coarse = detect_at(bgr, width);
    for (Fruit* f : large) {
      // The coarse pass's fruit nearest this one's centre, within its radius.
      const Fruit* best = nullptr;
      double best_d = 0.5 * f->diameter_px;
      for (const Fruit& c : coarse) {
        const double d = std::hypot(c.u - f->u, c.v - f->v);
        if (d < best_d) {
          best_d = d;
          best = &c;
        }
      }
      if (best) set_size(*f, best->diameter_x_px, best->diameter_y_px);
    }
  }
}

std::vector<Fruit> LearnedDetector::detect_at(const cv::Mat3b& bgr, int width) {
  // Scale to the training width; both sides a multiple of the stride.
  const double s = static_cast<double>(width) / bgr.cols;
  const int w = std::max(kStride, width / kStride * kStride);
  const int h = std::max(kStride, static_cast<int>(std::lround(bgr.rows * s)) / kStride * kStride);
  cv::Mat3b in;
  cv::resize(bgr, in, cv::Size(w, h), 0, 0, cv::INTER_LINEAR);
  std::vector<Fruit> fruits = decode(forward(in));
  const double sx = static_cast<double>(bgr.cols) / w, sy = static_cast<double>(bgr.rows) / h;
  for (Fruit& f : fruits) {
    f.u *= sx;
    f.v *= sy;
    set_size(f, f.diameter_px * sx, f.diameter_px * sy);
    f.roundness = 1.0;
    f.solidity = 1.0;
  }
  return fruits;
}

}  // namespace harvest::vision
