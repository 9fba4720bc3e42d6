// harvest-detect: the fruit detector on image files, one JSON line per image
// (docs/perception.md). Logic here, argument parsing in processes/detect.
#pragma once

#include <filesystem>
#include <iosfwd>
#include <opencv2/core.hpp>
#include <optional>
#include <string>
#include <vector>

#include "vision/box_evaluation.hpp"
#include "vision/fruit_detector.hpp"

namespace harvest::vision {

struct DetectToolOptions {
  std::string config_file;             // detector node configuration (optional)
  std::vector<std::string> overrides;  // --set KEY=VALUE
  std::filesystem::path overlay_dir;   // empty: no overlays
  std::vector<std::string> images;
  std::filesystem::path evaluate_csv;  // boxes to score against (evaluation mode); empty: off
  std::filesystem::path images_dir;    // where the CSV's images are; default <csv folder>/images
  // Cross-validation of mode learned: a CSV "image,model[,threshold]"
  // naming for each image the ONNX model whose training did not see it
  // (paths relative to the CSV's folder) and the threshold chosen without
  // its fold (else detector.threshold); written by tools/train_detector.py
  // --folds. Empty: off.
  std::filesystem::path fold_models;
};

struct FoldModel {
  std::filesystem::path model;
  std::optional<double> threshold;
};

// Per image of a fold-models CSV, its model and threshold. Throws std::runtime_error naming the file and line.
std::vector<std::pair<std::string, FoldModel>> read_fold_models(const std::filesystem::path& csv);

// {"image": PATH, "width": W, "height": H, "fruits": [{"u", "v", "diameter_px", "depth_m", "confidence", "selected"}]}
std::string detections_json(const std::string& image, int width, int height, const Detections& d);

// Evaluation mode (options.evaluate_csv set): one JSON line per annotated
// image {"image", "width", "height", "boxes", "fruits", "true_positives"},
// then {"summary": {"images", "boxes", "detections", "true_positives",
// "precision", "recall", "f1", "centre_error", "diameter_error"}}, the errors
// being medians over matched pairs, relative to the box's mean side. Overlays then also show the annotated boxes
// (green) and mark unmatched detections. Same exit codes as below.
int run_evaluation(const DetectToolOptions& options, std::ostream& out, std::ostream& err);

// Returns the exit code: 0 all images processed, 1 some could not be read or
// written (each named on `err`), 2 bad configuration or options.
int run_detect_tool(const DetectToolOptions& options, std::ostream& out, std::ostream& err);

}  // namespace harvest::vision
