// Scoring detections against annotated boxes (a CSV per image set, as
// published fruit data sets come): IoU, one-to-one matching, precision and
// recall. Used by harvest-detect --evaluate (docs/perception.md).
#pragma once

#include <algorithm>
#include <filesystem>
#include <string>
#include <utility>
#include <vector>

#include "vision/fruit_detector.hpp"

namespace harvest::vision {

struct BoxF {
  double x1, y1, x2, y2;  // pixel corners
  // Share of the fruit's silhouette that is visible (rendered frames know it,
  // docs/perception.md "Rendered training frames"; annotated photos: 1).
  double visible = 1.0;
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

// A fruit less visible than this is neither missed nor found: a detection on
// it does not count, and no detection on it is no miss (as an unboxed fruit
// in a photo would be, were it boxed).
inline constexpr double kScoredVisible = 0.5;

// One image's tallies from match_boxes' result.
EvalCounts score_matches(const std::vector<int>& match, const std::vector<BoxF>& boxes);

// Annotations of a CSV "image,img_w,img_h,x1,y1,x2,y2[,visible]" (header line
// first), grouped by image in file order. Throws std::runtime_error naming the
// file and line.
std::vector<std::pair<std::string, std::vector<BoxF>>> read_boxes_csv(const std::filesystem::path& csv);

}  // namespace harvest::vision
