// Learned fruit detector (detector mode "learned", docs/perception.md): a
// small fully convolutional network (tools/train_detector.py) run through
// OpenCV dnn from an ONNX file. It maps the image, scaled to a fixed width,
// to three maps at 1/4 resolution: fruit-centre heatmap, log fruit diameter
// and fruit mask. Fruits are the heatmap's 3x3 maxima above a threshold; a
// weaker maximum inside a stronger fruit's disc is the same fruit.
#pragma once

#include <filesystem>
#include <map>
#include <opencv2/core.hpp>
#include <opencv2/dnn.hpp>
#include <string>
#include <vector>

#include "config/key.hpp"

namespace harvest::vision {

struct Fruit;

// The detector's keys of mode learned.
namespace learned_keys {
using config::Key;
inline constexpr Key<config::Path> model{"model", "config/vision/models/fruit_net.onnx", {}, "",
                                         "mode learned: the ONNX network (loaded at start)"};
inline constexpr Key<int> input_width{"input_width", 320, {16, 4096}, "px",
                                      "mode learned: frames are scaled to this width (the training scale)"};
// Chosen by tools/train_detector.py --folds for the committed model (best F1 over the folds' held-out photos).
inline constexpr Key<double> threshold{"threshold", 0.35, {0.01, 1.0}, "",
                                       "mode learned: heatmap peaks below this are not fruit"};
inline constexpr Key<double> merge_within{
    "merge_within",
    0.75,
    {0.0, 2.0},
    "radii",
    "mode learned: a weaker peak this close to a stronger fruit's centre, in the larger of the two radii, is the "
    "same fruit (0: off)"};
inline constexpr Key<bool> score_visible{
    "score_visible", false, {}, "",
    "mode learned: a fruit's confidence, compared with threshold, is sqrt(peak x visible fraction) instead of the "
    "peak (docs/perception.md: thresholds 0.4-0.45)"};
// The training crops are 160 px square at the training scale: a fruit much wider than ~110 px there is beyond what
// the diameter map learnt (measured on the field look, camera in hand: 339 px of 640 read 0.96 of true, 374 px 0.83,
// 393 px 0.69), and a depth from it is too far.
inline constexpr Key<double> rescale_above{
    "rescale_above", 110.0, {0.0, 4096.0}, "px",
    "mode learned: a fruit wider than this at the network's input scale is measured again on the frame at half that "
    "scale, where it lies within the sizes the network learnt (0: never)"};
// A frame much wider than input_width (a photo of a whole tree or canopy) shows a far-off fruit a few pixels wide
// at that scale, below what the network finds (training fruit are 10-365 px there).
inline constexpr Key<double> finer_above{
    "finer_above", 2.0, {0.0, 64.0}, "",
    "mode learned: a frame more than this many times input_width wide is also run at twice input_width (and twice "
    "again while the frame is this many times wider), for fruit too small for the coarser pass (0: never; camera "
    "frames up to twice input_width never are)"};
inline constexpr Key<double> finer_below{
    "finer_below", 24.0, {0.0, 4096.0}, "px",
    "mode learned: ... a fruit of a finer pass counts if it is narrower than this at input_width's scale (too small "
    "for the first pass) and not found already (within merge_within)"};
inline constexpr Key<double> finer_threshold{
    "finer_threshold", 0.6, {0.01, 1.0}, "",
    "mode learned: ... and its peak is at least this (at the first pass's threshold they added 279 detections for "
    "15 fruit on photos upscaled to 2000 px, docs/perception.md)"};
}  // namespace learned_keys

struct LearnedConfig {
  std::filesystem::path model;  // ONNX file
  int input_width = learned_keys::input_width.fallback;
  double threshold = learned_keys::threshold.fallback;
  double merge_within = learned_keys::merge_within.fallback;
  bool score_visible = learned_keys::score_visible.fallback;
  double rescale_above = learned_keys::rescale_above.fallback;
  double finer_above = learned_keys::finer_above.fallback;
  double finer_below = learned_keys::finer_below.fallback;
  double finer_threshold = learned_keys::finer_threshold.fallback;
};

class LearnedDetector {
 public:
  static constexpr int kStride = 4;             // output cell size in input pixels
  static constexpr double kDiameterScale = 32;  // diameter channel is log(d / kDiameterScale)

  // Loads and checks the model (one trial forward pass: 3 output maps at 1/4
  // resolution). Throws std::runtime_error naming the file and what is wrong.
  explicit LearnedDetector(const LearnedConfig& config);

  // Fruits in image pixels: centre, diameter_px, bbox, visible_fraction (the
  // mask's share of the fruit's disc) and confidence (the peak). Depth and
  // cost are the caller's (FruitDetector), as for the colour modes.
  std::vector<Fruit> detect(const cv::Mat3b& bgr);

  // Fruits of `bgr` scaled to `width` (a multiple of kStride), in the frame's pixels.
  std::vector<Fruit> detect_at(const cv::Mat3b& bgr, int width);

  // The raw network output (1x3xH/4xW/4) for an input already at the
  // network's size (parity test with PyTorch).
  cv::Mat forward(const cv::Mat3b& bgr);

  // Peaks of raw maps -> fruits in network-input pixels, strongest first.
  std::vector<Fruit> decode(const cv::Mat& maps) const;

 private:
  // rescale_above: fruit too large for the network measured again at coarser scales (their diameter only).
  void measure_large_again(const cv::Mat3b& bgr, std::vector<Fruit>& fruits);
  // finer_above / finer_below: fruit too small for the network at input_width, from finer passes.
  void add_small_from_finer(const cv::Mat3b& bgr, std::vector<Fruit>& fruits);

  cv::dnn::Net& net_for(int width);  // the network for inputs this wide (loaded from model_bytes_ once)

  LearnedConfig config_;
  std::vector<char> model_bytes_;       // the ONNX file, read once at start
  std::map<int, cv::dnn::Net> nets_;  // by input width
};

}  // namespace harvest::vision
