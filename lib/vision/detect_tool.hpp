// harvest-detect: the fruit detector on image files, one JSON line per image
// (docs/perception.md). Logic here, argument parsing in processes/detect.
#pragma once

#include <algorithm>
#include <filesystem>
#include <iosfwd>
#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "vision/fruit_detector.hpp"

namespace harvest::vision {

struct DetectToolOptions {
  std::string config_file;             // detector node configuration (optional)
  std::vector<std::string> overrides;  // --set KEY=VALUE
  std::filesystem::path overlay_dir;   // empty: no overlays
  std::vector<std::string> images;
  std::filesystem::path evaluate_csv;  // boxes to score against (evaluation mode); empty: off
  std::filesystem::path images_dir;    // where the CSV's images are; default <csv folder>/images
};

// ---- evaluation against annotated boxes ----

struct BoxF {
  double x1, y1, x2, y2;  // pixel corners
  double area() const { return std::max(0.0, x2 - x1) * std::max(0.0, y2 - y1); }
};
double iou(const BoxF& a, const BoxF& b);

// One-to-one matching of detections to annotated boxes. A pair may match if
// the detection's centre lies inside the box or their IoU is at least
// `min_iou`; pairs are taken greedily, best first (centre inside, then IoU).
// Returns, per detection, the index of its box or -1.
struct DetectionBox {
  double u, v;  // centre
  BoxF box;
};
std::vector<int> match_boxes(const std::vector<DetectionBox>& detections, const std::vector<BoxF>& boxes,
                             double min_iou = 0.3);

// The box a fruit stands for: its region's bounding box, or the fitted
// circle's square when the outline was fitted (the region is then cut by an
// occluder and its box too small).
DetectionBox detection_box(const Fruit& f);

struct EvalCounts {
  int images = 0, boxes = 0, detections = 0, true_positives = 0;
  double precision() const { return detections ? static_cast<double>(true_positives) / detections : 0.0; }
  double recall() const { return boxes ? static_cast<double>(true_positives) / boxes : 0.0; }
};

// Annotations of a CSV "image,img_w,img_h,x1,y1,x2,y2" (header line first),
// grouped by image in file order. Throws std::runtime_error naming the file and line.
std::vector<std::pair<std::string, std::vector<BoxF>>> read_boxes_csv(const std::filesystem::path& csv);

// {"image": PATH, "width": W, "height": H, "fruits": [{"u", "v", "diameter_px", "depth_m", "confidence", "selected"}]}
std::string detections_json(const std::string& image, int width, int height, const Detections& d);

// The image with each fruit's outline, centre, index and depth drawn on it
// (the selected fruit in red, the others in cyan).
cv::Mat draw_overlay(const cv::Mat3b& image, const Detections& d);

// Evaluation mode (options.evaluate_csv set): one JSON line per annotated
// image {"image", "width", "height", "boxes", "fruits", "true_positives"},
// then {"summary": {"images", "boxes", "detections", "true_positives",
// "precision", "recall"}}. Overlays then also show the annotated boxes
// (green) and mark unmatched detections. Same exit codes as below.
int run_evaluation(const DetectToolOptions& options, std::ostream& out, std::ostream& err);

// Returns the exit code: 0 all images processed, 1 some could not be read or
// written (each named on `err`), 2 bad configuration or options.
int run_detect_tool(const DetectToolOptions& options, std::ostream& out, std::ostream& err);

}  // namespace harvest::vision
